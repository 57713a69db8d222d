//! Drift correction: the path's own motion and its loops in one pose graph,
//! optimised robustly, give the path without the drift the loops reveal.
//!
//! ```text
//! path -> loop search (pipeline::find_loops, as `loops`) -> LoopClosure
//!      -> PoseGraph (keyframes, odometry edges, loop edges)
//!      -> choice (apex-solver, DCS, residual gate, best loop first)
//!      -> drift measured from the chosen loops -> final solve
//!      -> every pose carried along by its keyframes
//! ```
//!
//! Loops are chosen under the odometry prior, an upper bound on drift:
//! they enter best score first, each solved robustly (dynamic covariance
//! scaling) from the solution before it and kept only if every kept loop
//! still fits within [`CorrectConfig::reject_above`] sigmas. The chosen
//! loops' misses against the uncorrected path then measure the drift the
//! path has (a maximum-likelihood factor on the prior's sigmas), and the
//! final solve, plain least squares with each loop trusted as far as its
//! own misfit says, moves the path only as far as that drift allows: loops
//! that show no drift beyond their own noise leave the path as it was.

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
    correct_again(path, loops, &[], config)
}

/// [`correct_with_loops`] for a path that has grown since a correction
/// that kept `kept` (by loop index; loops after them are new): the kept
/// loops enter together in one solve, and only the new ones and those
/// turned away before are tried one at a time (the online detector's
/// re-optimisation).
pub fn correct_again(
    path: &Trajectory,
    loops: &[LoopClosure],
    kept: &[bool],
    config: &CorrectConfig,
) -> Result<Corrected> {
    // Choice: loops admitted under the odometry prior (an upper bound on
    // drift) and the tolerant loop floor, robustly.
    let prior = PoseGraph::build(path, loops, config)?;
    let (chosen, _) = admit(&prior, loops, kept, config)?;
    // Measurement: the chosen loops' misses against the path say how much it
    // drifts, with each loop trusted as far as its own misfit says. A loop
    // that only reflects its own noise (a lane's offset on a path without
    // drift) then leaves the odometry stiff and the path as it was.
    let fit = CorrectConfig {
        loop_noise: LoopNoise {
            floor: config.loop_noise.fit_floor,
            ..config.loop_noise
        },
        ..config.clone()
    };
    let k = drift_scale(&PoseGraph::build(path, loops, &fit)?, &chosen);
    let graph = PoseGraph::build(
        path,
        loops,
        &CorrectConfig {
            odometry: config.odometry.scaled(k),
            ..fit
        },
    )?;
    let (active, solution) = settle(&graph, loops, chosen, config)?;
    let has_edges: Vec<bool> = (0..loops.len())
        .map(|id| graph.loop_edges(id).next().is_some())
        .collect();
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

/// Loops admitted one at a time, best score first, each solved warm from
/// the solution before it (a true loop then starts near its fit, a wrong
/// one far from it) and kept only if every kept loop still fits; loops
/// turned away are tried again once the others have bent the path.
fn admit(
    graph: &PoseGraph,
    loops: &[LoopClosure],
    kept: &[bool],
    config: &CorrectConfig,
) -> Result<(Vec<bool>, Vec<Similarity3>)> {
    let has_edges = |id: usize| graph.loop_edges(id).next().is_some();
    let mut active = vec![false; loops.len()];
    let mut solution = graph.poses.clone();
    // Loops kept before enter together when they still fit together.
    let before: Vec<bool> = (0..loops.len())
        .map(|id| kept.get(id).copied().unwrap_or(false) && has_edges(id))
        .collect();
    let mut warm = false;
    if before.iter().any(|k| *k) {
        let next = solve::optimise(graph, &solution, &before, true, config.max_iterations)?;
        if (0..loops.len())
            .filter(|&k| before[k])
            .all(|k| residual(graph, &next, k) <= config.reject_above)
        {
            active = before;
            solution = next;
            warm = true;
        }
    }
    // From a warm start, loops turned away before are tried again only if
    // a new loop is accepted (only then can they fit better than before).
    let old = if warm { kept.len().min(loops.len()) } else { 0 };
    let mut order: Vec<usize> = (old..loops.len()).filter(|&id| has_edges(id)).collect();
    order.sort_by(|&a, &b| loops[b].score.total_cmp(&loops[a].score));
    let mut rejected: Vec<usize> = (0..old)
        .filter(|&id| has_edges(id) && !active[id])
        .collect();
    let mut accepted_since = vec![0usize; loops.len()];
    let mut accepted = 0;
    let try_one =
        |id: usize, active: &mut Vec<bool>, solution: &mut Vec<Similarity3>| -> Result<bool> {
            let mut trial = active.clone();
            trial[id] = true;
            let next = solve::optimise(graph, solution, &trial, true, config.max_iterations)?;
            let fits = (0..loops.len())
                .filter(|&k| trial[k])
                .all(|k| residual(graph, &next, k) <= config.reject_above);
            if fits {
                *active = trial;
                *solution = next;
            }
            Ok(fits)
        };
    for &id in &order {
        if try_one(id, &mut active, &mut solution)? {
            accepted += 1;
        } else {
            rejected.push(id);
            accepted_since[id] = accepted;
        }
    }
    for &id in &rejected {
        if accepted > accepted_since[id] {
            try_one(id, &mut active, &mut solution)?;
        }
    }
    Ok((active, solution))
}

/// The chosen loops solved by plain least squares under the measured
/// odometry noise (the choice already turned the gross outliers away, and
/// a robust loss would hold back a true loop that starts many of its sigmas
/// off); the loop that misses by the most sigmas, if above the gate, is
/// switched off and the graph solved again.
fn settle(
    graph: &PoseGraph,
    loops: &[LoopClosure],
    mut active: Vec<bool>,
    config: &CorrectConfig,
) -> Result<(Vec<bool>, Vec<Similarity3>)> {
    loop {
        if !active.iter().any(|a| *a) {
            return Ok((active, graph.poses.clone()));
        }
        let solution = solve::optimise(graph, &graph.poses, &active, false, config.max_iterations)?;
        let worst = (0..loops.len())
            .filter(|&id| active[id])
            .map(|id| (id, residual(graph, &solution, id)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            Some((id, r)) if r > config.reject_above => active[id] = false,
            _ => return Ok((active, solution)),
        }
    }
}

/// Least drift scale searched: at a ten-thousandth of the prior's sigmas
/// the odometry is rigid next to any loop, which is the answer when the
/// loops show no drift beyond their own noise.
const MIN_DRIFT_SCALE: f64 = 1e-4;

/// Maximum-likelihood factor `k` in (0, 1] on the odometry prior's sigmas,
/// from the loops in `active`: each loop's miss against the uncorrected
/// path, `d` (its edges' mean squared translation miss), is modelled per
/// axis as `k² V / 3 + σ²`, where `σ` is the loop's own sigma and `V` the
/// prior's variance of the odometry chain between its two poses (the
/// translation random walk plus the heading random walk's lever to the far
/// pose). The likelihood `Σ -3/2 ln v - d / (2 v)` is maximised on a log grid
/// of tenths of a decade; 1 when no loop is active.
fn drift_scale(graph: &PoseGraph, active: &[bool]) -> f64 {
    let mut samples: Vec<(f64, f64, f64)> = Vec::new();
    for (id, _) in active.iter().enumerate().filter(|(_, &a)| a) {
        let edges: Vec<&graph::Edge> = graph.loop_edges(id).collect();
        let share2 = edges.len() as f64;
        let (mut d, mut v, mut s) = (0.0, 0.0, 0.0);
        for e in &edges {
            let odo = graph.poses[e.from].inverse().compose(&graph.poses[e.to]);
            d += (e.from_T_to.translation - odo.translation).norm_squared();
            s += e.sigmas.translation.powi(2) / share2;
            let far = graph.poses[e.to].translation;
            let (a, b) = (e.from.min(e.to), e.from.max(e.to));
            for o in &graph.edges[a..b] {
                let lever = (far - graph.poses[o.from].translation).norm_squared();
                v += 3.0 * o.sigmas.translation.powi(2) + 2.0 * o.sigmas.rotation.powi(2) * lever;
            }
        }
        let n = edges.len().max(1) as f64;
        samples.push((d / n, v / n, s / n));
    }
    if samples.is_empty() {
        return 1.0;
    }
    let log_likelihood = |k: f64| -> f64 {
        samples
            .iter()
            .map(|&(d, v, s)| {
                let var = k * k * v / 3.0 + s;
                -1.5 * var.ln() - d / (2.0 * var)
            })
            .sum()
    };
    let steps = (MIN_DRIFT_SCALE.log10().abs() * 10.0).round() as i32;
    (0..=steps)
        .map(|i| 10f64.powf(-(i as f64) / 10.0))
        .max_by(|&a, &b| log_likelihood(a).total_cmp(&log_likelihood(b)))
        .unwrap_or(1.0)
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
