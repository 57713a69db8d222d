//! apex-solver, factrs and tiny-solver (and turnprint's own solve path,
//! `correct::solve::optimise`, which is apex-solver behind turnprint's
//! isotropic sigmas) on the same g2o pose graphs, for the choice of the
//! solver behind turnprint's drift correction. Prints a Markdown table:
//! initial and final cost, iterations, wall time of the solve alone.
//!
//! ```text
//! cargo run --release -- GRAPH.g2o...
//! ```
//!
//! Every solver starts from the file's vertices and runs Levenberg-Marquardt
//! for at most 100 iterations with its own defaults otherwise. Each is judged
//! by one objective, computed here with apex-solver's Lie groups whatever
//! the solver minimised: 0.5 · Σ rᵀ Ω r with r the full logarithm of the
//! edge's error (`(T_from⁻¹ T_to)⁻¹ · measured`) and Ω the file's
//! information, GTSAM's `graph.error`. Graphs are read with each solver's own
//! g2o loader where it has one that keeps the information (apex-solver's
//! `G2oLoader`, factrs' `load_g20`); tiny-solver's `read_g2o` drops the
//! information and puts a Huber loss on every edge, so its problem is built
//! here from apex-solver's parse, each residual whitened by the square root
//! of the (diagonal) information. tiny-solver's SE(3) residual takes the
//! translation of the error as it is, not through the left Jacobian, so it
//! minimises a slightly different objective; the common judge shows what that
//! costs.

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use apex_solver::apex_io::{G2oLoader, Graph, GraphLoader};
use apex_solver::core::problem::Problem;
use apex_solver::factors::pose::BetweenFactor;
use apex_solver::manifold::se2::SE2;
use apex_solver::manifold::se3::SE3;
use apex_solver::manifold::{LieGroup, Tangent};
use apex_solver::optimizer::levenberg_marquardt::{LevenbergMarquardt, LevenbergMarquardtConfig};
use apex_solver::{JacobianMode, ManifoldType, NoiseModel};
use nalgebra_apex as na;

const MAX_ITERATIONS: usize = 100;

/// Node poses in apex-solver's types: one of the two per graph.
#[derive(Clone)]
enum Poses {
    Se2(Vec<SE2>),
    Se3(Vec<SE3>),
}

/// One solver's outcome on one graph.
struct Row {
    solver: &'static str,
    initial: f64,
    fin: Option<f64>,
    iterations: Option<usize>,
    seconds: Option<f64>,
    note: String,
}

fn main() {
    let files: Vec<String> = std::env::args().skip(1).collect();
    if files.is_empty() {
        eprintln!("usage: solver-compare GRAPH.g2o...");
        std::process::exit(2);
    }
    log::set_boxed_logger(Box::new(IterationCounter)).expect("one logger");
    log::set_max_level(log::LevelFilter::Off);
    println!("| graph | nodes | edges | solver | initial cost | final cost | iterations | time (s) | note |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for file in &files {
        let graph = match G2oLoader::load(file) {
            Ok(g) => g,
            Err(e) => {
                eprintln!("{file}: {e:?}");
                continue;
            }
        };
        let name = std::path::Path::new(file)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let start = start_poses(&graph);
        let initial = judge(&graph, &start);
        let rows = [
            run_apex(&graph, &start, initial),
            run_turnprint(file, &graph, initial),
            run_factrs(file, &graph, initial),
            run_tiny(&graph, &start, initial),
        ];
        for r in rows {
            println!(
                "| {name} | {} | {} | {} | {:.6e} | {} | {} | {} | {} |",
                graph.vertex_count(),
                graph.edge_count(),
                r.solver,
                r.initial,
                r.fin.map_or("-".into(), |c| format!("{c:.6e}")),
                r.iterations.map_or("-".into(), |i| i.to_string()),
                r.seconds.map_or("-".into(), |s| format!("{s:.3}")),
                r.note
            );
        }
    }
}

/// Node ids 0..n-1 as the g2o files here have them.
fn start_poses(g: &Graph) -> Poses {
    if g.vertices_se3.is_empty() {
        let n = g.vertices_se2.len();
        Poses::Se2((0..n).map(|i| g.vertices_se2[&i].pose.clone()).collect())
    } else {
        let n = g.vertices_se3.len();
        Poses::Se3((0..n).map(|i| g.vertices_se3[&i].pose.clone()).collect())
    }
}

/// 0.5 · Σ rᵀ Ω r over every edge of `g` at `poses`.
fn judge(g: &Graph, poses: &Poses) -> f64 {
    match poses {
        Poses::Se3(p) => g
            .edges_se3
            .iter()
            .map(|e| {
                let r = p[e.to]
                    .between(&p[e.from], None, None)
                    .compose(&e.measurement, None, None)
                    .log(None);
                let r = na::Vector6::from_column_slice(r.as_slice());
                0.5 * (r.transpose() * e.information * r)[(0, 0)]
            })
            .sum(),
        Poses::Se2(p) => g
            .edges_se2
            .iter()
            .map(|e| {
                let r = p[e.to]
                    .between(&p[e.from], None, None)
                    .compose(&e.measurement, None, None)
                    .log(None);
                let r = na::Vector3::from_column_slice(r.as_slice());
                0.5 * (r.transpose() * e.information * r)[(0, 0)]
            })
            .sum(),
    }
}

fn unavailable(solver: &'static str, initial: f64, note: impl Into<String>) -> Row {
    Row {
        solver,
        initial,
        fin: None,
        iterations: None,
        seconds: None,
        note: note.into(),
    }
}

/// apex-solver as turnprint configures it (`correct::solve`), with the
/// file's full information.
fn run_apex(g: &Graph, start: &Poses, initial: f64) -> Row {
    let mut problem = Problem::new(JacobianMode::Sparse);
    let (keys, dof) = match start {
        Poses::Se3(p) => (
            p.iter()
                .map(|x| {
                    let v = na::DVector::from_column_slice(x.as_param_slice());
                    problem.add_variable(ManifoldType::SE3, v)
                })
                .collect::<Vec<_>>(),
            6,
        ),
        Poses::Se2(p) => (
            p.iter()
                .map(|x| {
                    let v = na::DVector::from_column_slice(x.as_param_slice());
                    problem.add_variable(ManifoldType::SE2, v)
                })
                .collect::<Vec<_>>(),
            3,
        ),
    };
    for idx in 0..dof {
        problem.fix_variable(keys[0], idx);
    }
    let added: Result<(), String> = (|| {
        for e in &g.edges_se3 {
            let info = na::DMatrix::from_column_slice(6, 6, e.information.as_slice());
            let noise = NoiseModel::from_information(info).map_err(|e| format!("{e}"))?;
            problem
                .try_add_residual_block_with_noise(
                    &[keys[e.from], keys[e.to]],
                    Box::new(BetweenFactor::new(e.measurement.clone())),
                    None,
                    noise,
                )
                .map_err(|e| format!("{e}"))?;
        }
        for e in &g.edges_se2 {
            let info = na::DMatrix::from_column_slice(3, 3, e.information.as_slice());
            let noise = NoiseModel::from_information(info).map_err(|e| format!("{e}"))?;
            problem
                .try_add_residual_block_with_noise(
                    &[keys[e.from], keys[e.to]],
                    Box::new(BetweenFactor::new(e.measurement.clone())),
                    None,
                    noise,
                )
                .map_err(|e| format!("{e}"))?;
        }
        Ok(())
    })();
    if let Err(e) = added {
        return unavailable("apex-solver 1.5", initial, e);
    }
    let config = LevenbergMarquardtConfig::new()
        .with_max_iterations(MAX_ITERATIONS)
        .with_cost_tolerance(1e-9)
        .with_parameter_tolerance(1e-9);
    let t = Instant::now();
    let result = LevenbergMarquardt::with_config(config).optimize(&mut problem);
    let seconds = t.elapsed().as_secs_f64();
    match result {
        Ok(r) => {
            let values: Vec<Vec<f64>> = keys
                .iter()
                .map(|k| r.parameters[*k].as_param_slice().to_vec())
                .collect();
            let poses = match start {
                Poses::Se3(_) => {
                    Poses::Se3(values.iter().map(|v| SE3::from_param_slice(v)).collect())
                }
                Poses::Se2(_) => {
                    Poses::Se2(values.iter().map(|v| SE2::from_param_slice(v)).collect())
                }
            };
            Row {
                solver: "apex-solver 1.5",
                initial,
                fin: Some(judge(g, &poses)),
                iterations: Some(r.iterations),
                seconds: Some(seconds),
                note: format!("{:?}", r.status),
            }
        }
        Err(e) => unavailable("apex-solver 1.5", initial, format!("failed: {e}")),
    }
}

/// turnprint's reader and solve path: isotropic sigmas per block, 2D
/// lifted to 3D.
fn run_turnprint(file: &str, g: &Graph, initial: f64) -> Row {
    use turnprint::correct::g2o::from_g2o;
    use turnprint::correct::solve::optimise;
    let text = match std::fs::read_to_string(file) {
        Ok(t) => t,
        Err(e) => return unavailable("turnprint (apex)", initial, e.to_string()),
    };
    let graph = match from_g2o(&text) {
        Ok(x) => x,
        Err(e) => return unavailable("turnprint (apex)", initial, format!("not expressible: {e}")),
    };
    let t = Instant::now();
    let solution = optimise(&graph, &graph.poses, &[], MAX_ITERATIONS);
    let seconds = t.elapsed().as_secs_f64();
    let solution = match solution {
        Ok(s) => s,
        Err(e) => return unavailable("turnprint (apex)", initial, format!("failed: {e}")),
    };
    let poses = if g.vertices_se3.is_empty() {
        Poses::Se2(
            solution
                .iter()
                .map(|p| {
                    SE2::from_xy_angle(
                        p.translation.x,
                        p.translation.y,
                        p.rotation[(1, 0)].atan2(p.rotation[(0, 0)]),
                    )
                })
                .collect(),
        )
    } else {
        Poses::Se3(solution.iter().map(apex_se3).collect())
    };
    Row {
        solver: "turnprint (apex)",
        initial,
        fin: Some(judge(g, &poses)),
        iterations: None,
        seconds: Some(seconds),
        note: "`solve::optimise` reports no iterations".into(),
    }
}

fn apex_se3(p: &turnprint::geometry::Similarity3) -> SE3 {
    let r = nalgebra_tiny::Rotation3::from_matrix(&p.rotation);
    let q = nalgebra_tiny::UnitQuaternion::from_rotation_matrix(&r);
    SE3::new(
        na::Vector3::new(p.translation.x, p.translation.y, p.translation.z),
        na::UnitQuaternion::new_unchecked(na::Quaternion::new(q.w, q.i, q.j, q.k)),
    )
}

/// Counts factrs' steps.
struct StepCounter(Arc<AtomicUsize>);

impl factrs::optimizers::OptObserver for StepCounter {
    fn on_step(&self, _values: &factrs::containers::Values, _time: i64) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }
}

fn run_factrs(file: &str, g: &Graph, initial: f64) -> Row {
    use factrs::traits::Optimizer;
    use factrs::utils::X;
    let (graph, values) = factrs::utils::load_g20(file);
    let params = factrs::optimizers::LevenParams {
        base: factrs::optimizers::BaseOptParams {
            max_iterations: MAX_ITERATIONS,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut opt = factrs::optimizers::LevenMarquardt::new(params, graph);
    let steps = Arc::new(AtomicUsize::new(0));
    opt.observers_mut().add(StepCounter(steps.clone()));
    let n = g.vertex_count();
    let t = Instant::now();
    let result = opt.optimize(values);
    let seconds = t.elapsed().as_secs_f64();
    let (values, note) = match result {
        Ok(v) => (v, String::from("converged")),
        Err(factrs::optimizers::OptError::MaxIterations(v)) => (v, "iteration cap".into()),
        Err(e) => return unavailable("factrs 0.3", initial, format!("failed: {e:?}")),
    };
    let poses = if g.vertices_se3.is_empty() {
        Poses::Se2(
            (0..n)
                .map(|i| {
                    let p: &factrs::variables::SE2 = values.get(X(i as u32)).expect("node");
                    SE2::from_xy_angle(p.x(), p.y(), p.theta())
                })
                .collect(),
        )
    } else {
        Poses::Se3(
            (0..n)
                .map(|i| {
                    let p: &factrs::variables::SE3 = values.get(X(i as u32)).expect("node");
                    let (r, t) = (p.rot(), p.xyz());
                    SE3::new(
                        na::Vector3::new(t[0], t[1], t[2]),
                        na::UnitQuaternion::new_normalize(na::Quaternion::new(
                            r.w(),
                            r.x(),
                            r.y(),
                            r.z(),
                        )),
                    )
                })
                .collect(),
        )
    };
    Row {
        solver: "factrs 0.3",
        initial,
        fin: Some(judge(g, &poses)),
        iterations: Some(steps.load(Ordering::Relaxed)),
        seconds: Some(seconds),
        note,
    }
}

/// A tiny-solver factor with its residual scaled component-wise.
struct Whitened<F> {
    inner: F,
    weights: Vec<f64>,
}

impl<F, T> tiny_solver::factors::Factor<T> for Whitened<F>
where
    F: tiny_solver::factors::Factor<T>,
    T: nalgebra_tiny::RealField,
{
    fn residual_func(&self, params: &[nalgebra_tiny::DVector<T>]) -> nalgebra_tiny::DVector<T> {
        let mut r = self.inner.residual_func(params);
        for (v, w) in r.iter_mut().zip(&self.weights) {
            *v = v.clone() * T::from_f64(*w).expect("a weight");
        }
        r
    }
}

/// Counts tiny-solver's iterations from its trace log ("iter:").
struct IterationCounter;
static TINY_ITERATIONS: AtomicUsize = AtomicUsize::new(0);

impl log::Log for IterationCounter {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.target().starts_with("tiny_solver")
    }
    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) && record.args().to_string().starts_with("iter:") {
            TINY_ITERATIONS.fetch_add(1, Ordering::Relaxed);
        }
    }
    fn flush(&self) {}
}

fn diagonal<const D: usize>(m: &na::SMatrix<f64, D, D>) -> Option<Vec<f64>> {
    let off = (0..D)
        .flat_map(|i| (0..D).filter(move |&j| j != i).map(move |j| (i, j)))
        .any(|(i, j)| m[(i, j)] != 0.0);
    (!off).then(|| (0..D).map(|i| m[(i, i)].sqrt()).collect())
}

fn run_tiny(g: &Graph, start: &Poses, initial: f64) -> Row {
    use nalgebra_tiny as nt;
    use tiny_solver::factors::{BetweenFactorSE2, BetweenFactorSE3, PriorFactor};
    use tiny_solver::optimizer::Optimizer;
    let mut problem = tiny_solver::Problem::new();
    let mut values: HashMap<String, nt::DVector<f64>> = HashMap::new();
    let name = |i: usize| format!("x{i}");
    match start {
        Poses::Se3(p) => {
            for (i, x) in p.iter().enumerate() {
                let (t, q) = (x.translation(), x.rotation_quaternion());
                problem.set_variable_manifold(
                    &name(i),
                    Arc::new(tiny_solver::manifold::se3::SE3Manifold),
                );
                values.insert(
                    name(i),
                    nt::DVector::from_vec(vec![q.i, q.j, q.k, q.w, t.x, t.y, t.z]),
                );
            }
            for e in &g.edges_se3 {
                let Some(w) = diagonal(&e.information) else {
                    return unavailable(
                        "tiny-solver 0.18",
                        initial,
                        "not expressed: full information",
                    );
                };
                let (t, q) = (
                    e.measurement.translation(),
                    e.measurement.rotation_quaternion(),
                );
                let between = BetweenFactorSE3 {
                    dtx: t.x,
                    dty: t.y,
                    dtz: t.z,
                    dqx: q.i,
                    dqy: q.j,
                    dqz: q.k,
                    dqw: q.w,
                };
                // tiny-solver's SE(3) residual is rotation first.
                let weights = vec![w[3], w[4], w[5], w[0], w[1], w[2]];
                problem.add_residual_block(
                    6,
                    &[&name(e.from), &name(e.to)],
                    Box::new(Whitened {
                        inner: between,
                        weights,
                    }),
                    None,
                );
            }
        }
        Poses::Se2(p) => {
            for (i, x) in p.iter().enumerate() {
                values.insert(
                    name(i),
                    nt::DVector::from_vec(vec![x.angle(), x.x(), x.y()]),
                );
            }
            for e in &g.edges_se2 {
                let Some(w) = diagonal(&e.information) else {
                    return unavailable(
                        "tiny-solver 0.18",
                        initial,
                        "not expressed: full information",
                    );
                };
                let m = &e.measurement;
                let between = BetweenFactorSE2 {
                    dx: m.x(),
                    dy: m.y(),
                    dtheta: m.angle(),
                };
                problem.add_residual_block(
                    3,
                    &[&name(e.from), &name(e.to)],
                    Box::new(Whitened {
                        inner: between,
                        weights: w,
                    }),
                    None,
                );
            }
        }
    }
    // The gauge: node 0 held by a stiff prior at its start (a manifold
    // variable's fixed indices are ignored by tiny-solver).
    let x0 = values[&name(0)].clone();
    let dim = x0.len();
    problem.add_residual_block(
        dim,
        &[&name(0)],
        Box::new(Whitened {
            inner: PriorFactor { v: x0 },
            weights: vec![1e6; dim],
        }),
        None,
    );
    let options = tiny_solver::OptimizerOptions {
        max_iteration: MAX_ITERATIONS,
        ..Default::default()
    };
    TINY_ITERATIONS.store(0, Ordering::Relaxed);
    log::set_max_level(log::LevelFilter::Trace);
    let t = Instant::now();
    let result = tiny_solver::LevenbergMarquardtOptimizer::default().optimize(
        &problem,
        &values,
        Some(options),
    );
    let seconds = t.elapsed().as_secs_f64();
    log::set_max_level(log::LevelFilter::Off);
    let Some(result) = result else {
        return unavailable("tiny-solver 0.18", initial, "failed (no solution)");
    };
    let n = g.vertex_count();
    let poses = match start {
        Poses::Se3(_) => Poses::Se3(
            (0..n)
                .map(|i| {
                    let v = &result[&name(i)];
                    SE3::new(
                        na::Vector3::new(v[4], v[5], v[6]),
                        na::UnitQuaternion::new_normalize(na::Quaternion::new(
                            v[3], v[0], v[1], v[2],
                        )),
                    )
                })
                .collect(),
        ),
        Poses::Se2(_) => Poses::Se2(
            (0..n)
                .map(|i| {
                    let v = &result[&name(i)];
                    SE2::from_xy_angle(v[1], v[2], v[0])
                })
                .collect(),
        ),
    };
    Row {
        solver: "tiny-solver 0.18",
        initial,
        fin: Some(judge(g, &poses)),
        iterations: Some(TINY_ITERATIONS.load(Ordering::Relaxed)),
        seconds: Some(seconds),
        note: "residuals whitened here".into(),
    }
}
