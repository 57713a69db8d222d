//! The loop evaluation: whole KITTI sequences (ground truth, mono estimate,
//! ground truth with strong drift) under a random similarity, through
//! `find_loops` and through the naive nearest-earlier-position baseline,
//! scored against ground-truth revisit events.

use std::time::Instant;

use nalgebra::Vector3;
use rand::{rngs::StdRng, SeedableRng};
use serde::Serialize;

use super::baseline::Naive;
use super::checks::{loop_correct, median, LoopClaim};
use super::drift::DriftModel;
use super::revisits::Event;
use super::similarity::random_similarity;
use super::{Prepared, Source};
use turnprint::pipeline::{find_loops, Config};
use turnprint::Trajectory;

/// A loop is correct when its query poses lie within this (median, m) of
/// its match poses, in ground truth.
pub const LOOP_RADIUS_M: f64 = 10.0;
/// Loops returned and scored per run.
pub const TOP_K: usize = 10;

/// One method on one input.
#[derive(Debug, Clone, Serialize)]
pub struct LoopRun {
    /// KITTI sequence, e.g. `"00"`.
    pub sequence: String,
    /// Source of the input path.
    pub source: Source,
    /// Seed of the input's drift and random similarity.
    pub seed: u64,
    /// `"turnprint"` or `"naive"`.
    pub method: &'static str,
    /// Ground-truth revisit events of the sequence.
    pub events: usize,
    /// Events whose frames a correct top-10 loop's query range touches.
    pub events_covered: usize,
    /// Loops returned (at most 10).
    pub returned: usize,
    /// Correct loops among them.
    pub correct: usize,
    /// The best-ranked loop is correct.
    pub rank1_correct: bool,
    /// Wall time (s) of the method on the input.
    pub seconds: f64,
    /// `find_loops` failed, with its message (always `None` for the naive
    /// baseline).
    pub error: Option<String>,
    /// How far apart, in the input's own frame, ground-truth revisits are:
    /// median over revisiting frames of the input distance to the revisited
    /// frame, in median input steps (the naive baseline's threshold is 8).
    pub revisit_separation_steps: f64,
    /// The returned loops, best first, each with its verdict.
    pub loops: Vec<(LoopClaim, bool)>,
}

/// The input path of a run and its ground-truth frame per pose.
fn input(
    p: &Prepared,
    source: Source,
    rng: &mut StdRng,
    drift: &DriftModel,
) -> (Vec<Vector3<f64>>, Vec<f64>) {
    let seq = &p.seq;
    let all_frames = || (0..seq.gt.len()).map(|f| f as f64).collect();
    match source {
        Source::Mono => (seq.mono.positions.clone(), seq.mono.frames.clone()),
        Source::Stereo => (seq.stereo.positions.clone(), seq.stereo.frames.clone()),
        Source::Drift => (drift.apply(&seq.gt, rng), all_frames()),
        Source::Gt | Source::Gps => (seq.gt.clone(), all_frames()),
    }
}

/// Scores a ranked list of loop claims on one run: the events a correct
/// claim's query range touches (`frames[i]`: the truth's frame of input pose
/// `i`), the claims, the correct ones, and each claim's verdict.
fn score(
    claims: &[LoopClaim],
    truth: &[Vector3<f64>],
    frames: &[f64],
    p: &Prepared,
) -> (usize, usize, usize, Vec<bool>) {
    let ok: Vec<bool> = claims
        .iter()
        .map(|c| loop_correct(c, truth, LOOP_RADIUS_M))
        .collect();
    let ranges: Vec<[f64; 2]> = claims
        .iter()
        .map(|c| query_range(c).map(|i| frames[i]))
        .collect();
    let correct = ok.iter().filter(|x| **x).count();
    (covered(&ranges, &ok, &p.events), claims.len(), correct, ok)
}

/// A claim's query range, first index first.
pub fn query_range(c: &LoopClaim) -> [usize; 2] {
    [c.query[0].min(c.query[1]), c.query[0].max(c.query[1])]
}

/// The events touched by the query range (in the truth's frames) of a
/// claim judged correct (`ok`).
pub fn covered(ranges: &[[f64; 2]], ok: &[bool], events: &[Event]) -> usize {
    events
        .iter()
        .filter(|e| {
            ranges
                .iter()
                .zip(ok)
                .any(|(r, ok)| *ok && r[0] <= e.last as f64 && r[1] >= e.first as f64)
        })
        .count()
}

/// Median input-frame distance between a ground-truth revisit and the frame
/// it revisits, in median steps of the input (see [`LoopRun`]).
pub fn revisit_separation(p: &Prepared, positions: &[Vector3<f64>], frames: &[f64]) -> f64 {
    let mut index_of = vec![None; p.seq.gt.len()];
    for (k, f) in frames.iter().enumerate() {
        if let Some(slot) = index_of.get_mut(f.round() as usize) {
            *slot = Some(k);
        }
    }
    let steps: Vec<f64> = positions
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .filter(|d| *d > 0.0)
        .collect();
    let step = median(&steps);
    let d: Vec<f64> = p
        .revisits
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let (qi, qj) = (index_of[i]?, index_of[(*r)?]?);
            Some((positions[qi] - positions[qj]).norm() / step)
        })
        .collect();
    median(&d)
}

/// Runs `find_loops` (loops scoring below `min_score` left out) and the
/// naive baseline on one input (sequence, source, seed): the seed fixes the
/// drift and the similarity.
pub fn run(
    p: &Prepared,
    source: Source,
    seed: u64,
    drift: &DriftModel,
    min_score: f64,
) -> [LoopRun; 2] {
    let mut rng = StdRng::seed_from_u64(seed);
    let (positions, frames) = input(p, source, &mut rng, drift);
    let truth: Vec<Vector3<f64>> = frames.iter().map(|f| p.seq.true_position(*f)).collect();
    let extent = positions
        .iter()
        .map(|q| (q - positions[0]).norm())
        .fold(0.0, f64::max);
    let sim = random_similarity(&mut rng, extent.max(1.0));
    let positions: Vec<_> = positions.iter().map(|q| sim.apply(q)).collect();
    let traj = Trajectory::from_positions(format!("{}-{}", p.seq.name, source.name()), &positions);

    let mut config = Config::for_loops();
    config.top_k = TOP_K;
    config.min_score = min_score;
    let start = Instant::now();
    let found = find_loops(&traj, &config);
    let tp_seconds = start.elapsed().as_secs_f64();
    let (tp_claims, tp_error) = match found {
        Ok(mut h) => {
            h.sort_by(|x, y| y.score.total_cmp(&x.score));
            (
                h.iter()
                    .take(TOP_K)
                    .map(LoopClaim::from)
                    .collect::<Vec<_>>(),
                None,
            )
        }
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    let start = Instant::now();
    let naive_claims = Naive::default().loops(&positions);
    let naive_seconds = start.elapsed().as_secs_f64();

    let separation = revisit_separation(p, &positions, &frames);
    let make = |method, claims: &[LoopClaim], seconds, error| {
        let (events_covered, returned, correct, ok) = score(claims, &truth, &frames, p);
        LoopRun {
            sequence: p.seq.name.clone(),
            source,
            seed,
            method,
            events: p.events.len(),
            events_covered,
            returned,
            correct,
            rank1_correct: ok.first().copied().unwrap_or(false),
            seconds,
            error,
            revisit_separation_steps: separation,
            loops: claims.iter().copied().zip(ok).collect(),
        }
    };
    [
        make("turnprint", &tp_claims, tp_seconds, tp_error),
        make("naive", &naive_claims, naive_seconds, None),
    ]
}
