#![deny(missing_docs)]
//! The rerunnable evaluation of the batch matcher on real KITTI paths
//! (`examples/evaluate.rs`): merging windows of ground truth with windows of
//! ground truth, monocular estimates and GPS under random similarities, and
//! finding loops on ground truth, mono and drifting paths against the naive
//! nearest-earlier-position baseline. Results are Markdown tables or JSON.

pub mod ambiguity;
pub mod ape;
pub mod auc;
pub mod baseline;
pub mod checks;
pub mod data;
pub mod drift;
pub mod kinds;
pub mod loops;
pub mod many;
pub mod merge;
pub mod relations;
pub mod report;
pub mod revisits;
pub mod similarity;
pub mod windows;

/// Paths shared by the evaluation's unit tests.
#[cfg(test)]
pub(crate) mod test_paths {
    use nalgebra::Vector3;

    /// A 100-unit straight along x, a square loop of side 100 back to the
    /// start, then `back` units of the straight again, `offset` to its side:
    /// unit steps.
    pub fn square_loop(back: usize, offset: f64) -> Vec<Vector3<f64>> {
        let side = |k: usize, i: f64| match k {
            0 => Vector3::new(i, 0.0, 0.0),
            1 => Vector3::new(100.0, i, 0.0),
            2 => Vector3::new(100.0 - i, 100.0, 0.0),
            _ => Vector3::new(0.0, 100.0 - i, 0.0),
        };
        (0..4)
            .flat_map(|k| (0..100).map(move |i| side(k, i as f64)))
            .chain((0..back).map(|i| Vector3::new(i as f64, offset, 0.0)))
            .collect()
    }
}

use std::path::PathBuf;

use rand::{rngs::StdRng, Rng, SeedableRng};
use serde::Serialize;

use data::{load_sequence, resolve_data_dir, Sequence, SEQUENCES};
pub use report::Report;
use turnprint::Result;

/// Sources of B in the merge cases unless asked otherwise.
pub const MERGE_SOURCES: [Source; 3] = [Source::Gt, Source::Mono, Source::Gps];
/// Sources of the loop runs unless asked otherwise.
pub const LOOP_SOURCES: [Source; 3] = [Source::Gt, Source::Mono, Source::Drift];

/// Ground-truth revisits: within this distance (m) ...
pub const REVISIT_RADIUS_M: f64 = 8.0;
/// ... of a pose at least this many frames earlier.
pub const REVISIT_MIN_FRAMES: usize = 300;
/// An event spans at least this much road (m) ...
pub const EVENT_MIN_M: f64 = 40.0;
/// ... allowing this many non-revisiting frames inside.
pub const EVENT_MAX_GAP: usize = 5;

/// Where a test path comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// KITTI ground truth.
    Gt,
    /// Monocular ORB-SLAM2 estimate.
    Mono,
    /// Real 1 Hz GPS (KITTI 00).
    Gps,
    /// Ground truth with strong heading and scale drift.
    Drift,
    /// Stereo visual odometry without loop closure (S-PTAM, KITTI 00): a
    /// real drifting estimate at the true scale.
    Stereo,
}

impl Source {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Source::Gt => "gt",
            Source::Mono => "mono",
            Source::Gps => "gps",
            Source::Drift => "drift",
            Source::Stereo => "stereo",
        }
    }
}

/// A sequence with its ground-truth revisits and events.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The sequence and its sources.
    pub seq: Sequence,
    /// Per frame: the nearest frame >= 300 earlier within 8 m.
    pub revisits: Vec<Option<usize>>,
    /// Runs of revisits spanning >= 40 m.
    pub events: Vec<revisits::Event>,
}

impl Prepared {
    /// Computes the revisits and events of a sequence.
    pub fn new(seq: Sequence) -> Self {
        let revisits = revisits::revisits(&seq.gt, REVISIT_RADIUS_M, REVISIT_MIN_FRAMES);
        let events = revisits::events(&revisits, &seq.arc, EVENT_MAX_GAP, EVENT_MIN_M);
        Prepared {
            seq,
            revisits,
            events,
        }
    }

    /// True when the data for `source` was found.
    pub fn has(&self, source: Source) -> bool {
        match source {
            Source::Gt | Source::Drift => true,
            Source::Mono => !self.seq.mono.positions.is_empty(),
            Source::Gps => self.seq.gps.is_some(),
            Source::Stereo => !self.seq.stereo.positions.is_empty(),
        }
    }
}

/// What to evaluate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum What {
    /// Merging windows.
    Merge,
    /// Loops of whole sequences.
    Loops,
    /// Both.
    All,
}

/// Settings of one evaluation run.
#[derive(Debug, Clone)]
pub struct Options {
    /// Data directory (holds `kitti_gt/`, `kitti_orbslam2_vio/`, `gtsam_data/`).
    pub data: PathBuf,
    /// Seed of every random draw.
    pub seed: u64,
    /// Positive merge cases.
    pub cases: usize,
    /// Negative merge pairs.
    pub negatives: usize,
    /// Loop runs per sequence and source (seeds `seed..seed + n`).
    pub loop_seeds: u64,
    /// `Config::min_score` of the loop runs (the CLI's `loops --min-score`).
    pub loop_min_score: f64,
    /// What to run.
    pub what: What,
    /// Strength of the loops' drift, a factor of [`drift::DriftModel::strong`].
    pub drift_factor: f64,
    /// The drift's log-scale random walk per sqrt(m), in place of the
    /// scaled strong model's (`None`: keep it).
    pub drift_log_scale: Option<f64>,
    /// KITTI sequences to draw from (default [`SEQUENCES`]; others, such as
    /// 07 and 09, serve as held-out data).
    pub sequences: Vec<String>,
    /// Sources of B in the merge cases, taking turns (those a sequence has).
    pub merge_sources: Vec<Source>,
    /// Sources of the loop runs.
    pub loop_sources: Vec<Source>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            data: PathBuf::from("../shared/data"),
            seed: 1,
            cases: 480,
            negatives: 160,
            loop_seeds: 4,
            loop_min_score: 0.0,
            what: What::All,
            drift_factor: 1.0,
            drift_log_scale: None,
            sequences: SEQUENCES.iter().map(|s| s.to_string()).collect(),
            merge_sources: MERGE_SOURCES.to_vec(),
            loop_sources: LOOP_SOURCES.to_vec(),
        }
    }
}

/// Runs the evaluation and returns every case with the summaries.
pub fn run(opts: &Options) -> Result<Report> {
    let dir = resolve_data_dir(&opts.data)?;
    let prepared: Vec<Prepared> = opts
        .sequences
        .iter()
        .map(|name| load_sequence(&dir, name).map(Prepared::new))
        .collect::<Result<_>>()?;
    let do_merge = matches!(opts.what, What::Merge | What::All);
    let do_loops = matches!(opts.what, What::Loops | What::All);
    let total = if do_merge {
        opts.cases + opts.negatives
    } else {
        0
    } + if do_loops {
        let inputs = prepared
            .iter()
            .map(|p| opts.loop_sources.iter().filter(|s| p.has(**s)).count());
        inputs.sum::<usize>() * opts.loop_seeds as usize
    } else {
        0
    };
    let bar = indicatif::ProgressBar::new(total as u64);
    let mut report = Report::new(&dir, opts.seed, &prepared);
    if do_merge {
        let spec = windows::WindowSpec::default();
        let mut rng = StdRng::seed_from_u64(opts.seed);
        // Sources take turns (only those with data: GPS is KITTI 00's);
        // every other round of turns has B reversed.
        let sources: Vec<Source> = opts
            .merge_sources
            .iter()
            .copied()
            .filter(|s| prepared.iter().any(|p| p.has(*s)))
            .collect();
        let (mut cases, mut unattainable) = (Vec::new(), Vec::new());
        let mut draws = 0;
        while cases.len() < opts.cases && draws < 50 * opts.cases.max(1) {
            draws += 1;
            let source = sources[cases.len() % sources.len()];
            let reversed = (cases.len() / sources.len()) % 2 == 1;
            let having: Vec<&Prepared> = prepared.iter().filter(|p| p.has(source)).collect();
            let p = having[rng.random_range(0..having.len())];
            match merge::positive_case(&mut rng, p, source, reversed, &spec) {
                Some(c) if c.oracle_correct => {
                    cases.push(c);
                    bar.inc(1);
                }
                Some(c) => unattainable.push(c),
                None => {}
            }
        }
        let mut negatives = Vec::new();
        draws = 0;
        while negatives.len() < opts.negatives && draws < 50 * opts.negatives.max(1) {
            draws += 1;
            if let Some(n) = merge::negative_case(
                &mut rng,
                &prepared,
                &sources,
                negatives.len() % 2 == 1,
                &spec,
            ) {
                negatives.push(n);
                bar.inc(1);
            }
        }
        report.set_merge(cases, negatives, unattainable, spec);
    }
    if do_loops {
        let mut drift = drift::DriftModel::strong().scaled(opts.drift_factor);
        if let Some(walk) = opts.drift_log_scale {
            drift = drift.with_log_scale(walk);
        }
        let mut runs = Vec::new();
        for p in &prepared {
            for &source in &opts.loop_sources {
                if !p.has(source) {
                    continue;
                }
                for k in 0..opts.loop_seeds {
                    // One seed per (sequence, source, k): reruns repeat.
                    let seed = opts.seed.wrapping_mul(1000).wrapping_add(k)
                        ^ (p.seq.name.parse::<u64>().unwrap_or(0) << 20)
                        ^ ((source as u64) << 40);
                    runs.extend(loops::run(p, source, seed, &drift, opts.loop_min_score));
                    bar.inc(1);
                }
            }
        }
        report.set_loops(runs, drift, baseline::Naive::default());
    }
    bar.finish_and_clear();
    Ok(report)
}
