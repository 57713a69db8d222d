//! A placement refined jointly: every placed path's similarity refitted to
//! all of its overlaps with placed paths at once, not only the one that
//! placed it, so that a chain's errors spread over its cycles instead of
//! adding up along one branch of the spanning tree.
//!
//! With `first_T_u` the placement of path `u` and `u_T_v` an overlap's
//! similarity, the refit of `v` is the least squares similarity
//!
//! ```text
//! first_T_v = argmin Σ_e Σ_i | T p_v,i - first_T_u u_T_v p_v,i |²
//! ```
//!
//! over the poses `p_v,i` of each overlap's matched range in `v`, every
//! overlap weighing the same (one measurement however long: [`PAIRS`]
//! poses each). With one overlap the refit is the placement itself. Paths
//! are refitted in turn, the first held fixed, for a few sweeps (block
//! coordinate descent on one least-squares cost: it never rises).

use nalgebra::Vector3;

use super::placement::{agrees, Overlap};
use crate::geometry::Similarity3;
use crate::Trajectory;

/// Sweeps over the placed paths. Each lowers the joint cost; a chain of
/// `k` links carries a correction `k` links along in about `k` sweeps, and
/// the placements of a few dozen sessions settle within this many.
pub const SWEEPS: usize = 8;

/// Poses taken per overlap (evenly spread over its matched range): the
/// fit needs their spread, not their density.
pub const PAIRS: usize = 200;

/// `frames` refined over `overlaps` (all between placed paths, each
/// agreeing with the placement). A path whose refit would move it beyond
/// [`super::placement::AGREEMENT`] of its placement keeps the placement:
/// the refit may spread errors, never overturn a placement.
pub fn refine(
    paths: &[Trajectory],
    frames: &[Option<Similarity3>],
    overlaps: &[&Overlap],
) -> Vec<Option<Similarity3>> {
    let mut refined = frames.to_vec();
    for _ in 0..SWEEPS {
        for v in 1..paths.len() {
            let Some(placed) = frames[v] else {
                continue;
            };
            let Some(fit) = refit(paths, &refined, overlaps, v) else {
                continue;
            };
            let points: Vec<Vector3<f64>> = paths[v].poses.iter().map(|p| p.position).collect();
            if agrees(&points, &placed, &fit) {
                refined[v] = Some(fit);
            }
        }
    }
    refined
}

/// The least-squares `first_T_v` over `v`'s overlaps with placed paths:
/// each overlap's poses of `v` (its matched range) against where the
/// overlap's own similarity puts them through the other path's placement.
fn refit(
    paths: &[Trajectory],
    frames: &[Option<Similarity3>],
    overlaps: &[&Overlap],
    v: usize,
) -> Option<Similarity3> {
    let (mut src, mut dst) = (Vec::new(), Vec::new());
    for e in overlaps.iter().filter(|e| e.a == v || e.b == v) {
        let u = e.other(v);
        let Some(first_t_u) = frames[u] else {
            continue;
        };
        let first_t_v = first_t_u.compose(&e.seen_from(u));
        let [lo, hi] = if e.a == v {
            e.hypothesis.a_range
        } else {
            e.hypothesis.b_range
        };
        let hi = hi.min(paths[v].len().saturating_sub(1));
        if hi < lo {
            continue;
        }
        for k in 0..PAIRS {
            let p = paths[v].poses[lo + k * (hi - lo) / (PAIRS - 1)].position;
            src.push(p);
            dst.push(first_t_v.apply(&p));
        }
    }
    Similarity3::fit(&src, &dst)
}
