//! The merge evaluation: windows A (ground truth) and B (ground truth, mono
//! estimate or GPS, under a random similarity, half reversed) with common
//! road, run through `match_paths`; negatives from different sequences.

use std::time::Instant;

use nalgebra::Vector3;
use rand::{seq::IndexedRandom, Rng};
use serde::Serialize;

use super::ambiguity::{shape_rival, Ambiguity};
use super::checks::{
    kitti_tolerance, merge_verdict, merge_verdict_of, overlap, road_turning_deg, MergeVerdict,
    Overlap,
};
use super::similarity::{random_similarity, rotation_error_deg, scale_error_pct};
use super::windows::{overlapping_window, random_window, revisit_windows, Window, WindowSpec};
use super::{Prepared, Source};
use turnprint::geometry::Similarity3;
use turnprint::pipeline::{match_paths, Config};
use turnprint::{Hypothesis, Trajectory};

/// Radius (m) within which ground-truth positions count as the same road.
pub const SAME_ROAD_M: f64 = 8.0;
/// Fewest poses a B window must have (1 Hz GPS windows are short).
const MIN_POSES: usize = 20;

/// One positive merge case and how the matcher did.
#[derive(Debug, Clone, Serialize)]
pub struct MergeCase {
    /// KITTI sequence of A and B.
    pub sequence: String,
    /// Source of B (A is ground truth).
    pub source: Source,
    /// `"time"` (B shares part of A's drive) or `"revisit"` (a later pass).
    pub kind: &'static str,
    /// B's pose order is reversed.
    pub reversed: bool,
    /// Ground-truth frames of A's window (inclusive).
    pub a_frames: [usize; 2],
    /// Ground-truth frames of B's window (inclusive).
    pub b_frames: [usize; 2],
    /// Scale of the random similarity applied to B.
    pub scale: f64,
    /// Poses in A's window.
    pub a_poses: usize,
    /// Poses in B's window.
    pub b_poses: usize,
    /// Ground-truth length (m) of the common road.
    pub overlap_m: f64,
    /// Total turning (degrees) of the common road in the ground truth.
    pub overlap_turning_deg: f64,
    /// Rank-1 score, 0 when there is no hypothesis.
    pub rank1_score: f64,
    /// The rank-1 hypothesis is correct.
    pub rank1_correct: bool,
    /// One of the top 5 is correct.
    pub top5_correct: bool,
    /// Median error (m) of the rank-1 similarity on the common road.
    pub rank1_error_m: Option<f64>,
    /// Both rank-1 ranges touch the common road.
    pub rank1_ranges_hit: Option<bool>,
    /// Rotation error (deg) of a correct rank-1 against the best-fit truth.
    pub rot_err_deg: Option<f64>,
    /// Scale error (%) of a correct rank-1.
    pub scale_err_pct: Option<f64>,
    /// The best-fit (Umeyama) similarity of B's common-road poses onto their
    /// true positions passes the test. When it does not (the source bends
    /// more than the tolerance, e.g. mono drift between two passes), the case
    /// is not run and not counted.
    pub oracle_correct: bool,
    /// Whether shape alone could place B: the truth's support against its
    /// best failing rival ([`super::ambiguity`]; `None` without an oracle).
    pub ambiguity: Option<Ambiguity>,
    /// A failing rival lays as much of B onto A as the truth does
    /// (`ambiguity`'s `has_rival`, written out for readers of the JSON).
    pub shape_rival: bool,
    /// Wall time of `match_paths`.
    pub seconds: f64,
    /// `match_paths` failed (counted as no hypothesis).
    pub error: Option<String>,
}

/// One negative pair (no common road) and its rank-1 score.
#[derive(Debug, Clone, Serialize)]
pub struct NegativeCase {
    /// KITTI sequence of A (ground truth).
    pub a_sequence: String,
    /// KITTI sequence of B, another than A's.
    pub b_sequence: String,
    /// Source of B.
    pub source: Source,
    /// B's pose order is reversed.
    pub reversed: bool,
    /// Rank-1 score, 0 when there is no hypothesis.
    pub rank1_score: f64,
    /// Wall time (s) of `match_paths`.
    pub seconds: f64,
}

/// B cut from a source: input positions (source frame) and true positions.
struct Cut {
    input: Vec<Vector3<f64>>,
    truth: Vec<Vector3<f64>>,
}

/// The poses of `source` whose ground-truth frame lies in the window.
fn cut(p: &Prepared, source: Source, w: Window) -> Cut {
    let seq = &p.seq;
    let (lo, hi) = (w[0] as f64, w[1] as f64);
    let (positions, frames): (Vec<Vector3<f64>>, Vec<f64>) = match source {
        Source::Gt | Source::Drift => (
            seq.gt[w[0]..=w[1]].to_vec(),
            (w[0]..=w[1]).map(|f| f as f64).collect(),
        ),
        Source::Mono => keep(&seq.mono.positions, &seq.mono.frames, lo, hi),
        Source::Stereo => keep(&seq.stereo.positions, &seq.stereo.frames, lo, hi),
        Source::Gps => match &seq.gps {
            Some((g, _)) => keep(&g.positions, &g.frames, lo, hi),
            None => (Vec::new(), Vec::new()),
        },
    };
    Cut {
        truth: frames.iter().map(|f| seq.true_position(*f)).collect(),
        input: positions,
    }
}

fn keep(pos: &[Vector3<f64>], frames: &[f64], lo: f64, hi: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
    pos.iter()
        .zip(frames)
        .filter(|(_, f)| (lo..=hi).contains(*f))
        .map(|(p, f)| (*p, *f))
        .unzip()
}

/// Reverses B's pose order (when asked) and puts B under a random similarity.
fn disguise(rng: &mut impl Rng, mut b: Cut, reversed: bool) -> (Cut, bool, f64) {
    if reversed {
        b.input.reverse();
        b.truth.reverse();
    }
    let extent = b
        .input
        .iter()
        .map(|p| (p - b.input[0]).norm())
        .fold(0.0, f64::max);
    let sim = random_similarity(rng, extent.max(1.0));
    b.input = b.input.iter().map(|p| sim.apply(p)).collect();
    (b, reversed, sim.scale)
}

fn run_match(
    a: &Trajectory,
    b: &Trajectory,
    top_k: usize,
) -> (Vec<Hypothesis>, f64, Option<String>) {
    let mut config = Config::for_matching();
    config.top_k = top_k;
    let start = Instant::now();
    let out = match_paths(a, b, &config);
    let seconds = start.elapsed().as_secs_f64();
    match out {
        Ok(mut h) => {
            h.sort_by(|x, y| y.score.total_cmp(&x.score));
            h.truncate(top_k);
            (h, seconds, None)
        }
        Err(e) => (Vec::new(), seconds, Some(e.to_string())),
    }
}

/// Draws and runs one positive case, B reversed or not (`None`: the draw
/// did not fit, retry).
pub fn positive_case(
    rng: &mut impl Rng,
    p: &Prepared,
    source: Source,
    reversed: bool,
    spec: &WindowSpec,
) -> Option<MergeCase> {
    let arc = &p.seq.arc;
    let long_events: Vec<_> = p
        .events
        .iter()
        .filter(|e| e.length >= spec.overlap.0)
        .collect();
    let revisit = !long_events.is_empty() && rng.random_bool(1.0 / 3.0);
    let (a_win, b_win) = if revisit {
        let event = long_events.choose(rng)?;
        revisit_windows(rng, arc, event, &p.revisits, spec)?
    } else {
        let a = random_window(rng, arc, spec.a_len.0, spec.a_len.1)?;
        (a, overlapping_window(rng, arc, a, spec)?)
    };
    let kind = if revisit { "revisit" } else { "time" };
    window_case(
        rng,
        p,
        source,
        reversed,
        [a_win, b_win],
        kind,
        0.75 * spec.overlap.0,
    )
}

/// One positive case run in full: the true overlap, how well the best
/// single similarity could do, and every hypothesis with its verdict.
#[derive(Debug, Clone)]
pub struct CaseRun {
    /// B's poses as the matcher saw them (reversed, under a random
    /// similarity).
    pub b_input: Vec<Vector3<f64>>,
    /// Scale of that similarity.
    pub scale: f64,
    /// B's pose order is reversed.
    pub reversed: bool,
    /// The common road (indices into A's and B's windows).
    pub truth: Overlap,
    /// Total turning (degrees) of the common road in the ground truth.
    pub turning_deg: f64,
    /// Poses in A's window.
    pub a_poses: usize,
    /// The best-fit (Umeyama) similarity of B's common-road poses onto
    /// their true positions, judged like a hypothesis (`None`: no fit).
    pub oracle: Option<(Similarity3, MergeVerdict)>,
    /// The oracle's support by shape against its best failing rival.
    pub ambiguity: Option<Ambiguity>,
    /// The matcher's hypotheses, best first, each with its verdict (empty
    /// when the oracle fails: such a case is not run).
    pub hypotheses: Vec<(Hypothesis, MergeVerdict)>,
    /// Wall time (s) of `match_paths`.
    pub seconds: f64,
    /// `match_paths` failed, with its message.
    pub error: Option<String>,
}

/// Runs one positive case on given windows (frame ranges of A and B), B
/// under a random similarity and reversed or not, keeping the `top_k`
/// best hypotheses (`None`: B is too short or shares less than
/// `min_overlap` metres of road with A).
pub fn run_case(
    rng: &mut impl Rng,
    p: &Prepared,
    source: Source,
    reversed: bool,
    [a_win, b_win]: [Window; 2],
    min_overlap: f64,
    top_k: usize,
) -> Option<CaseRun> {
    let a_cut = cut(p, Source::Gt, a_win);
    let b_cut = cut(p, source, b_win);
    if b_cut.input.len() < MIN_POSES {
        return None;
    }
    let (b, reversed, scale) = disguise(rng, b_cut, reversed);
    let truth = overlap(&a_cut.truth, &b.truth, SAME_ROAD_M);
    if truth.length < min_overlap || truth.b.len() < 3 {
        return None;
    }
    let a_traj = Trajectory::from_positions(format!("{}-gt", p.seq.name), &a_cut.input);
    let b_traj = Trajectory::from_positions(format!("{}-{}", p.seq.name, source.name()), &b.input);
    let src: Vec<_> = truth.b.iter().map(|&k| b.input[k]).collect();
    let dst: Vec<_> = truth.b.iter().map(|&k| b.truth[k]).collect();
    let oracle = Similarity3::fit(&src, &dst).map(|o| {
        let (a_all, b_all) = (
            [truth.a[0], truth.a[truth.a.len() - 1]],
            [truth.b[0], truth.b[truth.b.len() - 1]],
        );
        let tolerance = kitti_tolerance(&truth);
        let v = merge_verdict_of(
            |p| o.apply(p),
            a_all,
            b_all,
            &b.input,
            &b.truth,
            &truth,
            tolerance,
        );
        (o, v)
    });
    // A case that no similarity can pass is not run (the caller skips it).
    let (hyps, seconds, error) = match oracle.as_ref().is_some_and(|(_, v)| v.correct) {
        true => run_match(&a_traj, &b_traj, top_k),
        false => (Vec::new(), 0.0, None),
    };
    let ambiguity = oracle.as_ref().map(|(o, v)| {
        shape_rival(
            &a_cut.truth,
            &b.input,
            &b.truth,
            &truth,
            o,
            v.tolerance,
            &|_| 1.0,
        )
    });
    let hypotheses = hyps
        .into_iter()
        .map(|h| {
            let v = merge_verdict(&h, &b.input, &b.truth, &truth);
            (h, v)
        })
        .collect();
    Some(CaseRun {
        turning_deg: road_turning_deg(&a_cut.truth, &truth.a),
        a_poses: a_traj.len(),
        b_input: b.input,
        scale,
        reversed,
        truth,
        oracle,
        ambiguity,
        hypotheses,
        seconds,
        error,
    })
}

/// Runs one positive case on given windows (frame ranges of A and B), B
/// under a random similarity and reversed or not (`None`: B is too short
/// or shares less than `min_overlap` metres of road with A).
pub fn window_case(
    rng: &mut impl Rng,
    p: &Prepared,
    source: Source,
    reversed: bool,
    windows: [Window; 2],
    kind: &'static str,
    min_overlap: f64,
) -> Option<MergeCase> {
    let run = run_case(rng, p, source, reversed, windows, min_overlap, 5)?;
    let first = run.hypotheses.first();
    let rank1_correct = first.is_some_and(|(_, v)| v.correct);
    let (mut rot_err_deg, mut scale_err_pct) = (None, None);
    if let (true, Some((h, _)), Some((best, _))) = (rank1_correct, first, &run.oracle) {
        rot_err_deg = Some(rotation_error_deg(&h.rotation, &best.rotation));
        scale_err_pct = Some(scale_error_pct(h.scale, best.scale));
    }
    Some(MergeCase {
        sequence: p.seq.name.clone(),
        source,
        kind,
        reversed: run.reversed,
        a_frames: windows[0],
        b_frames: windows[1],
        scale: run.scale,
        a_poses: run.a_poses,
        b_poses: run.b_input.len(),
        overlap_m: run.truth.length,
        overlap_turning_deg: run.turning_deg,
        rank1_score: first.map_or(0.0, |(h, _)| h.score),
        rank1_correct,
        top5_correct: run.hypotheses.iter().any(|(_, v)| v.correct),
        rank1_error_m: first.map(|(_, v)| v.median_error),
        rank1_ranges_hit: first.map(|(_, v)| v.ranges_hit),
        rot_err_deg,
        scale_err_pct,
        oracle_correct: run.oracle.as_ref().is_some_and(|(_, v)| v.correct),
        ambiguity: run.ambiguity,
        shape_rival: run.ambiguity.is_some_and(|a| a.has_rival()),
        seconds: run.seconds,
        error: run.error,
    })
}

/// Draws and runs one negative pair: A from one sequence, B (any source)
/// from another, same window lengths and disguise as the positives.
pub fn negative_case(
    rng: &mut impl Rng,
    all: &[Prepared],
    sources: &[Source],
    reversed: bool,
    spec: &WindowSpec,
) -> Option<NegativeCase> {
    if all.len() < 2 {
        return None;
    }
    let ia = rng.random_range(0..all.len());
    let ib = (ia + rng.random_range(1..all.len())) % all.len();
    let (pa, pb) = (&all[ia], &all[ib]);
    let sources: Vec<Source> = sources.iter().copied().filter(|s| pb.has(*s)).collect();
    let source = *sources.choose(rng)?;
    let a_win = random_window(rng, &pa.seq.arc, spec.a_len.0, spec.a_len.1)?;
    let b_win = random_window(rng, &pb.seq.arc, spec.a_len.0, spec.a_len.1)?;
    let a_cut = cut(pa, Source::Gt, a_win);
    let b_cut = cut(pb, source, b_win);
    if b_cut.input.len() < MIN_POSES {
        return None;
    }
    let (b, reversed, _) = disguise(rng, b_cut, reversed);
    let a_traj = Trajectory::from_positions(format!("{}-gt", pa.seq.name), &a_cut.input);
    let b_traj = Trajectory::from_positions(format!("{}-{}", pb.seq.name, source.name()), &b.input);
    let (hyps, seconds, _) = run_match(&a_traj, &b_traj, 5);
    Some(NegativeCase {
        a_sequence: pa.seq.name.clone(),
        b_sequence: pb.seq.name.clone(),
        source,
        reversed,
        rank1_score: hyps.first().map_or(0.0, |h| h.score),
        seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{Sequence, Sourced};
    use crate::revisits::arc_lengths;
    use rand::{rngs::StdRng, SeedableRng};

    /// A winding closed course driven 1.6 times (so the second lap revisits
    /// the first), about 1 m per frame; "mono" is the same course at scale
    /// 0.05 with a few frames missing at the start.
    fn synthetic() -> Prepared {
        let n = 3000;
        let gt: Vec<Vector3<f64>> = (0..n)
            .map(|k| {
                let th = k as f64 / n as f64 * 1.6 * std::f64::consts::TAU;
                Vector3::new(
                    250.0 * th.cos() + 60.0 * (3.0 * th).cos(),
                    0.0,
                    180.0 * th.sin() + 40.0 * (2.0 * th).sin(),
                )
            })
            .collect();
        let mono = Sourced {
            positions: gt[5..].iter().map(|p| p * 0.05).collect(),
            frames: (5..n).map(|f| f as f64).collect(),
        };
        let seq = Sequence {
            name: "syn".into(),
            arc: arc_lengths(&gt),
            times: (0..n).map(|k| k as f64 * 0.1).collect(),
            gt,
            mono,
            gps: None,
            stereo: Default::default(),
        };
        Prepared::new(seq)
    }

    #[test]
    fn drawn_cases_have_common_road_and_a_passing_oracle() {
        let p = synthetic();
        assert!(p.events.iter().any(|e| e.length >= 200.0), "{:?}", p.events);
        let spec = WindowSpec::default();
        let mut rng = StdRng::seed_from_u64(5);
        let (mut made, mut revisits) = (0, 0);
        for i in 0..200 {
            let source = if i % 2 == 0 { Source::Gt } else { Source::Mono };
            let reversed = i % 4 < 2;
            let Some(c) = positive_case(&mut rng, &p, source, reversed, &spec) else {
                continue;
            };
            made += 1;
            revisits += usize::from(c.kind == "revisit");
            assert_eq!(c.reversed, reversed);
            assert!(c.overlap_m >= 150.0, "{c:?}");
            assert!(c.oracle_correct, "{c:?}");
            assert!((0.01..=100.0).contains(&c.scale));
            if c.kind == "revisit" {
                assert!(
                    c.a_frames[1] < c.b_frames[0] || c.b_frames[1] < c.a_frames[0],
                    "{c:?}"
                );
            } else {
                assert!(c.a_frames[0].max(c.b_frames[0]) < c.a_frames[1].min(c.b_frames[1]));
            }
        }
        assert!(
            made >= 100 && revisits >= 10,
            "{made} cases, {revisits} revisits"
        );
    }
}
