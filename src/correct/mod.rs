//! Drift correction: the path's own motion and its loops in one pose graph,
//! optimised robustly, give the path without the drift the loops reveal.
//!
//! ```text
//! path -> loop search (pipeline::find_loops, as `loops`) -> LoopClosure
//!      -> PoseGraph (keyframes, odometry edges, loop edges)
//!      -> solve (apex-solver, DCS on loops) -> residual gate -> re-solve
//!      -> every pose carried along by its keyframes
//! ```
//!
//! Robustness is in two layers: dynamic covariance scaling keeps a wrong
//! loop from dragging the solution while it is solved, and after each solve
//! the loop whose edges miss by the most sigmas is switched off and the
//! graph solved again, until every loop left fits within
//! [`CorrectConfig::reject_above`] sigmas. A loop switched off that fits the
//! final solution is switched back on.

// Frame names as in Sophus: `a_T_b` maps points from b to a.
#![allow(non_snake_case)]

pub mod config;
pub mod g2o;
pub mod graph;
pub mod loops;
pub mod solve;

pub use config::{CorrectConfig, Group, LoopNoise, OdometryNoise};
pub use graph::PoseGraph;
pub use loops::LoopClosure;

use crate::geometry::Similarity3;
use crate::trajectory::{Pose, Trajectory};
use crate::Result;
use nalgebra::{Rotation3, UnitQuaternion};

/// What became of one loop.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopVerdict {
    /// The loop as it entered the graph.
    pub closure: LoopClosure,
    /// Kept in the final solution.
    pub kept: bool,
    /// Median normalised residual of its edges in the final solution (in
    /// its sigmas); infinite when it has no edge.
    pub residual: f64,
}

/// A corrected path.
#[derive(Debug, Clone)]
pub struct Corrected {
    /// One pose per input pose, in order, with the input's timestamps;
    /// orientation corrected where the input has one.
    pub poses: Vec<Pose>,
    /// Every loop, kept or rejected, in input order.
    pub loops: Vec<LoopVerdict>,
    /// The group the graph was solved in.
    pub group: Group,
    /// The graph before optimisation.
    pub graph: PoseGraph,
}

impl Corrected {
    /// Loops kept.
    pub fn kept(&self) -> usize {
        self.loops.iter().filter(|l| l.kept).count()
    }

    /// The corrected path as a trajectory.
    pub fn trajectory(&self, source: impl Into<String>) -> Trajectory {
        Trajectory {
            source: source.into(),
            poses: self.poses.clone(),
        }
    }
}

/// Finds the loops of `path` with the loop search of `loops` and corrects
/// the path's drift with them.
pub fn correct(path: &Trajectory, config: &CorrectConfig) -> Result<Corrected> {
    let hypotheses = crate::pipeline::find_loops(path, &config.loops)?;
    let loops = hypotheses
        .iter()
        .map(|h| LoopClosure::from_hypothesis(path, h))
        .collect::<Result<Vec<_>>>()?;
    correct_with_loops(path, &loops, config)
}

/// Corrects the drift of `path` with the given loops.
pub fn correct_with_loops(
    path: &Trajectory,
    loops: &[LoopClosure],
    config: &CorrectConfig,
) -> Result<Corrected> {
    let graph = PoseGraph::build(path, loops, config)?;
    let has_edges: Vec<bool> = (0..loops.len())
        .map(|id| graph.loop_edges(id).next().is_some())
        .collect();
    // Loops enter best first, each solved from the solution of those before
    // it: a true loop then starts near its fit, a wrong one far from it.
    let mut order: Vec<usize> = (0..loops.len()).filter(|&id| has_edges[id]).collect();
    order.sort_by(|&a, &b| loops[b].score.total_cmp(&loops[a].score));
    let mut active = vec![false; loops.len()];
    let mut solution = graph.poses.clone();
    let mut rejected: Vec<usize> = Vec::new();
    let mut accepted_since = vec![0usize; loops.len()];
    let mut accepted = 0;
    let admit =
        |id: usize, active: &mut Vec<bool>, solution: &mut Vec<Similarity3>| -> Result<bool> {
            let mut trial = active.clone();
            trial[id] = true;
            let next = solve::optimise(&graph, solution, &trial, config.max_iterations)?;
            let fits = (0..loops.len())
                .filter(|&k| trial[k])
                .all(|k| residual(&graph, &next, k) <= config.reject_above);
            if fits {
                *active = trial;
                *solution = next;
            }
            Ok(fits)
        };
    for &id in &order {
        if admit(id, &mut active, &mut solution)? {
            accepted += 1;
        } else {
            rejected.push(id);
            accepted_since[id] = accepted;
        }
    }
    // A loop turned away before later loops bent the path may fit now.
    for &id in &rejected {
        if accepted > accepted_since[id] {
            admit(id, &mut active, &mut solution)?;
        }
    }
    let verdicts = loops
        .iter()
        .enumerate()
        .map(|(id, l)| LoopVerdict {
            closure: l.clone(),
            kept: active[id],
            residual: if has_edges[id] {
                residual(&graph, &solution, id)
            } else {
                f64::INFINITY
            },
        })
        .collect();
    Ok(Corrected {
        poses: carry(path, &graph, &solution),
        loops: verdicts,
        group: graph.group,
        graph,
    })
}

/// Median over the edges of loop `id` of the larger of the translation and
/// rotation misses, each in its sigmas (without the share that splits one
/// loop's information among its edges).
fn residual(graph: &PoseGraph, solution: &[Similarity3], id: usize) -> f64 {
    let mut r: Vec<f64> = graph
        .loop_edges(id)
        .map(|e| {
            let share = (graph.loop_edges(id).count() as f64).sqrt();
            let predicted = solution[e.from].compose(&e.from_T_to);
            let actual = &solution[e.to];
            let units = solution[e.from].scale;
            let dt = (predicted.translation - actual.translation).norm()
                / (units * e.sigmas.translation / share);
            let dr =
                crate::geometry::similarity::angle_between(&predicted.rotation, &actual.rotation)
                    / (e.sigmas.rotation / share);
            dt.max(dr)
        })
        .collect();
    if r.is_empty() {
        return f64::INFINITY;
    }
    r.sort_by(f64::total_cmp);
    r[r.len() / 2]
}

/// Every pose moved with its keyframes: a pose between keyframes `a` and `b`
/// takes the two keyframes' corrections blended by arc length, so the
/// corrected path stays continuous.
fn carry(path: &Trajectory, graph: &PoseGraph, solution: &[Similarity3]) -> Vec<Pose> {
    let positions = path.positions();
    let arc = graph::arc_length(&positions);
    // world_T_world' correction of each keyframe: corrected ∘ original⁻¹.
    let corrections: Vec<Similarity3> = graph
        .poses
        .iter()
        .zip(solution)
        .map(|(before, after)| after.compose(&before.inverse()))
        .collect();
    let mut node = 0;
    path.poses
        .iter()
        .enumerate()
        .map(|(i, pose)| {
            while node + 1 < graph.keyframes.len() - 1 && graph.keyframes[node + 1] <= i {
                node += 1;
            }
            let (a, b) = (node, (node + 1).min(graph.keyframes.len() - 1));
            let (sa, sb) = (arc[graph.keyframes[a]], arc[graph.keyframes[b]]);
            let w = if sb > sa {
                ((arc[i] - sa) / (sb - sa)).clamp(0.0, 1.0)
            } else if i >= graph.keyframes[b] {
                1.0
            } else {
                0.0
            };
            let (ca, cb) = (&corrections[a], &corrections[b]);
            let position = (1.0 - w) * ca.apply(&pose.position) + w * cb.apply(&pose.position);
            let orientation = pose.orientation.map(|q| {
                let ra =
                    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&ca.rotation));
                let rb =
                    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&cb.rotation));
                let r = ra.try_slerp(&rb, w, 1e-9).unwrap_or(ra);
                r * q
            });
            Pose {
                t: pose.t,
                position,
                orientation,
            }
        })
        .collect()
}
