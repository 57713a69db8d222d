//! Solves a g2o pose graph with turnprint's solver (`correct::solve`,
//! apex-solver Levenberg-Marquardt, node 0 held) in plain least squares,
//! every edge as odometry, as GTSAM's plain LM would, and prints JSON: the
//! cost before and after (0.5 · Σ whitened residual², GTSAM's
//! `graph.error(values)`, `correct::g2o::cost`) and the solve's wall time.
//!
//! ```text
//! cargo run --release --all-features --example solve_g2o -- GRAPH.g2o [--max-iterations N]
//! ```
//!
//! `scripts/crosscheck/gtsam_solve.py solve` prints the same for GTSAM, and
//! `gtsam_solve.py convert` writes GTSAM's benchmark graphs as g2o files.

use std::time::Instant;

use turnprint::correct::g2o::{cost, from_g2o};
use turnprint::correct::solve::optimise;

fn main() {
    if let Err(message) = run() {
        eprintln!("solve_g2o: {message}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let mut file = None;
    let mut max_iterations = 100usize;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--max-iterations" => {
                max_iterations = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .ok_or("--max-iterations needs a number")?;
            }
            _ if file.is_none() => file = Some(a),
            _ => return Err(format!("unexpected argument '{a}'")),
        }
    }
    let file = file.ok_or("usage: solve_g2o GRAPH.g2o [--max-iterations N]")?;
    let text = std::fs::read_to_string(&file).map_err(|e| format!("{file}: {e}"))?;
    let mut graph = from_g2o(&text).map_err(|e| format!("{file}: {e}"))?;
    for e in &mut graph.edges {
        e.loop_id = None;
    }
    let initial_cost = cost(&graph, &graph.poses);
    let start = Instant::now();
    let solution =
        optimise(&graph, &graph.poses, &[], max_iterations).map_err(|e| format!("{file}: {e}"))?;
    let time_s = start.elapsed().as_secs_f64();
    let out = serde_json::json!({
        "solver": "turnprint",
        "file": file,
        "group": graph.group.name(),
        "nodes": graph.poses.len(),
        "edges": graph.edges.len(),
        "initial_cost": initial_cost,
        "final_cost": cost(&graph, &solution),
        // `solve::optimise` returns the poses only.
        "iterations": serde_json::Value::Null,
        "time_s": time_s,
        "max_iterations": max_iterations,
    });
    println!("{out}");
    Ok(())
}
