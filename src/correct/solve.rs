//! Optimisation of a [`PoseGraph`] with apex-solver: Levenberg-Marquardt on
//! SE(3) or Sim(3) nodes, the first node held fixed, plain least squares
//! (the loops at odds with the rest are turned away before, by the rise of
//! the cost they bring: `correct::admit`), and the graph's cost at any
//! poses ([`cost`]), the objective it minimises.

use super::config::Group;
use super::graph::{Edge, PoseGraph};
use super::sim3_between::Sim3Between;
use crate::geometry::{nearest_rotation, Similarity3};
use crate::{Error, Result};
use apex_solver::core::problem::Problem;
use apex_solver::factors::pose::BetweenFactor;
use apex_solver::manifold::se3::SE3;
use apex_solver::manifold::sim3::Sim3;
use apex_solver::manifold::{LieGroup, Tangent};
use apex_solver::optimizer::levenberg_marquardt::{LevenbergMarquardt, LevenbergMarquardtConfig};
use apex_solver::{JacobianMode, ManifoldType, NoiseModel};
use nalgebra::{UnitQuaternion, Vector3};
use nalgebra_apex as na;

/// Relative change of the cost (and of the parameters) below which a solve
/// stops: 1e-6. A millionth of the cost is far below the loops' own noise:
/// every KITTI estimate's corrected APE is the same to the centimetre as
/// with 1e-9, and the solves take three quarters of the time
/// (`cargo bench --bench correct`).
const COST_TOLERANCE: f64 = 1e-6;

/// The optimised `world_T_node` of every node, starting from `start`, using
/// the odometry edges and the loop edges whose loop is in `active`.
pub fn optimise(
    graph: &PoseGraph,
    start: &[Similarity3],
    active: &[bool],
    max_iterations: usize,
) -> Result<Vec<Similarity3>> {
    let mut problem = Problem::new(JacobianMode::Sparse);
    let keys: Vec<_> = start
        .iter()
        .map(|p| match graph.group {
            Group::Sim3 => problem.add_variable(ManifoldType::Sim3, params(p, true)),
            _ => problem.add_variable(ManifoldType::SE3, params(p, false)),
        })
        .collect();
    let dof = graph.group.dof();
    // The gauge: the path's first pose stays where it was.
    for idx in 0..dof {
        problem.fix_variable(keys[0], idx);
    }
    for e in &graph.edges {
        if let Some(id) = e.loop_id {
            if !active.get(id).copied().unwrap_or(false) {
                continue;
            }
        }
        let (factor, noise) = factor(e, graph.group)?;
        problem
            .try_add_residual_block_with_noise(&[keys[e.from], keys[e.to]], factor, None, noise)
            .map_err(solver_error)?;
    }
    let config = LevenbergMarquardtConfig::new()
        .with_max_iterations(max_iterations)
        .with_cost_tolerance(COST_TOLERANCE)
        .with_parameter_tolerance(COST_TOLERANCE);
    let result = LevenbergMarquardt::with_config(config)
        .optimize(&mut problem)
        .map_err(solver_error)?;
    keys.iter()
        .map(|k| {
            let v = result
                .parameters
                .get(*k)
                .ok_or_else(|| solver_error("a node is missing from the solution"))?;
            Ok(from_params(v.as_param_slice()))
        })
        .collect()
}

fn solver_error(e: impl std::fmt::Display) -> Error {
    Error::input("pose graph", format!("optimisation failed: {e}"))
}

type Factor = Box<dyn apex_solver::Factor + Send + Sync>;

/// The between factor and whitening of one edge.
fn factor(e: &Edge, group: Group) -> Result<(Factor, NoiseModel)> {
    let s = e.sigmas;
    let m = &e.from_T_to;
    let sim3 = group == Group::Sim3;
    let factor: Factor = if sim3 {
        Box::new(Sim3Between::new(sim(m)))
    } else {
        Box::new(BetweenFactor::new(se3(m)))
    };
    let noise = if !s.isotropic() {
        let w = s.sqrt_information(sim3);
        NoiseModel::from_sqrt_info(na::DMatrix::from_fn(w.nrows(), w.ncols(), |i, j| w[(i, j)]))
    } else {
        let mut sigmas = vec![s.translation; 3];
        sigmas.extend([s.rotation; 3]);
        if sim3 {
            sigmas.push(s.log_scale);
        }
        NoiseModel::from_sigmas(&sigmas)
    }
    .map_err(solver_error)?;
    Ok((factor, noise))
}

fn quaternion(p: &Similarity3) -> UnitQuaternion<f64> {
    UnitQuaternion::from_rotation_matrix(&nearest_rotation(&p.rotation))
}

/// apex-solver's parameters: `[t, qw, qx, qy, qz]` and, for Sim(3), `s`.
fn params(p: &Similarity3, with_scale: bool) -> na::DVector<f64> {
    let q = quaternion(p);
    let t = p.translation;
    let mut v = vec![t.x, t.y, t.z, q.w, q.i, q.j, q.k];
    if with_scale {
        v.push(p.scale);
    }
    na::DVector::from_vec(v)
}

fn from_params(v: &[f64]) -> Similarity3 {
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(v[3], v[4], v[5], v[6]));
    Similarity3 {
        scale: v.get(7).copied().unwrap_or(1.0),
        rotation: *q.to_rotation_matrix().matrix(),
        translation: Vector3::new(v[0], v[1], v[2]),
    }
}

/// 0.5 · Σ over `graph`'s edges of the squared whitened residual at `poses`:
/// the objective apex-solver minimises (the residual of an edge `i -> j` is
/// the Lie logarithm of `(world_T_i⁻¹ world_T_j)⁻¹ · i_T_j`, translation
/// through the group's left Jacobian, each component over its sigma), equal
/// to GTSAM's `graph.error(values)` and half g2o's χ². Every edge counts,
/// loop edges included.
/// NaN when `poses` does not hold every node an edge names.
pub fn cost(graph: &PoseGraph, poses: &[Similarity3]) -> f64 {
    cost_of(graph, poses, |_| true)
}

/// [`cost`] over the edges `keep` admits.
pub fn cost_of(graph: &PoseGraph, poses: &[Similarity3], keep: impl Fn(&Edge) -> bool) -> f64 {
    let sim3 = graph.group == Group::Sim3;
    graph
        .edges
        .iter()
        .filter(|e| keep(e))
        .map(|e| {
            if e.from.max(e.to) >= poses.len() {
                return f64::NAN;
            }
            let s = e.sigmas;
            let r: Vec<f64> = if sim3 {
                let (a, b, m) = (sim(&poses[e.from]), sim(&poses[e.to]), sim(&e.from_T_to));
                b.between(&a, None, None)
                    .compose(&m, None, None)
                    .log(None)
                    .as_slice()
                    .to_vec()
            } else {
                let (a, b, m) = (se3(&poses[e.from]), se3(&poses[e.to]), se3(&e.from_T_to));
                b.between(&a, None, None)
                    .compose(&m, None, None)
                    .log(None)
                    .as_slice()
                    .to_vec()
            };
            let whitened = s.sqrt_information(sim3) * nalgebra::DVector::from_vec(r);
            0.5 * whitened.norm_squared()
        })
        .sum()
}

fn apex_parts(p: &Similarity3) -> (na::Vector3<f64>, na::UnitQuaternion<f64>) {
    let q = quaternion(p);
    let t = p.translation;
    (
        na::Vector3::new(t.x, t.y, t.z),
        na::UnitQuaternion::new_unchecked(na::Quaternion::new(q.w, q.i, q.j, q.k)),
    )
}

fn se3(p: &Similarity3) -> SE3 {
    let (t, q) = apex_parts(p);
    SE3::new(t, q)
}

fn sim(p: &Similarity3) -> Sim3 {
    let (t, q) = apex_parts(p);
    Sim3::new(t, q, p.scale)
}
