//! The measured drift checked by the loops themselves
//! (`CorrectConfig::check_drift`): each kept loop is left out in turn and
//! the others predict where its two passes lie, at the measured odometry
//! and at a looser one. Drift that one loop shows is also where the others
//! put it; misses that are a loop's own (a lane's offset, a flight's passes
//! a metre apart) are not, so a looser odometry brings the left-out passes
//! closer only where the path drifts more than the misses alone said.

use super::graph::PoseGraph;
use super::{carry, pieces_of, solve, LoopClosure};
use crate::geometry::Similarity3;
use crate::trajectory::{Pose, Trajectory};
use crate::Result;

/// The looser odometry the measured drift is checked against, times the
/// measured factor: half a decade, the factor's own uncertainty from a
/// handful of loops (measured factors of one estimate vary 2-5x with the
/// loops chosen). A full decade went too far on KITTI: MULLS 00 1.39 ->
/// 1.60 m, GICP 02 20.0 -> 24.3 m.
pub(super) const LOOSER: f64 = 3.0;

/// How much closer, in sum, the left-out loops' passes must come at the
/// looser odometry: 2 %, past the few centimetres a re-solved path moves
/// by where nothing changed.
const LOOSER_SHOWN: f64 = 0.98;

/// The final solve's result, to leave loops out of.
pub(super) struct Check<'a> {
    pub path: &'a Trajectory,
    /// The final solve's nodes, where each left-out solve starts.
    pub solution: &'a [Similarity3],
    /// The loop pieces kept by the final solve.
    pub active: &'a [bool],
    /// The loop each piece is of.
    pub owner: &'a [usize],
    /// Each loop whole, whose passes are measured.
    pub levelled: &'a [LoopClosure],
    pub max_iterations: usize,
}

impl Check<'_> {
    /// Whether `looser` (the graph at a looser odometry than `tight`)
    /// brings the passes of the loops `ids`, each left out in turn, closer
    /// in sum by [`LOOSER_SHOWN`].
    pub fn prefers(&self, tight: &PoseGraph, looser: &PoseGraph, ids: &[usize]) -> Result<bool> {
        // Every (graph, left-out loop) solve is independent: spread over the
        // cores. Each costs its set-up more than its iterations (a solve
        // capped at one iteration takes two thirds of the time of one run
        // to convergence), so the cap is the configured one.
        let cases: Vec<(bool, usize)> = [false, true]
            .into_iter()
            .flat_map(|loose| ids.iter().map(move |&id| (loose, id)))
            .collect();
        let distances = crate::parallel::map(&cases, |&(loose, id)| {
            let graph = if loose { looser } else { tight };
            let mut without = self.active.to_vec();
            for p in pieces_of(self.owner, id) {
                without[p] = false;
            }
            let solved = solve::optimise(graph, self.solution, &without, self.max_iterations);
            Some(solved.map(|s| {
                (
                    loose,
                    apart(&carry(self.path, graph, &s), &self.levelled[id]),
                )
            }))
        });
        let (mut tight_sum, mut loose_sum) = (0.0, 0.0);
        for d in distances {
            match d? {
                (true, d) => loose_sum += d,
                (false, d) => tight_sum += d,
            }
        }
        Ok(loose_sum < LOOSER_SHOWN * tight_sum)
    }
}

/// RMS distance from the query poses of `l` to the nearest of its match
/// poses, in `poses`.
fn apart(poses: &[Pose], l: &LoopClosure) -> f64 {
    let matched = &poses[l.match_range[0]..=l.match_range[1]];
    let (mut sum, mut n) = (0.0, 0.0f64);
    for q in &poses[l.query_range[0]..=l.query_range[1]] {
        let d = matched
            .iter()
            .map(|m| (m.position - q.position).norm_squared())
            .fold(f64::INFINITY, f64::min);
        sum += d;
        n += 1.0;
    }
    (sum / n.max(1.0)).sqrt()
}
