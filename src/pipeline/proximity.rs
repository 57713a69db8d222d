//! Proximity seeds for loops within one map: where the path comes back near
//! an earlier part of itself, in the map's own frame.
//!
//! On a map that is still consistent this finds most revisits, including
//! straight ones that carry no turn to match: the naive "nearest earlier
//! position" search a SLAM engineer would try first. turnprint must never do
//! worse than it, so its seeds go through the same verification as the
//! shape candidates (starting from the identity) and compete on score.
//!
//! Where a map has drifted, the earlier pass lies farther away the longer
//! the path between the two: a window that finds nothing near gets a second
//! probe whose radius grows with that distance, by the drift prior's
//! position rate (the radius the loop score itself tolerates). Its seed
//! starts from the similarity of the probe points onto their nearest
//! points, since the identity is then off by the drift. On the KITTI
//! monocular estimate of 08, which ORB-SLAM2 did not close, this finds
//! both revisits.

use nalgebra::Vector2;

use super::PreparedPath;
use crate::geometry::Similarity2;

/// A query grid range, the target grid index its middle is nearest to, and
/// where to start growing (batch seeds and the online probe alike).
#[derive(Debug, Clone)]
pub struct ProximitySeed {
    /// Inclusive query grid range.
    pub query: [usize; 2],
    /// The probes' median nearest grid index outside the neighbourhood.
    pub target: usize,
    /// The similarity (query onto target) to grow from: the identity in a
    /// consistent map, [`drifted_start`] in a drifting one.
    pub start: Similarity2,
    /// Found only with the drifting map's wider radius.
    pub drifted: bool,
    /// The probe points and their nearest points (target, query).
    pub pairs: Vec<(Vector2<f64>, Vector2<f64>)>,
}

impl ProximitySeed {
    /// The similarities to grow from, in turn until one grows: `start`,
    /// then, for a consistent map's seed, the rigid fit of the probe points
    /// onto their nearest points ([`consistent_start`]). A map that drifts
    /// a little between the passes puts the earlier pass within the
    /// consistent radius but a few metres off the identity, farther than
    /// the first grow round's tolerance (3 % of a probe window: about a
    /// metre on KITTI), and that growth finds nothing; trying the identity
    /// first keeps consistent maps, where it is exact, as they were.
    pub fn starts(&self, length: f64) -> impl Iterator<Item = Similarity2> + '_ {
        // The fit only when the identity found nothing (most seeds grow).
        let fit = std::iter::once_with(move || {
            (!self.drifted)
                .then(|| consistent_start(&self.pairs, length))
                .flatten()
        });
        std::iter::once(self.start).chain(fit.flatten())
    }
}

/// One probe point's nearest point of the other part.
#[derive(Debug, Clone, Copy)]
pub struct Near {
    /// Distance over the radius (below 1: within it).
    pub ratio: f64,
    /// Grid index of the nearest point.
    pub target: usize,
    /// The nearest point and the probe point (target, query).
    pub pair: (Vector2<f64>, Vector2<f64>),
}

/// The seed of window `query` (of `length`) whose probes found `near`
/// (`None`: nothing within the largest radius), when their median ratio is
/// below 1: the median target, grown from the identity or, for a drifting
/// map, from [`drifted_start`].
pub fn seed_of(
    query: [usize; 2],
    length: f64,
    near: &[Option<Near>; PROBES],
    drifted: bool,
) -> Option<ProximitySeed> {
    let target = near_target(near, 1.0)?;
    // The probes that found a point: at least half of them, by the median.
    let pairs: Vec<_> = near.iter().flatten().map(|n| n.pair).collect();
    let start = match drifted {
        true => drifted_start(&pairs, length)?,
        false => Similarity2::identity(),
    };
    Some(ProximitySeed {
        query,
        target,
        start,
        drifted,
        pairs,
    })
}

/// The probes' median nearest grid index, when their median ratio is below
/// `ratio` (1: within the radius).
pub fn near_target(near: &[Option<Near>; PROBES], ratio: f64) -> Option<usize> {
    let mut ratios = near.map(|n| n.map_or(f64::INFINITY, |n| n.ratio));
    ratios.sort_by(f64::total_cmp);
    if ratios[PROBES / 2] >= ratio {
        return None;
    }
    let mut targets: Vec<usize> = near.iter().flatten().map(|n| n.target).collect();
    targets.sort_unstable();
    Some(targets[targets.len() / 2])
}

/// Probe points per window.
pub const PROBES: usize = 8;
/// A window revisits a place when its probes' median distance to the other
/// part is below this fraction of the window's length.
pub const NEAR_FRACTION: f64 = 0.25;

/// The radius within which a window of `length` finds the part it revisits,
/// `between` along the path away: `NEAR_FRACTION * length` in a consistent
/// map, growing by `drift` per unit of path in between in a drifting one.
pub fn radius(length: f64, drift: f64, between: f64) -> f64 {
    NEAR_FRACTION * length + drift * between
}

/// A drifted seed's probes must fit their nearest points under one
/// similarity within this fraction of the window's length, so that a road
/// that only crosses or passes the window is not grown: twice the band a
/// drifting map's revisit is grown in (`Config::for_loops`), as eight
/// nearest points fit less tightly than a grown overlap. (At 0.05 the
/// strong-drift loops lost events; without the check, rank-1.)
pub const DRIFT_FIT: f64 = 0.1;

/// The similarity a drifted seed grows from: the fit of the probe points
/// (query) onto their nearest points (target), when its RMS residual is
/// within [`DRIFT_FIT`] of the window's `length`.
pub fn drifted_start(pairs: &[(Vector2<f64>, Vector2<f64>)], length: f64) -> Option<Similarity2> {
    fitting(Similarity2::fit(pairs, None)?, pairs, length)
}

/// The similarity a consistent map's seed grows from when the identity
/// found nothing: the fit of the probe points onto their nearest points at
/// the map's own scale (within [`DRIFT_FIT`] as [`drifted_start`]). The
/// passes of one map within the consistent radius share its scale, and
/// nearest points do not measure it: on a straight revisit whose passes
/// the drift has turned a few degrees apart, the similarity fit shrank the
/// window by a third and the growth from it ended at that scale (KITTI 08,
/// strong drift, seed 12: 3-11 m apart, scale 1.49, score 0.003). Strong
/// drift, seeds 1-40: 382 -> 387 of 440 events (held out, seeds 41-80: 368,
/// the same).
pub fn consistent_start(
    pairs: &[(Vector2<f64>, Vector2<f64>)],
    length: f64,
) -> Option<Similarity2> {
    fitting(Similarity2::fit_rigid(pairs)?, pairs, length)
}

/// `start` when it maps the probe points (query) within an RMS of
/// [`DRIFT_FIT`] times `length` of their nearest points (target).
fn fitting(
    start: Similarity2,
    pairs: &[(Vector2<f64>, Vector2<f64>)],
    length: f64,
) -> Option<Similarity2> {
    let rms = (pairs
        .iter()
        .map(|(t, q)| (start.apply(q) - t).norm_squared())
        .sum::<f64>()
        / pairs.len().max(1) as f64)
        .sqrt();
    (rms <= DRIFT_FIT * length).then_some(start)
}

/// Seeds from windows of two consecutive segments; `drift` is the position
/// drift per unit of path length between the parts (0: consistent map only).
pub fn proximity_seeds(path: &PreparedPath, drift: f64) -> Vec<ProximitySeed> {
    let track = &path.track;
    let sig = &path.signature;
    let stride = 2;
    let mut seeds = Vec::new();
    for w in path.bounds.windows(3) {
        let g0 = sig.grid[w[0]].floor() as usize;
        let g1 = (sig.grid[w[2]].ceil() as usize).min(track.len() - 1);
        if g1 <= g0 + PROBES {
            continue;
        }
        let length = track.s[g1] - track.s[g0];
        if length > 0.0 {
            seeds.extend(probe(path, [g0, g1], length, drift, stride));
        }
    }
    seeds
}

/// The probe of window `g` (grid range of length `length`): each of
/// [`PROBES`] points' nearest other point at least `length` away along the
/// path, by distance over a radius: `NEAR_FRACTION * length` in a
/// consistent map, plus `drift * (distance along the path)` in a drifting
/// one. A seed when the median is within the radius, the consistent map
/// first (one scan computes both).
fn probe(
    path: &PreparedPath,
    g: [usize; 2],
    length: f64,
    drift: f64,
    stride: usize,
) -> Option<ProximitySeed> {
    let track = &path.track;
    // Per probe, the nearest point for the consistent and the drifting map.
    let nearest = |k: usize| {
        let gk = g[0] + (k * (g[1] - g[0])) / (PROBES - 1);
        let (p, s) = (track.xy[gk], track.s[gk]);
        // (ratio, target) per map; the points are looked up once at the end.
        let mut best = [(f64::INFINITY, 0usize); 2];
        let mut t = 0;
        while t < track.len() {
            let between = (track.s[t] - s).abs();
            if between > length {
                let d = (track.xy[t] - p).norm();
                for (map, r) in [radius(length, 0.0, between), radius(length, drift, between)]
                    .into_iter()
                    .enumerate()
                {
                    if d < best[map].0 * r {
                        best[map] = (d / r, t);
                    }
                }
            }
            t += stride;
        }
        best.map(|(ratio, t)| {
            ratio.is_finite().then(|| Near {
                ratio,
                target: t,
                pair: (track.xy[t], p),
            })
        })
    };
    let per_probe: [[Option<Near>; 2]; PROBES] = std::array::from_fn(nearest);
    let near = [per_probe.map(|n| n[0]), per_probe.map(|n| n[1])];
    seed_of(g, length, &near[0], false).or_else(|| {
        (drift > 0.0)
            .then(|| seed_of(g, length, &near[1], true))
            .flatten()
    })
}
