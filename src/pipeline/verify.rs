//! Geometric verification of one candidate: RANSAC on its sample
//! correspondences, grow and refit along both paths, then the evidence.

use nalgebra::Vector2;

use super::{Config, PreparedPath};
use crate::align::ransac::SplitMix;
use crate::align::{grow_and_refit, ransac_similarity, Overlap};
use crate::matching::Candidate;
use crate::score::Evidence;

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

/// Linear interpolation in a point list at a fractional index.
fn lerp(xy: &[Vector2<f64>], at: f64) -> Vector2<f64> {
    let n = xy.len();
    let at = at.clamp(0.0, (n - 1) as f64);
    let i = (at.floor() as usize).min(n.saturating_sub(2));
    let f = at - i as f64;
    xy[i] * (1.0 - f) + xy[(i + 1).min(n - 1)] * f
}

/// Verifies `cand` (query samples aligned to target samples); `query_xy` are
/// the query track's points, already mirrored when the candidate is.
pub fn verify(
    target: &PreparedPath,
    query: &PreparedPath,
    query_xy: &[Vector2<f64>],
    cand: &Candidate,
    config: &Config,
    allowed: &dyn Fn(usize, f64) -> bool,
) -> Option<Verified> {
    let (ts, qs) = (&target.signature, &query.signature);
    let mut pairs = Vec::new();
    let (mut s_min, mut s_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for b in cand.query[0]..=cand.query[1] {
        let a = cand.target_of(b);
        if a < 0 || a as usize >= ts.len() {
            continue;
        }
        let a = a as usize;
        pairs.push((
            target.track.point_at(ts.grid[a]),
            lerp(query_xy, qs.grid[b]),
        ));
        s_min = s_min.min(ts.s[a]);
        s_max = s_max.max(ts.s[a]);
    }
    let threshold = config.ransac_threshold * (s_max - s_min);
    let mut rng = SplitMix(0x7475_726e ^ (cand.line as u64) ^ ((cand.query[0] as u64) << 20));
    let (a_t_b, _) = ransac_similarity(&pairs, threshold, config.ransac_iterations, &mut rng)?;
    let seed = [
        qs.grid[cand.query[0]].floor() as usize,
        (qs.grid[cand.query[1]].ceil() as usize).min(query_xy.len() - 1),
    ];
    let overlap = grow_and_refit(
        &target.track,
        &target.polyline,
        &query.track,
        query_xy,
        seed,
        a_t_b,
        &config.grow,
        allowed,
    )?;
    let length = overlap.target_length.max(overlap.query_length);
    let evidence = Evidence {
        zncc: cand.zncc,
        turning: query.turning_between(overlap.query[0] as f64, overlap.query[1] as f64),
        relative_rmse: overlap.rmse / length.max(f64::MIN_POSITIVE),
        length_ratio: overlap.target_length / overlap.query_length,
    };
    Some(Verified {
        overlap,
        candidate: cand.clone(),
        evidence,
    })
}
