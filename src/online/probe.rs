//! The proximity probe: the newest stretch's nearest earlier positions,
//! within the consistent map's radius, else (a drifting map) within a radius
//! growing with the path in between. Its seed is where growth starts when
//! the shape queries find nothing.

use nalgebra::Vector2;

use super::history::{History, SpatialIndex};
use crate::pipeline::proximity::{radius, seed_of, Near, ProximitySeed, PROBES};

/// Proximity seed of the newest two segments (as the batch proximity
/// seeds), or, for a periodic probe (`segments == false`), of the newest
/// `window` track samples.
pub fn proximity_seed(
    h: &History,
    spatial: &SpatialIndex,
    segments: bool,
    window: usize,
    drift: f64,
) -> Option<ProximitySeed> {
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
    h: &History,
    spatial: &SpatialIndex,
    g0: usize,
    g1: usize,
    drift: f64,
) -> Option<ProximitySeed> {
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
    seed_of([g0, g1], length, &consistent, false).or_else(|| {
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
    })
}
