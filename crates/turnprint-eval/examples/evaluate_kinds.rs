//! The evaluation over every kind of real path in the data folder (cars,
//! drones, hand-held cameras, wheeled robots, pedestrians; references and
//! drifting estimates): merge rates and ROC AUC per kind, loop events covered
//! per kind and input beside the naive baseline. Prints Markdown (or JSON
//! with `--json`) on stdout.
//!
//! `cargo run --release -p turnprint-eval --example evaluate_kinds`

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use turnprint_eval::kinds::{evaluate, Kind, KindsOptions};

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum WhatArg {
    Merge,
    Loops,
    /// The loops, and the online detector replaying each loop input.
    Online,
    All,
}

/// Evaluate turnprint on every kind of path in the data folder.
#[derive(Parser)]
struct Args {
    /// Data directory in the shared data's layout; when it has no KITTI 00,
    /// `$TURNPRINT_DATA`, the shared data beside the repository, then the
    /// set-up cache `target/data`.
    #[arg(long, default_value = "../shared/data")]
    data: PathBuf,
    /// Seed of all random draws.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Window cases per kind.
    #[arg(long, default_value_t = 40)]
    windows: usize,
    /// Session-pair cases per kind at most.
    #[arg(long, default_value_t = 40)]
    pairs: usize,
    /// Negatives per kind.
    #[arg(long, default_value_t = 30)]
    negatives: usize,
    /// Loop runs per session and input.
    #[arg(long, default_value_t = 1)]
    loop_seeds: u64,
    /// Kinds to run (comma-separated keys: car, car-odometry, car-gps,
    /// drone, drone-vio, handheld, wheeled, walker); all when absent.
    #[arg(long, value_delimiter = ',')]
    kinds: Vec<String>,
    #[arg(long, value_enum, default_value = "all")]
    what: WhatArg,
    /// Every case and run as JSON instead of the tables.
    #[arg(long)]
    json: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let mut kinds = Vec::new();
    for key in &args.kinds {
        match Kind::ALL.into_iter().find(|k| k.key() == key) {
            Some(k) => kinds.push(k),
            None => {
                eprintln!("evaluate_kinds: unknown kind '{key}'");
                return ExitCode::from(2);
            }
        }
    }
    let opts = KindsOptions {
        data: args.data,
        seed: args.seed,
        windows: args.windows,
        pairs: args.pairs,
        negatives: args.negatives,
        loop_seeds: args.loop_seeds,
        kinds,
        merge: matches!(args.what, WhatArg::Merge | WhatArg::All),
        loops: args.what != WhatArg::Merge,
        online: args.what == WhatArg::Online,
    };
    match evaluate(&opts) {
        Ok(report) if args.json => {
            println!(
                "{}",
                serde_json::to_string_pretty(&report).unwrap_or_default()
            );
            ExitCode::SUCCESS
        }
        Ok(report) => {
            print!("{}", report.markdown());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("evaluate_kinds: {e}");
            ExitCode::FAILURE
        }
    }
}
