//! The proximity probe: the newest stretch's nearest earlier positions,
//! within the consistent map's radius, else (a drifting map) within a radius
//! growing with the path in between. Its seed is where growth starts when
//! the shape queries find nothing; on a drifting map, roads near the window
//! that no one similarity fits are still where the network registration
//! looks ([`Probed::Roads`]).

use nalgebra::Vector2;

use super::history::{HistoryView, SpatialIndex};
use crate::pipeline::proximity::{near_target, radius, seed_of, Near, ProximitySeed, PROBES};

/// What a probe found near the newest stretch.
#[derive(Debug, Clone)]
pub enum Probed {
    /// A seed to grow from.
    Seed(ProximitySeed),
    /// On a drifting map, earlier roads near the window (its track samples
    /// `query`; the probes' median nearest sample `target`), but no one
    /// similarity lays the probe points on their nearest points: no start
    /// to grow from, but where the network registration looks.
    Roads {
        /// The window's track samples.
        query: [usize; 2],
        /// The probes' median nearest track sample.
        target: usize,
    },
}

impl Probed {
    /// The seed to grow from, if any.
    pub fn seed(&self) -> Option<&ProximitySeed> {
        match self {
            Probed::Seed(seed) => Some(seed),
            Probed::Roads { .. } => None,
        }
    }

    /// The probed window's track samples.
    pub fn query(&self) -> [usize; 2] {
        match self {
            Probed::Seed(seed) => seed.query,
            Probed::Roads { query, .. } => *query,
        }
    }

    /// The probes' median nearest earlier track sample.
    pub fn target(&self) -> usize {
        match self {
            Probed::Seed(seed) => seed.target,
            Probed::Roads { target, .. } => *target,
        }
    }
}

/// Roads that no one similarity fits count for the registration when the
/// probes' median lies within this fraction of the drifting radius (a
/// seed's own test is 1). Strong drift, seeds 1-40: 349 events of 440 with
/// none, 366 at 0.5, 370 at 1; KITTI 00's ground truth then costs 183.3,
/// 184.8 and 195.7 M worker instructions (7 more registrations, none true,
/// at 1): the stream's 200 000 poses/s rests on about 187 M.
const ROADS_RATIO: f64 = 0.5;

/// The probe of the newest two segments (as the batch proximity seeds), or,
/// for a periodic probe (`segments == false`), of the newest `window` track
/// samples.
pub fn probe_newest(
    h: &HistoryView,
    spatial: &SpatialIndex,
    segments: bool,
    window: usize,
    drift: f64,
) -> Option<Probed> {
    let last = h.xy.len().checked_sub(1)?;
    let nb = h.bounds.len();
    let g0 = if segments && nb >= 3 {
        h.sig_grid[h.bounds[nb - 3]].floor() as usize
    } else {
        last.saturating_sub(window)
    };
    probe(h, spatial, g0, last, drift)
}

/// Cells of the spatial index (64 track grid steps each) the drifting map's
/// probe looks beyond its window at most: its radius stops growing there,
/// so a probe costs the same at any length of history. (8 cells gave the
/// same candidates on KITTI, at more time.)
pub const DRIFT_CELLS: i32 = 4;
/// The consistent map's probe radius is a quarter of its window, within a
/// cell or two; this only bounds a degenerate window.
const CONSISTENT_CELLS: i32 = 64;

/// The probe of track samples `[g0, g1]`, as the batch proximity seeds
/// (`pipeline::proximity`): each probe point's nearest earlier sample (at
/// least the window's own length back along the path) within the
/// consistent map's radius, else (`drift > 0`) the drifting map's.
pub fn probe(
    h: &HistoryView,
    spatial: &SpatialIndex,
    g0: usize,
    g1: usize,
    drift: f64,
) -> Option<Probed> {
    if g1 <= g0 + PROBES {
        return None;
    }
    let length = h.s[g1] - h.s[g0];
    if length <= 0.0 {
        return None;
    }
    let probes: [(Vector2<f64>, f64); PROBES] = std::array::from_fn(|k| {
        let g = g0 + (k * (g1 - g0)) / (PROBES - 1);
        (h.point(g), h.s[g])
    });
    let allowed = |k: usize, t: usize| (h.s[t] - probes[k].1).abs() > length && t < g0;
    let near = |k: usize, found: Option<(f64, usize)>| {
        found.map(|(ratio, t)| Near {
            ratio,
            target: t,
            pair: (h.point(t), probes[k].0),
        })
    };
    let points = probes.map(|p| p.0);
    // The consistent map's radius first (one scan of the cells around the
    // window), then, where that finds nothing, the drifting map's.
    let r = radius(length, 0.0, 0.0);
    let found = spatial.nearest_scaled(h, &points, r, CONSISTENT_CELLS, |_, _| r, allowed);
    let consistent: [Option<Near>; PROBES] = std::array::from_fn(|k| near(k, found[k]));
    if let Some(seed) = seed_of([g0, g1], length, &consistent, false) {
        return Some(Probed::Seed(seed));
    }
    if drift <= 0.0 {
        return None;
    }
    // Every earlier part lies at most the whole path back.
    let found = spatial.nearest_scaled(
        h,
        &points,
        radius(length, drift, h.s[g1]),
        DRIFT_CELLS,
        |k, t| radius(length, drift, (probes[k].1 - h.s[t]).abs()),
        allowed,
    );
    let drifting: [Option<Near>; PROBES] = std::array::from_fn(|k| near(k, found[k]));
    seed_of([g0, g1], length, &drifting, true)
        .map(Probed::Seed)
        .or_else(|| {
            near_target(&drifting, ROADS_RATIO).map(|target| Probed::Roads {
                query: [g0, g1],
                target,
            })
        })
}
