//! Registration of the newest stretch of path onto the map's road network:
//! where a drifted later pass lies on everything driven before, not only on
//! the one earlier pass it is compared with.
//!
//! Pairwise matching (one later window against one earlier window) cannot
//! place a straight that the later pass enters and leaves by other roads
//! than the earlier pass did: along the common straight every slide fits,
//! and the turns at its ends lie on *other* earlier passes (KITTI 00 poses
//! 1553-1645 under strong drift, seed 1: the pairwise candidates slid
//! 40-55 m).
//! Here each window point votes, with every earlier map sample of a
//! compatible road direction, for the rotation and translation that would
//! lay it there (a Hough transform over the similarity); the placement most
//! window points agree on, refined on the map and weighed by the drift
//! prior, is where the turns pin the window along its roads.
//!
//! ```text
//!   theta = axial(psi_map - phi_window)          (direction of travel free)
//!   t     = m - c - R(theta) (p - c)             (about the window centroid c)
//!   vote (theta, t) for window point p; placement = most agreeing points
//! ```
//!
//! The map's first road is a place of its own: a return to where the path
//! began (the commonest loop) enters it from beyond the map's first pose,
//! where the map knows nothing. There a window point counts half
//! (`OpenStart`), the first road's best vote cells are always checked,
//! and its first window length is searched as far as the drift prior
//! reaches.

use std::collections::HashMap;

use nalgebra::Vector2;

use super::drift_path::{self, PathMoments};
use super::history::{CellHash, HistoryView, SpatialIndex};
use super::probe;
use crate::geometry::Similarity2;
use crate::pipeline::proximity::radius;
use crate::score::DriftPrior;
use map::{Block, Map};
use window::{OnMap, Window};

mod map;
mod window;

/// Window points that vote (one bit each of a `u64`).
const POINTS: usize = 48;
/// Rotation bin of the vote.
const ANGLE_BIN: f64 = 3.0 * std::f64::consts::PI / 180.0;
/// A window point lies on the map within this fraction of the window's
/// length (about 2 m on the 80 m windows of KITTI): a road's lanes.
pub const BAND_FRACTION: f64 = 0.025;
/// One window point in this many votes.
const VOTE_EVERY: usize = 2;
/// Vote cells checked as placements, most agreeing points first.
const TOP_CELLS: usize = 8;
/// Vote cells checked per place (within a rotation bin and [`RIVAL_BANDS`]
/// translation cells of each other): the other checked cells are rival
/// places, so the margin weighs one (with all 8 about one peak it was
/// infinite at 29 of 151 placements on strong drift, seeds 1-4, now 9;
/// seeds 1-10: 18 false candidates fewer of 571, one event fewer of 110).
const PER_PLACE: usize = 3;
/// Two placements whose window middles lie more than this many bands (a
/// quarter of the window) apart are two places. Closer, they put the
/// window on the same roads, slid along them: the same loop for the
/// verifier. (At two bands, a slide of 5 m was a rival and the margin of
/// most true placements stayed near 1: strong drift, seeds 1-10, 60 events
/// of 110 against 68.)
pub const RIVAL_BANDS: i32 = 10;
/// Placements refined further, best first.
const TOP_REFINED: usize = 3;
/// Refit rounds of every checked placement, and of the best few.
const ROUNDS: (usize, usize) = (1, 3);

/// Where a placement lays the window.
#[derive(Debug, Clone, Copy)]
pub struct Place {
    /// `history_T_window`: the window's points onto the map (one frame, so
    /// near identity up to drift).
    pub sim: Similarity2,
    /// Map sample the window's middle lands on.
    pub target: usize,
}

/// A placement of the window on the map.
#[derive(Debug, Clone, Copy)]
pub struct Registration {
    /// The best place.
    pub place: Place,
    /// Turning-weighted share of the window points within the band.
    pub support: f64,
    /// Drift-prior factor of the placement.
    pub prior: f64,
    /// The best placement's score (support times the prior's square root)
    /// over the best rival place's (rotated by more than a bin, or the
    /// window's middle moved by more than [`RIVAL_BANDS`] bands, a quarter
    /// of the window): infinite when there is none. A straight window
    /// slides along its road: margin near 1.
    pub margin: f64,
    /// The best rival place, the one the margin is over.
    pub rival: Option<Place>,
}

/// Where the drift allows the window to lie.
#[derive(Debug, Clone, Copy)]
pub struct Bounds {
    /// Largest translation of the window's centroid.
    pub radius: f64,
    /// Largest rotation (radians).
    pub angle: f64,
    /// Map samples at least this much arc length before the window's start
    /// (the window's own neighbourhood excluded).
    pub exclude: f64,
    /// Largest distance between two indexed map samples along a road.
    pub gap: f64,
    /// Growth of the largest translation with the path between the window
    /// and a map sample: a sample `between` back along the path takes the
    /// window within [`radius`]`(length, rate, between)` of it (at most
    /// `radius`), as the drifting probe's own radius does per sample. The
    /// drift cannot have moved the window far from the road it just drove,
    /// so that road slid along by a window length is no place for it.
    pub rate: f64,
}

impl Bounds {
    /// The drift prior's reach for a window of `length` whose earlier part
    /// may lie `between` back along the path: the proximity probes' radius
    /// ([`radius`]) at 1.5 times the prior's position sigma (`position` per
    /// unit of path, the drifting probe's rate), but no farther beyond the
    /// consistent map's radius than the drifting probe looks
    /// ([`probe::DRIFT_CELLS`] cells of `spatial`); two of its heading
    /// sigmas. The gap is `spatial`'s indexing stride of track steps of
    /// `step`.
    ///
    /// Without the probe's limit the reach grew to a quarter of a kilometre
    /// on KITTI's later revisits, and every look-alike corner in it was a
    /// rival: strong drift, seeds 21-40 (never used before), 142 -> 147
    /// events of 220 with the limit, and 186.5 M -> 172.7 M worker
    /// instructions streaming KITTI 00, a saving that now pays for placing
    /// every window (`network`).
    pub fn of_drift(
        prior: &DriftPrior,
        position: f64,
        length: f64,
        between: f64,
        spatial: &SpatialIndex,
        step: f64,
    ) -> Self {
        let ratio = (between / length).sqrt();
        let widest = radius(length, 0.0, 0.0) + probe::DRIFT_CELLS as f64 * spatial.cell();
        Bounds {
            radius: radius(length, 1.5 * position, between).min(widest),
            angle: 2.0 * (prior.heading_floor + prior.heading * ratio),
            exclude: length,
            gap: spatial.every() as f64 * step,
            rate: 1.5 * position,
        }
    }
}

/// `x.floor() as i32` without the libm call `floor` is on baseline x86-64
/// (the vote's inner loop).
fn floor_i32(x: f64) -> i32 {
    let i = x as i32;
    i.saturating_sub(((i as f64) > x) as i32)
}

/// Direction of the track at sample `g` (central difference).
fn heading(h: &HistoryView, g: usize) -> f64 {
    let last = h.xy.len() - 1;
    let d = h.point((g + 1).min(last)) - h.point(g.saturating_sub(1));
    d.y.atan2(d.x)
}

/// `x` in `[-2 pi, 2 pi]` wrapped into `[-pi/2, pi/2]`: the difference of
/// two road directions when either may be driven either way.
fn axial(mut x: f64) -> f64 {
    let pi = std::f64::consts::PI;
    while x > pi / 2.0 {
        x -= pi;
    }
    while x < -pi / 2.0 {
        x += pi;
    }
    x
}

/// The best placement of track samples `[g0, g1]` on the map within
/// `bounds`, or `None` when no map sample is in reach.
pub fn register(
    h: &HistoryView,
    spatial: &SpatialIndex,
    g0: usize,
    g1: usize,
    bounds: &Bounds,
    prior: &DriftPrior,
) -> Option<Registration> {
    let length = h.s[g1] - h.s[g0];
    if length <= 0.0 || g1 < g0 + POINTS {
        return None;
    }
    let band = BAND_FRACTION * length;
    let (window, centroid) = Window::new(h, g0, g1, band);
    let half = window
        .points
        .iter()
        .map(|p| (p.0 - centroid).norm())
        .fold(0.0, f64::max);
    // Map samples in reach, with their road directions. The map is indexed
    // every few samples: a point between two indexed samples is on the
    // road within half their spacing.
    let s_end = h.s[g0] - bounds.exclude;
    let reach = bounds.radius + half + band;
    // Each sample's own reach: the drift grows with the path between.
    let mut samples = Vec::new();
    let mut reach2 = Vec::new();
    spatial.samples_near(h, &centroid, reach, |t| {
        let r = bounds
            .radius
            .min(radius(length, bounds.rate, h.s[g0] - h.s[t]));
        if h.s[t] <= s_end && (h.point(t) - centroid).norm() <= r + half + band {
            samples.push((h.point(t), heading(h, t), t as u32));
            reach2.push(r * r);
        }
    });
    // The map's first road, a window's length of it, as far as the drift
    // prior reaches without the cap: where the path began is where most
    // loops close, and one road adds few rivals.
    let capped = samples.len();
    // Their nearness bound, as `near2` below but at each one's own reach.
    let mut near2_beyond = Vec::new();
    let road = window.start.road;
    for t in (0..=road as usize).step_by(spatial.every().max(1)) {
        if h.s[t] > s_end {
            break;
        }
        let r = radius(length, bounds.rate, h.s[g0] - h.s[t]);
        let d = (h.point(t) - centroid).norm();
        if d > bounds.radius.min(r) + half + band && d <= r + half + band {
            samples.push((h.point(t), heading(h, t), t as u32));
            reach2.push(r * r);
            near2_beyond.push((r + half).powi(2));
        }
    }
    if samples.is_empty() {
        return None;
    }
    let map = Map::new(samples, band + 0.5 * bounds.gap);
    // Votes: (rotation bin, translation cell) -> the window points agreeing.
    let key = |v: f64| floor_i32(v / band);
    let mut votes: HashMap<(i32, i32, i32), u64, CellHash> = HashMap::default();
    let na = (bounds.angle / ANGLE_BIN).ceil() as i32;
    let rot: Vec<(f64, f64)> = (-na..=na)
        .map(|b| (b as f64 * ANGLE_BIN).sin_cos())
        .collect();
    let near2 = (bounds.radius + half).powi(2);
    // The votes onto the map's first road alone (see below).
    let mut at_start: HashMap<(i32, i32, i32), u64, CellHash> = HashMap::default();
    // Every other point votes: a point on a straight votes for a line of
    // slides along each parallel road, and the lines of two straights that
    // meet at a junction cross at the placement. (Only the points that turn
    // most: one strong-drift event of 44 fewer; all 48 points: one more, at
    // twice the time.)
    let voters = (0..POINTS).step_by(VOTE_EVERY);
    // The vote cell of window point `p` (`d` from the centroid, heading
    // `phi`) laid on map sample `m` (heading `psi`), within `near2` of it
    // and a translation within `r2`.
    let vote = |p: &Vector2<f64>,
                d: &Vector2<f64>,
                phi: f64,
                m: &Vector2<f64>,
                psi: f64,
                r2: f64,
                near2: f64| {
        if (m - p).norm_squared() > near2 {
            return None;
        }
        let theta = axial(psi - phi);
        if theta.abs() > bounds.angle {
            return None;
        }
        let b = (theta / ANGLE_BIN).round() as i32;
        let (s, c) = rot[(b + na) as usize];
        let t = m - centroid - Vector2::new(c * d.x - s * d.y, s * d.x + c * d.y);
        (t.norm_squared() <= r2).then(|| (b, key(t.x), key(t.y)))
    };
    let (in_reach, beyond) = map.samples.split_at(capped);
    for i in voters {
        let (p, phi) = &window.points[i];
        let d = p - centroid;
        for (&(m, psi, sample), &r2) in in_reach.iter().zip(&reach2) {
            let Some(cell) = vote(p, &d, *phi, &m, psi, r2, near2) else {
                continue;
            };
            *votes.entry(cell).or_default() |= 1 << i;
            if sample <= road {
                *at_start.entry(cell).or_default() |= 1 << i;
            }
        }
        // The first road beyond the reach votes for its own cells alone.
        let far = reach2[capped..].iter().zip(&near2_beyond);
        for (&(m, psi, _), (&r2, &near2)) in beyond.iter().zip(far) {
            if let Some(cell) = vote(p, &d, *phi, &m, psi, r2, near2) {
                *at_start.entry(cell).or_default() |= 1 << i;
            }
        }
    }
    // The cells most points agree on, each refined on the map (heading noise
    // and the bin edges scatter a placement over neighbouring cells).
    let mut cells: Vec<((i32, i32, i32), u64)> = votes.iter().map(|(k, v)| (*k, *v)).collect();
    cells.sort_unstable_by_key(|(_, bits)| std::cmp::Reverse(bits.count_ones()));
    let same_place = |a: &(i32, i32, i32), b: &(i32, i32, i32)| {
        (a.0 - b.0).abs() <= 1
            && (a.1 - b.1).abs() <= RIVAL_BANDS
            && (a.2 - b.2).abs() <= RIVAL_BANDS
    };
    let mut kept: Vec<((i32, i32, i32), u64)> = Vec::with_capacity(TOP_CELLS);
    for c in &cells {
        if kept.len() == TOP_CELLS {
            break;
        }
        if kept.iter().filter(|k| same_place(&k.0, &c.0)).count() < PER_PLACE {
            kept.push(*c);
        }
    }
    // A window that returns to the map's first road has its entry beyond
    // the map's first pose, where nothing votes: its place gathers fewer
    // votes than straights elsewhere that lay every point on a road, and
    // was not checked. The cells most votes onto the first road agree on
    // (as many as one place has above) are checked too, apart from the
    // others: their entry counts half there (`OpenStart`). One refined off
    // the first road is some other cell's place again (a rival of the true
    // one by its rotation alone): left out.
    let mut start_cells: Vec<((i32, i32, i32), u64)> = at_start
        .into_iter()
        .filter(|(k, _)| !kept.iter().any(|c| c.0 == *k))
        .collect();
    start_cells.sort_unstable_by_key(|(k, bits)| (std::cmp::Reverse(bits.count_ones()), *k));
    start_cells.truncate(PER_PLACE);
    kept.extend(&start_cells);
    let is_start = |cell: &(i32, i32, i32)| start_cells.iter().any(|c| c.0 == *cell);
    let cells = kept;
    let score = |sim: &Similarity2, support: f64| -> Option<(f64, Registration)> {
        // The map sample under the window point nearest the middle that
        // lies on the map (a window entering the map from a new road has
        // its middle off it).
        let to_map = sim.applier();
        let mut block = Block::default();
        let mut outward = (0..POINTS).map(|k| match k % 2 {
            0 => POINTS / 2 + k / 2,
            _ => POINTS / 2 - k.div_ceil(2),
        });
        let target = outward
            .find_map(|k| map.nearest(&to_map(&window.points[k].0), &mut block))
            .map(|j| map.samples[j].2 as usize)?;
        // The drift prior along the path between (`drift_path`): the
        // angle and the offset as drift makes them agree.
        let path = PathMoments::between(h, target, (g0 + g1) / 2);
        let factor = drift_path::factor(drift_path::mahalanobis2(
            prior, sim, centroid, &path, length,
        ));
        Some((
            support * factor.sqrt(),
            Registration {
                place: Place { sim: *sim, target },
                support,
                prior: factor,
                margin: f64::INFINITY,
                rival: None,
            },
        ))
    };
    let mut placements: Vec<(f64, Registration, OnMap)> = Vec::new();
    for (cell @ (b, kx, ky), _) in cells {
        // history_T_window about the centroid: p -> c + t + R (p - c).
        let rotate = Similarity2 {
            scale: 1.0,
            angle: b as f64 * ANGLE_BIN,
            translation: Vector2::zeros(),
        };
        let t = Vector2::new((kx as f64 + 0.5) * band, (ky as f64 + 0.5) * band);
        let start = Similarity2 {
            translation: centroid + t - rotate.apply(&centroid),
            ..rotate
        };
        let on = window.support(&map, &start);
        let (sim, on) = window.refine(&map, start, on, ROUNDS.0);
        let placed = score(&sim, on.support)
            .filter(|(_, r)| !is_start(&cell) || r.place.target <= road as usize);
        placements.extend(placed.map(|(s, r)| (s, r, on)));
    }
    placements.sort_by(|a, b| b.0.total_cmp(&a.0));
    for placement in placements.iter_mut().take(TOP_REFINED) {
        let on = std::mem::take(&mut placement.2);
        let (sim, on) = window.refine(&map, placement.1.place.sim, on, ROUNDS.1 - ROUNDS.0);
        if let Some((s, r)) = score(&sim, on.support) {
            *placement = (s, r, on);
        }
    }
    placements.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (best_score, mut best) = placements.first().map(|p| (p.0, p.1))?;
    let mid = window.points[POINTS / 2].0;
    let rival = placements.iter().skip(1).find(|(_, r, _)| {
        axial(r.place.sim.angle - best.place.sim.angle).abs() > ANGLE_BIN
            || (r.place.sim.apply(&mid) - best.place.sim.apply(&mid)).norm()
                > RIVAL_BANDS as f64 * band
    });
    if let Some((rival_score, r, _)) = rival {
        best.margin = best_score / rival_score.max(f64::MIN_POSITIVE);
        best.rival = Some(r.place);
    }
    Some(best)
}

#[cfg(test)]
mod tests;
