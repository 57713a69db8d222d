//! Merge cases of every kind: B placed into A's frame by `match_paths`.
//!
//! - **Window**: A a window of a session's truth (a quarter to a half of its
//!   length), B a window of the same session's input sharing 30-80 % of A's
//!   length and running up to 30 % beyond it on either side.
//! - **Sessions**: A one session's truth, B another session's input, where
//!   both were recorded in one frame (EuRoC's machine hall, TUM-VI's room,
//!   two devices on one walk, an estimate against another session's truth).
//!
//! B is disguised: thinned to every 1st-3rd pose (a rate change), in a third
//! of the window cases noised by 0.1 % of its length per pose, reversed in
//! half of the cases, under a random similarity (scale 0.01-100, any
//! rotation). Negatives: A of one kind against B of another, disguised
//! alike. A case that no single similarity passes (B bends more than the
//! tolerance) is counted as unattainable and not run.

use std::time::Instant;

use nalgebra::Vector3;
use rand::{seq::IndexedRandom, Rng};
use serde::Serialize;

use super::{extent, Kind, Session, MERGE_TOLERANCE, SAME_ROAD};
use crate::checks::{merge_verdict_of, overlap, MergeVerdict, Overlap};
use crate::revisits::arc_lengths;
use crate::similarity::{gaussian, random_similarity, rotation_error_deg};
use turnprint::geometry::Similarity3;
use turnprint::pipeline::{match_paths, Config};
use turnprint::Trajectory;

/// Hypotheses kept per case (rank-1 and top-5).
const TOP_K: usize = 5;
/// B shares at least this fraction of its length with A, else the draw is
/// redrawn: less is a glancing touch, not a common road.
const MIN_COMMON_SHARE: f64 = 0.2;
/// Per-pose noise of the noised window cases, a fraction of B's length
/// (KITTI's 0.5-1 km windows: 0.5-1 m, a GPS's metre).
const NOISE: f64 = 0.001;

/// How B relates to A.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum How {
    /// Two windows of one session.
    Window,
    /// Two sessions recorded in one frame.
    Sessions,
}

/// One positive case and its outcome.
#[derive(Debug, Clone, Serialize)]
pub struct MergeCase {
    /// Kind of B's session, the kind the case counts for.
    pub kind: Kind,
    /// Name of A's session.
    pub a: String,
    /// Name of B's session.
    pub b: String,
    /// How B relates to A.
    pub how: How,
    /// A's poses `[first, last]` in its session's truth (windows; the
    /// whole session for session pairs).
    pub a_window: [usize; 2],
    /// B's poses `[first, last]` in its session, before thinning.
    pub b_window: [usize; 2],
    /// Poses in A.
    pub a_poses: usize,
    /// Poses in B after thinning.
    pub b_poses: usize,
    /// B's pose order is reversed.
    pub reversed: bool,
    /// B keeps every `rate`-th pose.
    pub rate: usize,
    /// B's poses carry Gaussian noise of 0.1 % of its length.
    pub noised: bool,
    /// Scale of the random similarity applied to B.
    pub scale: f64,
    /// Common road length over B's length.
    pub common_share: f64,
    /// Rank-1 score, 0 when there is no hypothesis.
    pub rank1_score: f64,
    /// The rank-1 hypothesis is correct.
    pub rank1_correct: bool,
    /// One of the top 5 is correct.
    pub top5_correct: bool,
    /// Rank-1's median error over the common length.
    pub rank1_error: Option<f64>,
    /// Rank-1 is wrong and its rotation is more than 135° from the truth's:
    /// the layout laid on itself turned over (a symmetric look-alike).
    pub rank1_flipped: bool,
    /// Wall time (s) of `match_paths`.
    pub seconds: f64,
    /// `match_paths` failed, with its message (counted as no hypothesis).
    pub error: Option<String>,
}

/// One negative pair: A and B share no road.
#[derive(Debug, Clone, Serialize)]
pub struct Negative {
    /// Kind of A's session.
    pub a_kind: Kind,
    /// Kind of B's session, another than A's.
    pub b_kind: Kind,
    /// Name of A's session.
    pub a: String,
    /// Name of B's session.
    pub b: String,
    /// Rank-1 score, 0 when there is no hypothesis or `match_paths` failed.
    pub rank1_score: f64,
}

/// A disguised B: its input as the matcher sees it and the truth of each
/// of its poses.
struct Disguised {
    input: Vec<Vector3<f64>>,
    truth: Vec<Vector3<f64>>,
    window: [usize; 2],
    reversed: bool,
    rate: usize,
    noised: bool,
    scale: f64,
}

fn disguise(
    rng: &mut impl Rng,
    input: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    window: [usize; 2],
    reversed: bool,
    noised: bool,
) -> Disguised {
    let rate = rng.random_range(1..=3);
    let phase = rng.random_range(0..rate);
    let keep = |v: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
        v.iter().skip(phase).step_by(rate).copied().collect()
    };
    let (mut input, mut truth) = (keep(input), keep(truth));
    if noised {
        let sigma = NOISE * arc_lengths(&input).last().copied().unwrap_or(0.0);
        for p in &mut input {
            *p += Vector3::new(gaussian(rng), gaussian(rng), gaussian(rng)) * sigma;
        }
    }
    if reversed {
        input.reverse();
        truth.reverse();
    }
    let sim = random_similarity(rng, extent(&input).max(f64::MIN_POSITIVE));
    Disguised {
        input: input.iter().map(|p| sim.apply(p)).collect(),
        truth,
        window,
        reversed,
        rate,
        noised,
        scale: sim.scale,
    }
}

/// Indices `[first, last]` of the poses whose arc length lies in `[from, to]`.
fn window(arc: &[f64], from: f64, to: f64) -> Option<[usize; 2]> {
    let first = arc.partition_point(|s| *s < from);
    let last = arc.partition_point(|s| *s <= to).checked_sub(1)?;
    (last > first).then_some([first, last])
}

/// A random window of a session: `[first, last]` covering `share` of its
/// length at a random place.
fn random_window(rng: &mut impl Rng, arc: &[f64], share: f64) -> Option<[usize; 2]> {
    let total = *arc.last()?;
    let length = share * total;
    let start = rng.random_range(0.0..=(total - length).max(0.0));
    window(arc, start, start + length)
}

/// The outcome of a positive case: `None` when the draw does not make a
/// case (too short, too little common road), `Err` with the common share
/// when no single similarity passes it.
pub type Outcome = Option<Result<MergeCase, f64>>;

/// Draws and runs one window case of `s`.
pub fn window_case(rng: &mut impl Rng, s: &Session, reversed: bool) -> Outcome {
    let arc = arc_lengths(&s.truth);
    let total = *arc.last()?;
    let a_len = rng.random_range(0.25..=0.5) * total;
    let a_start = rng.random_range(0.0..=total - a_len);
    let common = rng.random_range(0.3..=0.8) * a_len;
    let beyond = rng.random_range(0.0..=0.3) * a_len;
    let (b_from, b_to) = match rng.random::<bool>() {
        true => (a_start + a_len - common, a_start + a_len + beyond),
        false => (a_start - beyond, a_start + common),
    };
    let a = window(&arc, a_start, a_start + a_len)?;
    let b = window(&arc, b_from.max(0.0), b_to.min(total))?;
    let noised = rng.random_range(0..3) == 0;
    let range = |v: &[Vector3<f64>], w: [usize; 2]| v[w[0]..=w[1]].to_vec();
    let b = disguise(
        rng,
        &range(&s.input, b),
        &range(&s.truth, b),
        b,
        reversed,
        noised,
    );
    run(
        s.kind,
        &s.name,
        &range(&s.truth, a),
        a,
        &s.name,
        b,
        How::Window,
    )
}

/// Runs the case of session `b` placed into session `a` (one frame).
pub fn sessions_case(rng: &mut impl Rng, a: &Session, b: &Session, reversed: bool) -> Outcome {
    let whole = |s: &Session| [0, s.truth.len().saturating_sub(1)];
    let b_cut = disguise(rng, &b.input, &b.truth, whole(b), reversed, false);
    run(
        b.kind,
        &a.name,
        &a.truth,
        whole(a),
        &b.name,
        b_cut,
        How::Sessions,
    )
}

fn run(
    kind: Kind,
    a_name: &str,
    a: &[Vector3<f64>],
    a_window: [usize; 2],
    b_name: &str,
    b: Disguised,
    how: How,
) -> Outcome {
    if b.input.len() < 20 || a.len() < 20 {
        return None;
    }
    let truth = overlap(a, &b.truth, SAME_ROAD * extent(a));
    let b_length = arc_lengths(&b.truth).last().copied().unwrap_or(0.0);
    let common_share = truth.length / b_length.max(f64::MIN_POSITIVE);
    if common_share < MIN_COMMON_SHARE || truth.b.len() < 3 {
        return None;
    }
    let verdict = |map: &dyn Fn(&Vector3<f64>) -> Vector3<f64>, ar, br| {
        merge_verdict_of(
            map,
            ar,
            br,
            &b.input,
            &b.truth,
            &truth,
            MERGE_TOLERANCE * truth.length,
        )
    };
    let oracle = oracle(&b, &truth)?;
    let ends = |v: &[usize]| [v[0], v[v.len() - 1]];
    if !verdict(&|p| oracle.apply(p), ends(&truth.a), ends(&truth.b)).correct {
        return Some(Err(common_share));
    }
    let a_traj = Trajectory::from_positions(a_name, a);
    let b_traj = Trajectory::from_positions(b_name, &b.input);
    let start = Instant::now();
    let found = match_paths(&a_traj, &b_traj, &Config::for_matching());
    let seconds = start.elapsed().as_secs_f64();
    let (hyps, error) = match found {
        Ok(h) => (h, None),
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    let verdicts: Vec<(MergeVerdict, f64)> = hyps
        .iter()
        .take(TOP_K)
        .map(|h| {
            let v = verdict(&|p| h.transform(p), h.a_range, h.b_range);
            (v, rotation_error_deg(&h.rotation, &oracle.rotation))
        })
        .collect();
    let first = verdicts.first();
    Some(Ok(MergeCase {
        kind,
        a: a_name.to_string(),
        b: b_name.to_string(),
        how,
        a_window,
        b_window: b.window,
        a_poses: a.len(),
        b_poses: b.input.len(),
        reversed: b.reversed,
        rate: b.rate,
        noised: b.noised,
        scale: b.scale,
        common_share,
        rank1_score: hyps.first().map_or(0.0, |h| h.score),
        rank1_correct: first.is_some_and(|(v, _)| v.correct),
        top5_correct: verdicts.iter().any(|(v, _)| v.correct),
        rank1_error: first.map(|(v, _)| v.median_error / truth.length),
        rank1_flipped: first.is_some_and(|(v, angle)| !v.correct && *angle > 135.0),
        seconds,
        error,
    }))
}

/// The least-squares similarity of B's common poses onto their truth.
fn oracle(b: &Disguised, truth: &Overlap) -> Option<Similarity3> {
    let src: Vec<_> = truth.b.iter().map(|&k| b.input[k]).collect();
    let dst: Vec<_> = truth.b.iter().map(|&k| b.truth[k]).collect();
    Similarity3::fit(&src, &dst)
}

/// Draws and runs one negative: A a window of a session of `kind`, B a
/// window of a session of another kind.
pub fn negative_case(
    rng: &mut impl Rng,
    sessions: &[Session],
    kind: Kind,
    reversed: bool,
) -> Option<Negative> {
    let own: Vec<&Session> = sessions.iter().filter(|s| s.kind == kind).collect();
    let others: Vec<Kind> = Kind::ALL
        .into_iter()
        .filter(|k| *k != kind && sessions.iter().any(|s| s.kind == *k))
        .collect();
    let other_kind = *others.choose(rng)?;
    let other: Vec<&Session> = sessions.iter().filter(|s| s.kind == other_kind).collect();
    let (a, b) = (*own.choose(rng)?, *other.choose(rng)?);
    let (a_share, b_share) = (rng.random_range(0.25..=0.5), rng.random_range(0.2..=0.5));
    let aw = random_window(rng, &arc_lengths(&a.truth), a_share)?;
    let bw = random_window(rng, &arc_lengths(&b.truth), b_share)?;
    let b_cut = disguise(
        rng,
        &b.input[bw[0]..=bw[1]],
        &b.truth[bw[0]..=bw[1]],
        bw,
        reversed,
        false,
    );
    let a_traj = Trajectory::from_positions(&a.name, &a.truth[aw[0]..=aw[1]]);
    let b_traj = Trajectory::from_positions(&b.name, &b_cut.input);
    let score = match_paths(&a_traj, &b_traj, &Config::for_matching())
        .ok()
        .and_then(|h| h.first().map(|h| h.score))
        .unwrap_or(0.0);
    Some(Negative {
        a_kind: kind,
        b_kind: other_kind,
        a: a.name.clone(),
        b: b.name.clone(),
        rank1_score: score,
    })
}

/// Every ordered pair of distinct sessions of `kind` recorded in one frame
/// (B of `kind`, A its frame's reference: a session of any kind whose input
/// is its truth).
pub fn session_pairs(sessions: &[Session], kind: Kind) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for (ib, b) in sessions.iter().enumerate() {
        if b.kind != kind || b.frame.is_none() {
            continue;
        }
        for (ia, a) in sessions.iter().enumerate() {
            let reference = a.input == a.truth && a.kind != Kind::Wheeled;
            if ia != ib && reference && a.recording != b.recording && a.frame == b.frame {
                pairs.push((ia, ib));
            }
        }
    }
    pairs
}
