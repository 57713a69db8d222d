//! Grow, then refit: a rough seed similarity is extended along both paths as
//! far as the mapped query stays on the target, then refitted on every
//! matched point with robust weights. Repeating this turns a seed of a few
//! percent into sub-degree, sub-percent alignments.

use nalgebra::Vector2;

use crate::geometry::{Polyline2, Similarity2};
use crate::track::Track;

/// Settings of growing and refitting.
#[derive(Debug, Clone, Copy)]
pub struct GrowConfig {
    /// A mapped query point is on the target when closer than this fraction
    /// of the matched length.
    pub tolerance: f64,
    /// Grow/refit rounds.
    pub rounds: usize,
    /// Points used per seed (the query is strided to about this many).
    pub points_per_seed: usize,
    /// Misses in a row that end the growth.
    pub max_misses: usize,
}

impl Default for GrowConfig {
    fn default() -> Self {
        GrowConfig {
            tolerance: 0.03,
            rounds: 4,
            points_per_seed: 120,
            max_misses: 3,
        }
    }
}

/// The grown common part of a query and a target track.
#[derive(Debug, Clone)]
#[allow(non_snake_case)]
pub struct Overlap {
    /// Final similarity, query (b) to target (a), in 2D.
    pub a_T_b: Similarity2,
    /// Inclusive query grid range.
    pub query: [usize; 2],
    /// Inclusive target grid range (from the projections).
    pub target: [f64; 2],
    /// Matched (target grid index, query grid index) pairs.
    pub pairs: Vec<(f64, usize)>,
    /// RMS distance of the matched pairs (target units).
    pub rmse: f64,
    /// Matched length along the target (target units).
    pub target_length: f64,
    /// Matched length along the query times the scale (target units).
    pub query_length: f64,
}

/// Grows the seed `[g0, g1]` of `query` (2D points `query_xy`, the query
/// track's own points, mirrored if need be) on `target`.
/// `allowed(query_grid, target_grid)` rejects trivial self-matches.
#[allow(non_snake_case)]
#[allow(clippy::too_many_arguments)]
pub fn grow_and_refit(
    target: &Track,
    target_poly: &Polyline2,
    query: &Track,
    query_xy: &[Vector2<f64>],
    seed: [usize; 2],
    a_T_b: Similarity2,
    config: &GrowConfig,
    allowed: &dyn Fn(usize, f64) -> bool,
) -> Option<Overlap> {
    let n = query_xy.len();
    if n < 2 || seed[1] <= seed[0] {
        return None;
    }
    let stride = ((seed[1] - seed[0]) / config.points_per_seed).max(1);
    let mut sim = a_T_b;
    let mut range = [seed[0], seed[1].min(n - 1)];
    let mut result = None;
    for _ in 0..config.rounds {
        let length = sim.scale * (query.s[range[1]] - query.s[range[0]]);
        let tol = config.tolerance * length;
        if !(tol > 0.0 && tol.is_finite()) {
            return None;
        }
        let probe = |g: usize| -> Option<(f64, Vector2<f64>, f64)> {
            let p = sim.apply(&query_xy[g]);
            let proj = target_poly.project(&p);
            (proj.distance < tol && allowed(g, proj.vertex))
                .then(|| (proj.vertex, target.point_at(proj.vertex), proj.distance))
        };
        // Matched points inside the current range.
        let mut matched: Vec<(usize, f64, Vector2<f64>, f64)> = Vec::new();
        let mut g = range[0];
        while g <= range[1] {
            if let Some((v, q, d)) = probe(g) {
                matched.push((g, v, q, d));
            }
            g += stride;
        }
        // Grow outwards on both sides.
        let mut lo = range[0];
        let mut misses = 0;
        while lo >= stride && misses < config.max_misses {
            lo -= stride;
            match probe(lo) {
                Some((v, q, d)) => {
                    matched.push((lo, v, q, d));
                    misses = 0;
                    range[0] = lo;
                }
                None => misses += 1,
            }
        }
        let mut hi = range[1];
        misses = 0;
        while hi + stride < n && misses < config.max_misses {
            hi += stride;
            match probe(hi) {
                Some((v, q, d)) => {
                    matched.push((hi, v, q, d));
                    misses = 0;
                    range[1] = hi;
                }
                None => misses += 1,
            }
        }
        if matched.len() < 6 {
            return result;
        }
        // Robust refit: Huber weights on the distance.
        let huber = tol / 3.0;
        let pairs: Vec<(Vector2<f64>, Vector2<f64>)> =
            matched.iter().map(|(g, _, q, _)| (*q, query_xy[*g])).collect();
        let weights: Vec<f64> = matched
            .iter()
            .map(|(_, _, _, d)| if *d <= huber { 1.0 } else { huber / d })
            .collect();
        let Some(refit) = Similarity2::fit(&pairs, Some(&weights)) else {
            return result;
        };
        sim = refit;
        matched.sort_by_key(|m| m.0);
        let residuals: Vec<f64> = matched
            .iter()
            .map(|(g, _, _, _)| target_poly.project(&sim.apply(&query_xy[*g])).distance)
            .collect();
        let rmse = (residuals.iter().map(|d| d * d).sum::<f64>() / residuals.len() as f64).sqrt();
        let (tmin, tmax) = matched.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| {
            (a.min(m.1), b.max(m.1))
        });
        let target_length = Track::interp(&target.s, tmax) - Track::interp(&target.s, tmin);
        result = Some(Overlap {
            a_T_b: sim,
            query: range,
            target: [tmin, tmax],
            pairs: matched.iter().map(|(g, v, _, _)| (*v, *g)).collect(),
            rmse,
            target_length,
            query_length: sim.scale * (query.s[range[1]] - query.s[range[0]]),
        });
    }
    result
}
