//! turnprint's pose-graph solver (`correct::solve::optimise`, apex-solver
//! Levenberg-Marquardt, plain least squares, node 0 held) against GTSAM
//! 4.3.0's Levenberg-Marquardt (`scripts/crosscheck/gtsam_solve.py`) on the
//! same g2o graphs: the final costs (0.5 · Σ whitened residual², GTSAM's
//! `graph.error`) within 1 %, and the initial costs within 1e-6, which
//! checks that both evaluate one objective. Skips without a Python that has
//! GTSAM (`scripts/setup.sh` makes one) except under `CI=true`.
//!
//! Graphs: turnprint's own graph of KITTI 00 (MULLS without loop closure and
//! S-PTAM, exported as `turnprint correct --g2o` does, every loop's edges
//! included and solved in L2 on both sides), and GTSAM's city10000 from the
//! wheel's data (converted to g2o by the script, lifted to 3D on both
//! sides). GTSAM's w10000 and sphere2500 are left out: see BENCHMARKS.md
//! ("Pose-graph solvers") for why.

mod crosscheck_support;

use std::path::Path;
use std::time::Instant;

use crosscheck_support::{num, python_with, run_json, shared, within};
use turnprint::correct::g2o::{cost, from_g2o, to_g2o};
use turnprint::correct::solve::optimise;
use turnprint::correct::{correct, CorrectConfig};
use turnprint::io::{read_trajectory, Format};

/// GTSAM's default iteration cap, used on both sides.
const MAX_ITERATIONS: usize = 100;

/// Solves `file` with both solvers and asserts agreement.
fn compare(python: &Path, file: &Path, two_d: bool) {
    let text = std::fs::read_to_string(file).expect("graph written");
    let graph = from_g2o(&text).expect("turnprint reads the graph");
    let initial = cost(&graph, &graph.poses);
    let start = Instant::now();
    let solution = optimise(&graph, &graph.poses, &[], MAX_ITERATIONS).expect("solves");
    let seconds = start.elapsed().as_secs_f64();
    let fin = cost(&graph, &solution);
    let mut args = vec!["solve", file.to_str().unwrap()];
    if two_d {
        args.extend(["--2d", "--lift"]);
    }
    let iterations = MAX_ITERATIONS.to_string();
    args.extend(["--max-iterations", &iterations]);
    let gtsam = run_json(python, "gtsam_solve.py", &args);
    let name = file.file_name().unwrap().to_string_lossy();
    eprintln!(
        "{name}: initial {initial:.6} (GTSAM {:.6}), final {fin:.6} in {seconds:.2} s \
         (GTSAM {:.6} in {:.2} s, {} iterations)",
        num(&gtsam, "initial_cost"),
        num(&gtsam, "final_cost"),
        num(&gtsam, "time_s"),
        gtsam["iterations"]
    );
    assert_eq!(gtsam["edges"].as_u64(), Some(graph.edges.len() as u64));
    assert!(
        within(initial, num(&gtsam, "initial_cost"), 1e-6),
        "{name}: initial cost {initial} vs GTSAM {}",
        num(&gtsam, "initial_cost")
    );
    assert!(
        within(fin, num(&gtsam, "final_cost"), 0.01),
        "{name}: final cost {fin} vs GTSAM {}",
        num(&gtsam, "final_cost")
    );
}

fn scratch() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary directory")
}

#[test]
fn kitti_00_graphs_solve_to_gtsams_cost() {
    let Some(python) = python_with("gtsam") else {
        return;
    };
    let dir = scratch();
    for estimate in [
        "odometry/kitti_mulls_dso/mulls_no_loop/00.txt",
        "evo/KITTI_00_SPTAM.txt",
    ] {
        let Some(path) = shared(estimate) else {
            return;
        };
        let path_in = read_trajectory(&path, Format::Kitti).expect("readable");
        let corrected = correct(&path_in, &CorrectConfig::default()).expect("corrects");
        let file = dir
            .path()
            .join(format!("{}.g2o", estimate.replace('/', "_")));
        std::fs::write(&file, to_g2o(&corrected.graph)).expect("writable");
        compare(&python, &file, false);
    }
}

#[test]
fn city10000_solves_to_gtsams_cost() {
    let Some(python) = python_with("gtsam") else {
        return;
    };
    let dir = scratch();
    let file = dir.path().join("city10000.g2o");
    run_json(
        &python,
        "gtsam_solve.py",
        &["convert", "city10000", file.to_str().unwrap()],
    );
    compare(&python, &file, true);
}
