//! Geometric verification of one candidate: RANSAC on its sample
//! correspondences, grow and refit along both paths, then the evidence.

use nalgebra::Vector2;

use super::{Config, PreparedPath};
use crate::align::ransac::SplitMix;
use crate::align::{grow_and_refit, ransac_similarity, Overlap};
use crate::geometry::Similarity2;
use crate::matching::{Candidate, Orientation};
use crate::score::Evidence;
use crate::track::Track;

/// A candidate that survived geometry.
#[derive(Debug, Clone)]
pub struct Verified {
    /// The grown overlap and its similarity (query -> target, 2D).
    pub overlap: Overlap,
    /// The candidate it came from.
    pub candidate: Candidate,
    /// Its evidence.
    pub evidence: Evidence,
}

/// Verifies `cand` (query samples aligned to target samples); `query_xy` are
/// the query track's points, already mirrored when the candidate is.
/// `gate` sees the RANSAC similarity (query -> target) and its sample pairs
/// (target point, query point) and can stop before the costly growth: a
/// caller that knows no similarity like it can score high enough says so
/// there (`&|_, _| true` otherwise). `promising`, if given, sees the
/// candidate as the first grow round leaves it and can stop the rounds
/// that follow ([`grow_and_refit`]); without it no evidence is taken
/// before the end.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn verify(
    target: &PreparedPath,
    query: &PreparedPath,
    query_xy: &[Vector2<f64>],
    cand: &Candidate,
    config: &Config,
    allowed: &dyn Fn(usize, f64) -> bool,
    gate: &dyn Fn(&Similarity2, &[(Vector2<f64>, Vector2<f64>)]) -> bool,
    promising: Option<&dyn Fn(&Verified) -> bool>,
) -> Option<Verified> {
    let (ts, qs) = (&target.signature, &query.signature);
    let (a_t_b, pairs) = seed_similarity(
        cand,
        1,
        ts.len(),
        |a, b| {
            (
                target.track.point_at(ts.grid[a]),
                crate::track::lerp_point(query_xy, qs.grid[b]),
            )
        },
        |a| ts.s[a],
        config,
        0x7475_726e,
    )?;
    if !gate(&a_t_b, &pairs) {
        return None;
    }
    let seed = [
        qs.grid[cand.seed[0]].floor() as usize,
        (qs.grid[cand.seed[1]].ceil() as usize).min(query_xy.len() - 1),
    ];
    // The seed's ZNCC compares signatures each at its own resolution; the
    // grown overlap knows the scale, and so a common one.
    // The overlap's direction is the growth's (the alignment line that
    // keeps more points), which may differ from the seed's: the hypothesis
    // reports the direction its correspondences run in.
    let verified = |overlap: Overlap| {
        let negate = overlap.reversed != cand.orientation.mirrored;
        let zncc = cand.zncc.max(overlap_zncc(target, query, &overlap, negate));
        let cand = Candidate {
            orientation: Orientation {
                reversed: overlap.reversed,
                ..cand.orientation
            },
            ..cand.clone()
        };
        finish(target, query, query_xy, overlap, cand, zncc, config)
    };
    // An overlap too short to verify after one round may still grow.
    let promising = |overlap: &Overlap| {
        promising.is_none_or(|promising| verified(overlap.clone()).is_none_or(|v| promising(&v)))
    };
    let overlap = grow_and_refit(
        &target.track,
        &target.polyline,
        &query.track,
        query_xy,
        seed,
        a_t_b,
        &config.grow,
        allowed,
        &promising,
    )?;
    verified(overlap)
}

/// The RANSAC similarity (query -> target) of a candidate's seed samples,
/// with the sample pairs it was fitted to: every `stride`-th query sample
/// `b` of the seed and its aligned target sample `a` (below `target_len`),
/// as `point(a, b)` = (target point, query point); the inlier threshold is
/// `config.ransac_threshold` of the target arc (`target_s`) they span.
/// `salt` keeps the random draws of different callers apart.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn seed_similarity(
    cand: &Candidate,
    stride: usize,
    target_len: usize,
    point: impl Fn(usize, usize) -> (Vector2<f64>, Vector2<f64>),
    target_s: impl Fn(usize) -> f64,
    config: &Config,
    salt: u64,
) -> Option<(Similarity2, Vec<(Vector2<f64>, Vector2<f64>)>)> {
    let mut pairs = Vec::new();
    let (mut s_min, mut s_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for b in (cand.seed[0]..=cand.seed[1]).step_by(stride.max(1)) {
        let a = cand.target_of(b);
        if a < 0 || a as usize >= target_len {
            continue;
        }
        let a = a as usize;
        pairs.push(point(a, b));
        s_min = s_min.min(target_s(a));
        s_max = s_max.max(target_s(a));
    }
    let threshold = config.ransac_threshold * (s_max - s_min);
    let mut rng = SplitMix(salt ^ (cand.line as u64) ^ ((cand.query[0] as u64) << 20));
    let (a_t_b, _) = ransac_similarity(
        &pairs,
        threshold,
        config.ransac_iterations,
        config.ransac_confidence,
        &mut rng,
    )?;
    Some((a_t_b, pairs))
}

/// Verifies a pooled candidate from its best vote and, when the votes span
/// more, from their union too (a long union gives context that tells look-
/// alikes apart, a single clean vote gives a better seed): the better
/// score wins.
pub fn verify_best(
    target: &PreparedPath,
    query: &PreparedPath,
    query_xy: &[Vector2<f64>],
    cand: &Candidate,
    config: &Config,
    allowed: &dyn Fn(usize, f64) -> bool,
) -> Option<(Verified, f64)> {
    let scored = |c: &Candidate| {
        verify(
            target,
            query,
            query_xy,
            c,
            config,
            allowed,
            &|_, _| true,
            None,
        )
        .map(|v| {
            let s = crate::score::score(&v.evidence, &config.score);
            (v, s)
        })
    };
    let best = scored(cand);
    if cand.seed == cand.query {
        return best;
    }
    let union = Candidate {
        seed: cand.query,
        ..cand.clone()
    };
    match (best, scored(&union)) {
        (Some(a), Some(b)) => Some(if b.1 > a.1 { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// Verifies a seed that already has a similarity (a proximity seed within
/// one map starts from the identity): grow, refit, and correlate the
/// curvature of the grown overlap for its ZNCC.
#[allow(clippy::too_many_arguments)]
#[allow(non_snake_case)]
pub fn verify_seeded(
    target: &PreparedPath,
    query: &PreparedPath,
    query_xy: &[Vector2<f64>],
    seed: [usize; 2],
    a_T_b: Similarity2,
    mirrored: bool,
    config: &Config,
    allowed: &dyn Fn(usize, f64) -> bool,
) -> Option<Verified> {
    let overlap = grow_and_refit(
        &target.track,
        &target.polyline,
        &query.track,
        query_xy,
        seed,
        a_T_b,
        &config.grow,
        allowed,
        &|_| true,
    )?;
    let reversed = overlap.reversed;
    let zncc = overlap_zncc(target, query, &overlap, reversed != mirrored);
    let cand = Candidate {
        orientation: Orientation { reversed, mirrored },
        query: [0, 0],
        seed: [0, 0],
        line: 0,
        zncc,
        strength: 0.0,
    };
    finish(target, query, query_xy, overlap, cand, zncc, config)
}

/// Each side of an overlap spans at least this many of its own path's
/// smoothing bandwidths: below that the smoothed path holds no shape, and a
/// stretch where one path stands still matches the other's at a scale near
/// zero (TUM fr2/desk: a hand-held camera held still for a moment matched a
/// 0.3 m stretch of the same path at scale 0.0005).
const MIN_SIDE_BANDWIDTHS: f64 = 2.0;

/// The evidence of a grown overlap; `None` when a side is too short to
/// hold a shape.
fn finish(
    target: &PreparedPath,
    query: &PreparedPath,
    query_xy: &[Vector2<f64>],
    overlap: Overlap,
    candidate: Candidate,
    zncc: f64,
    config: &Config,
) -> Option<Verified> {
    if overlap.target_length < MIN_SIDE_BANDWIDTHS * target.track.bandwidth
        // (`query_length` is in the target's units, through the scale.)
        || overlap.query_length < MIN_SIDE_BANDWIDTHS * query.track.bandwidth * overlap.a_T_b.scale
    {
        return None;
    }
    let length = overlap.target_length.max(overlap.query_length);
    let query_fraction =
        overlap.query_length / (overlap.a_T_b.scale * query.track.length()).max(f64::MIN_POSITIVE);
    let target_fraction = overlap.target_length / target.track.length().max(f64::MIN_POSITIVE);
    // A path that drives a road twice holds it at two places: the query
    // may lie on the target beyond the one matched stretch.
    let on_target = if config.score.coverage_power > 0.0 {
        share_on_target(target, query_xy, &overlap, length)
    } else {
        0.0
    };
    let evidence = Evidence {
        zncc,
        // Turns that agree are on both sides: noise adds turning to one
        // (monocular wiggle), so the smaller of the two counts.
        turning: query
            .turning_between(overlap.query[0] as f64, overlap.query[1] as f64)
            .min(target.turning_between(overlap.target[0], overlap.target[1])),
        relative_rmse: overlap.rmse / length.max(f64::MIN_POSITIVE),
        length_ratio: overlap.target_length / overlap.query_length,
        coverage: query_fraction
            .max(target_fraction)
            .max(on_target)
            .clamp(0.0, 1.0),
    };
    Some(Verified {
        overlap,
        candidate,
        evidence,
    })
}

/// Query points checked by [`share_on_target`].
const ON_TARGET_SAMPLES: usize = 256;

/// Within this fraction of the matched length (or 3 RMS residuals), a
/// query point mapped by the overlap's similarity lies on the target.
const ON_TARGET_FRACTION: f64 = 0.02;

/// Share of the whole query (uniform grid, so by length) that the overlap's
/// similarity lays on the target anywhere, inside the matched stretch or
/// not.
fn share_on_target(
    target: &PreparedPath,
    query_xy: &[Vector2<f64>],
    overlap: &Overlap,
    length: f64,
) -> f64 {
    let n = query_xy.len();
    if n == 0 {
        return 0.0;
    }
    let tol = (ON_TARGET_FRACTION * length).max(3.0 * overlap.rmse);
    let samples = ON_TARGET_SAMPLES.min(n);
    let on = (0..samples)
        .map(|i| &query_xy[i * (n - 1) / (samples - 1).max(1)])
        .filter(|q| {
            let p = overlap.a_T_b.apply(q);
            target.polyline.project_within(&p, tol, |_| true).is_some()
        })
        .count();
    on as f64 / samples as f64
}

/// ZNCC of the two paths' curvature over the grown overlap, sampled at
/// [`OVERLAP_SAMPLES`] uniform steps of the query's matched arc length
/// (`negate` when one path travels or is seen the other way), at a common
/// resolution: the path smoothed less (in the target's units, through the
/// overlap's scale) is smoothed further to the other's bandwidth. A 1 Hz
/// GPS is smoothed over metres where 10 Hz odometry keeps sharp corners;
/// compared raw, their curvature disagrees where the road agrees.
pub fn overlap_zncc(
    target: &PreparedPath,
    query: &PreparedPath,
    overlap: &Overlap,
    negate: bool,
) -> f64 {
    let p = &overlap.pairs;
    if p.len() < 4 {
        return 0.0;
    }
    let sign = if negate { -1.0 } else { 1.0 };
    let scale = overlap.a_T_b.scale;
    let (bw_t, bw_q) = (target.track.bandwidth, scale * query.track.bandwidth);
    let bw = bw_t.max(bw_q);
    // Paths smoothed alike are compared as they are: two windows of one map
    // share one bandwidth (a scale away from 1 between them is drift or a
    // wrong candidate, not a resolution), and bandwidths a little apart
    // change little.
    let one_map = target.track.bandwidth == query.track.bandwidth;
    let (sigma_t, sigma_q) = if !one_map && bw > RESOLUTION_RATIO * bw_t.min(bw_q) {
        (
            (bw * bw - bw_t * bw_t).max(0.0).sqrt(),
            (bw * bw - bw_q * bw_q).max(0.0).sqrt() / scale,
        )
    } else {
        (0.0, 0.0)
    };
    let mut qv = Vec::with_capacity(OVERLAP_SAMPLES);
    let mut tv = Vec::with_capacity(OVERLAP_SAMPLES);
    for i in 0..OVERLAP_SAMPLES {
        let k = (i * (p.len() - 1)) / (OVERLAP_SAMPLES - 1);
        let (t, q) = p[k];
        qv.push(sign * curvature_at(&query.track, q as f64, sigma_q));
        tv.push(curvature_at(&target.track, t, sigma_t));
    }
    crate::matching::zncc::zncc_pair(&qv, &tv)
}

/// Curvature of `track` at grid position `g`, further smoothed by a
/// Gaussian of `sigma` (the track's length units; none below half a grid
/// step). Smoothing the path again by `sigma` smooths its heading, and so
/// its curvature, by about the same kernel.
fn curvature_at(track: &Track, g: f64, sigma: f64) -> f64 {
    let n = track.curvature.len();
    if sigma.is_nan() || sigma <= 0.5 * track.step || n == 0 {
        return Track::interp(&track.curvature, g);
    }
    let half = (3.0 * sigma / track.step).ceil() as i64;
    let centre = g.round() as i64;
    let (lo, hi) = ((centre - half).max(0), (centre + half).min(n as i64 - 1));
    let (mut sum, mut weights) = (0.0, 0.0);
    for i in lo..=hi {
        let d = (i as f64 - g) * track.step / sigma;
        let w = (-0.5 * d * d).exp();
        sum += w * track.curvature[i as usize];
        weights += w;
    }
    if weights > 0.0 {
        sum / weights
    } else {
        Track::interp(&track.curvature, g)
    }
}

/// [`overlap_zncc`] smooths one path further when the two bandwidths
/// differ by more than this factor.
const RESOLUTION_RATIO: f64 = 1.5;

/// Samples used by [`overlap_zncc`].
pub const OVERLAP_SAMPLES: usize = 64;
