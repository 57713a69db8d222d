//! Evaluation of the batch matcher on real KITTI paths: merge rates, ROC AUC,
//! loop rates against the naive baseline. Prints Markdown (or JSON with
//! `--json`) on stdout and writes nothing else.
//!
//! `cargo run --release --example evaluate -- --what all`

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use turnprint_eval as eval;
use turnprint_eval::{Options, Source, What};

#[derive(Clone, Copy, ValueEnum)]
enum SourceArg {
    Gt,
    Mono,
    Gps,
    Drift,
    Stereo,
}

impl From<SourceArg> for Source {
    fn from(s: SourceArg) -> Source {
        match s {
            SourceArg::Gt => Source::Gt,
            SourceArg::Mono => Source::Mono,
            SourceArg::Gps => Source::Gps,
            SourceArg::Drift => Source::Drift,
            SourceArg::Stereo => Source::Stereo,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum WhatArg {
    Merge,
    Loops,
    All,
}

/// Evaluate turnprint's batch matcher on KITTI 00, 02, 05, 06, 08.
#[derive(Parser)]
struct Args {
    /// Data directory in the shared data's layout (`kitti_gt/00.txt`); when
    /// it has no KITTI 00, `$TURNPRINT_DATA`, the shared data beside the
    /// repository, then the set-up cache `target/data`.
    #[arg(long, default_value = "../shared/data")]
    data: PathBuf,
    /// Seed of all random draws.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Positive merge cases (negatives: a third as many).
    #[arg(long, default_value_t = 480)]
    cases: usize,
    /// Loop runs per sequence and source.
    #[arg(long, default_value_t = 4)]
    loop_seeds: u64,
    /// Leave out loops scoring below this (`loops --min-score`).
    #[arg(long, default_value_t = 0.0)]
    loop_min_score: f64,
    /// Print JSON instead of Markdown.
    #[arg(long)]
    json: bool,
    /// Strength of the loops' drift, a factor of the strong model.
    #[arg(long, default_value_t = 1.0)]
    drift_factor: f64,
    /// The drift's log-scale random walk per sqrt(m), in place of the
    /// strong model's (real monocular ORB-SLAM2: 0.003-0.008).
    #[arg(long)]
    drift_log_scale: Option<f64>,
    /// KITTI sequences, comma-separated (held-out ones: 07,09).
    #[arg(long, value_delimiter = ',', default_values_t = eval::data::SEQUENCES.map(String::from))]
    sequences: Vec<String>,
    /// Sources of B in the merge cases, comma-separated (`stereo`: S-PTAM
    /// stereo VO of KITTI 00, not loop-closed; default gt,mono,gps).
    #[arg(long, value_enum, value_delimiter = ',')]
    sources: Vec<SourceArg>,
    /// Sources of the loop runs, comma-separated (default gt,mono,drift).
    #[arg(long, value_enum, value_delimiter = ',')]
    loop_sources: Vec<SourceArg>,
    /// What to evaluate.
    #[arg(long, value_enum, default_value = "all")]
    what: WhatArg,
}

/// The sources asked for, or `default` when none were.
fn or_default(asked: Vec<SourceArg>, default: &[Source]) -> Vec<Source> {
    match asked.is_empty() {
        true => default.to_vec(),
        false => asked.into_iter().map(Source::from).collect(),
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    let opts = Options {
        data: args.data,
        seed: args.seed,
        cases: args.cases,
        negatives: args.cases.div_ceil(3),
        loop_seeds: args.loop_seeds,
        loop_min_score: args.loop_min_score,
        drift_factor: args.drift_factor,
        drift_log_scale: args.drift_log_scale,
        sequences: args.sequences,
        merge_sources: or_default(args.sources, &eval::MERGE_SOURCES),
        loop_sources: or_default(args.loop_sources, &eval::LOOP_SOURCES),
        what: match args.what {
            WhatArg::Merge => What::Merge,
            WhatArg::Loops => What::Loops,
            WhatArg::All => What::All,
        },
    };
    match eval::run(&opts) {
        Ok(report) if args.json => match serde_json::to_string_pretty(&report) {
            Ok(text) => {
                println!("{text}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("evaluate: {e}");
                ExitCode::FAILURE
            }
        },
        Ok(report) => {
            print!("{}", report.to_markdown());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("evaluate: {e}");
            ExitCode::FAILURE
        }
    }
}
