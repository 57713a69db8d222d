//! The batch measurement of placing many paths in one frame
//! (`pipeline::merge_many`): chains of 3-5 windows of real drives (KITTI
//! ground truth, monocular ORB-SLAM2 estimates, car GPS), each under its own
//! random similarity, with strangers of other recordings shuffled in; and
//! every multi-session set of the data folder merged whole. Prints Markdown
//! (or JSON with `--json`) on stdout; the rules are in
//! `turnprint_eval::many`.
//!
//! `cargo run --release -p turnprint-eval --example evaluate_many -- --seed 1`
//! (120 chains and the sets: about 7 minutes on 2 cores)

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use turnprint_eval::many::{evaluate, ManyOptions};
use turnprint_eval::Source;

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum WhatArg {
    Chains,
    Sets,
    All,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum SourceArg {
    Gt,
    Mono,
    Gps,
    Stereo,
}

/// Place many paths in one frame: chains of windows with strangers, and the
/// multi-session sets.
#[derive(Parser)]
struct Args {
    /// The data folder (found as `turnprint_eval::data::resolve_data_dir`
    /// finds it).
    #[arg(long, default_value = "../shared/data")]
    data: PathBuf,
    /// Seed of the draws: chains, windows, similarities, strangers.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Chain cases in all, the sources taking turns.
    #[arg(long, default_value_t = 120)]
    cases: usize,
    /// Sources of the chains.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "gt,mono,gps")]
    sources: Vec<SourceArg>,
    #[arg(long, value_enum, default_value = "all")]
    what: WhatArg,
    /// Every case and set as JSON instead of the tables.
    #[arg(long)]
    json: bool,
    /// Also write the JSON to this file (the tables still on stdout).
    #[arg(long)]
    json_to: Option<PathBuf>,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let sources = args
        .sources
        .iter()
        .map(|s| match s {
            SourceArg::Gt => Source::Gt,
            SourceArg::Mono => Source::Mono,
            SourceArg::Gps => Source::Gps,
            SourceArg::Stereo => Source::Stereo,
        })
        .collect();
    let opts = ManyOptions {
        data: args.data,
        seed: args.seed,
        cases: args.cases,
        sources,
        chains: args.what != WhatArg::Sets,
        sets: args.what != WhatArg::Chains,
    };
    let report = match evaluate(&opts) {
        Ok(report) => report,
        Err(e) => {
            eprintln!("evaluate_many: {e}");
            return ExitCode::FAILURE;
        }
    };
    let json = serde_json::to_string_pretty(&report).unwrap_or_default();
    if let Some(path) = &args.json_to {
        if let Err(e) = std::fs::write(path, &json) {
            eprintln!("evaluate_many: {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    match args.json {
        true => println!("{json}"),
        false => print!("{}", report.markdown()),
    }
    ExitCode::SUCCESS
}
