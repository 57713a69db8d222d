//! Loop runs of every kind that revisits: `find_loops`, the online
//! detector replaying the same input pose by pose, and the naive
//! nearest-earlier-position baseline on each judged session, scored against
//! the revisit events of its truth.
//!
//! Inputs per session: an estimate as recorded (its own drift); for a
//! reference (motion capture, GPS) the truth itself, the truth under a
//! random walk (heading 0.3 rad and log-scale 0.05 one-sigma at the path's
//! end) and the truth under a systematic bias (heading 0.2 rad and
//! log-scale 0.15 at the end, signs drawn: a miscalibrated wheel base, a
//! monocular VO's growing scale). Every input is put under a random
//! similarity.

use std::time::Instant;

use nalgebra::Vector3;
use rand::{rngs::StdRng, Rng, SeedableRng};
use serde::Serialize;

use super::{extent, Kind, Session, EVENT_MIN_RADII, LOOP_RADII, REVISIT_GAP, REVISIT_RADIUS};
use crate::baseline::Naive;
use crate::checks::{loop_correct_apart, median, LoopClaim};
use crate::drift::{DriftBias, DriftModel};
use crate::loops::{covered, query_range, TOP_K};
use crate::revisits::{arc_lengths, events, nearest_earlier_apart, true_offset, Event};
use crate::similarity::random_similarity;
use crate::EVENT_MAX_GAP;
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
use turnprint::pipeline::{find_loops, Config};
use turnprint::Trajectory;

/// One-sigma heading error at the end of the path under the random walk
/// (radians): about KITTI's strong model over a drive (0.3 rad = 17°).
pub const WALK_HEADING: f64 = 0.3;
/// One-sigma log-scale error at the end of the path under the random walk.
pub const WALK_LOG_SCALE: f64 = 0.05;
/// Heading error at the end of the path under the bias (radians).
pub const BIAS_HEADING: f64 = 0.2;
/// Log-scale error at the end of the path under the bias: a monocular VO
/// whose scale grows 15 % over its run.
pub const BIAS_LOG_SCALE: f64 = 0.15;

/// What the loop search is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Input {
    /// The reference itself.
    Truth,
    /// The reference under a random walk of heading and scale.
    Walk,
    /// The reference under a heading and scale bias.
    Bias,
    /// A real estimate with its own drift.
    Estimate,
}

impl Input {
    /// Name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Input::Truth => "truth",
            Input::Walk => "random walk",
            Input::Bias => "bias",
            Input::Estimate => "real estimate",
        }
    }
}

/// One session and input through both methods.
#[derive(Debug, Clone, Serialize)]
pub struct LoopRun {
    /// Kind of the session.
    pub kind: Kind,
    /// Name of the session.
    pub session: String,
    /// What the loop search was given.
    pub input: Input,
    /// Revisit events of the session's truth.
    pub events: usize,
    /// Each event's revisiting poses and the earlier poses they match, as
    /// `[first, last, match_first, match_last]` (to see which are missed).
    pub event_ranges: Vec<[usize; 4]>,
    /// Events a correct top-10 loop touches: turnprint, naive.
    pub covered: [usize; 2],
    /// Events a correct loop of the top [`WIDE_K`] touches: turnprint,
    /// naive.
    pub covered_wide: [usize; 2],
    /// The best-ranked loop is correct: turnprint, naive.
    pub rank1_correct: [bool; 2],
    /// Loops returned: turnprint, naive.
    pub returned: [usize; 2],
    /// Correct loops among them: turnprint, naive.
    pub correct: [usize; 2],
    /// turnprint's loops, best first: the claim, its verdict and the true
    /// median offset between its passes in revisit radii.
    pub loops: Vec<(LoopClaim, bool, f64)>,
    /// Wall time (s) of `find_loops`.
    pub seconds: f64,
    /// `find_loops` failed, with its message (counted as no loops).
    pub error: Option<String>,
    /// The online detector on the same input, when asked for.
    pub online: Option<OnlineRun>,
}

/// The online detector's candidates on one input, judged like the loops.
#[derive(Debug, Clone, Serialize)]
pub struct OnlineRun {
    /// Events a correct candidate touches (every candidate counts: the
    /// detector emits them as the path grows, not as one ranked list).
    pub covered: usize,
    /// Each candidate, in order of emission: the claim, its verdict, the
    /// true median offset between its passes in revisit radii, the search
    /// that found it.
    pub claims: Vec<(LoopClaim, bool, f64, String)>,
    /// Wall time (s) of the replay.
    pub seconds: f64,
}

impl OnlineRun {
    /// Candidates emitted.
    pub fn candidates(&self) -> usize {
        self.claims.len()
    }

    /// Correct candidates among them.
    pub fn correct(&self) -> usize {
        self.claims.iter().filter(|c| c.1).count()
    }
}

/// Loops asked for beside the default 10, as a user would with `--top
/// 50`: a room walked for minutes revisits 7-25 places (TUM-VI), a drone
/// circuit up to 12, more than ten loops can name.
pub const WIDE_K: usize = 50;

/// The revisit events of a truth by the scale-free rules of the module,
/// and the revisit radius.
pub fn truth_events(truth: &[Vector3<f64>]) -> (Vec<Event>, f64) {
    let arc = arc_lengths(truth);
    let total = arc.last().copied().unwrap_or(0.0);
    let radius = REVISIT_RADIUS * extent(truth);
    let revisits: Vec<Option<usize>> = nearest_earlier_apart(truth, REVISIT_GAP * total)
        .into_iter()
        .map(|n| n.filter(|(_, d)| *d <= radius).map(|(j, _)| j))
        .collect();
    (
        events(&revisits, &arc, EVENT_MAX_GAP, EVENT_MIN_RADII * radius),
        radius,
    )
}

/// The inputs a session is run with.
pub fn inputs(s: &Session) -> Vec<Input> {
    match s.input == s.truth {
        true => vec![Input::Truth, Input::Walk, Input::Bias],
        false => vec![Input::Estimate],
    }
}

/// Runs both methods (and the online detector when `online`) on one
/// session and input; `None` when the session is not judged or its truth
/// has no revisit event.
pub fn run(s: &Session, input: Input, seed: u64, online: bool) -> Option<LoopRun> {
    if !s.judged {
        return None;
    }
    let (events, radius) = truth_events(&s.truth);
    if events.is_empty() {
        return None;
    }
    let arc = arc_lengths(&s.truth);
    let positions = input_positions(s, input, seed);

    let mut config = Config::for_loops();
    // The first ten of the ranked fifty are the top ten (ranking keeps the
    // best in order and stops at the count).
    config.top_k = WIDE_K;
    let start = Instant::now();
    let found = find_loops(&Trajectory::from_positions(&s.name, &positions), &config);
    let seconds = start.elapsed().as_secs_f64();
    let (mut claims, error) = match found {
        Ok(h) => (h.iter().map(LoopClaim::from).collect::<Vec<_>>(), None),
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    claims.sort_by(|x, y| y.score.total_cmp(&x.score));
    let wide = claims.clone();
    claims.truncate(TOP_K);
    // The naive loops are sorted and cut too: its first ten are its top ten.
    let naive_wide = naive(&s.truth, radius, WIDE_K).loops(&positions);
    let naive = &naive_wide[..naive_wide.len().min(TOP_K)];

    let judge = |c: &[LoopClaim]| judge(c, &s.truth, &arc, &events, radius);
    let (t, n) = (judge(&claims), judge(naive));
    let covered_wide = [judge(&wide).0, judge(&naive_wide).0];
    let offset = |c: &LoopClaim| true_offset(c.query, c.matched, &s.truth) / radius;
    let online = online.then(|| run_online(&positions, judge, offset));
    Some(LoopRun {
        kind: s.kind,
        session: s.name.clone(),
        input,
        events: events.len(),
        event_ranges: events
            .iter()
            .map(|e| [e.first, e.last, e.match_first, e.match_last])
            .collect(),
        covered: [t.0, n.0],
        covered_wide,
        rank1_correct: [t.3.first() == Some(&true), n.3.first() == Some(&true)],
        returned: [t.1, n.1],
        correct: [t.2, n.2],
        loops: claims
            .iter()
            .zip(&t.3)
            .map(|(c, ok)| (*c, *ok, offset(c)))
            .collect(),
        seconds,
        error,
        online,
    })
}

/// The input a loop run is given: the estimate, or the truth as it is,
/// under a random walk or under a bias; then under a random similarity.
fn input_positions(s: &Session, input: Input, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let length = arc_lengths(&s.truth).last().copied().unwrap_or(0.0);
    let positions = match input {
        Input::Truth | Input::Estimate => s.input.clone(),
        Input::Walk => {
            DriftModel::over_length(length, WALK_HEADING, WALK_LOG_SCALE).apply(&s.truth, &mut rng)
        }
        Input::Bias => {
            let sign = |rng: &mut StdRng| if rng.random::<bool>() { 1.0 } else { -1.0 };
            DriftBias {
                heading_rad: sign(&mut rng) * BIAS_HEADING,
                log_scale: sign(&mut rng) * BIAS_LOG_SCALE,
            }
            .apply(&s.truth)
        }
    };
    let sim = random_similarity(&mut rng, extent(&positions).max(f64::MIN_POSITIVE));
    positions.iter().map(|p| sim.apply(p)).collect()
}

/// Replays `positions` through the online detector, one pose at a time
/// (the caller waits for the matcher, so the candidates do not depend on
/// timing), and judges every candidate.
fn run_online(
    positions: &[Vector3<f64>],
    judge: impl Fn(&[LoopClaim]) -> (usize, usize, usize, Vec<bool>),
    offset: impl Fn(&LoopClaim) -> f64,
) -> OnlineRun {
    let start = Instant::now();
    let mut detector = Detector::new(OnlineConfig::default(), Overflow::Block);
    let mut events = Vec::new();
    for p in positions {
        detector.push(&PoseInput::at(*p));
        events.extend(detector.poll());
    }
    events.extend(detector.finish().0);
    let seconds = start.elapsed().as_secs_f64();
    let claims: Vec<LoopClaim> = events.iter().map(|e| (&e.hypothesis).into()).collect();
    let (covered, _, _, ok) = judge(&claims);
    OnlineRun {
        covered,
        claims: claims
            .into_iter()
            .zip(ok)
            .zip(&events)
            .map(|((c, ok), e)| (c, ok, offset(&c), e.source.name().to_string()))
            .collect(),
        seconds,
    }
}

/// Scores ranked claims on a truth (`arc`: its cumulative length): the events a correct claim's query
/// range touches, the claims, the correct ones, each claim's verdict. A
/// claim is judged by [`loop_correct_apart`] with the revisit gap, so that
/// the laps of a circuit flown again and again count.
fn judge(
    claims: &[LoopClaim],
    truth: &[Vector3<f64>],
    arc: &[f64],
    events: &[Event],
    radius: f64,
) -> (usize, usize, usize, Vec<bool>) {
    let gap = REVISIT_GAP * arc.last().copied().unwrap_or(0.0);
    let ok: Vec<bool> = claims
        .iter()
        .map(|c| loop_correct_apart(c, truth, arc, LOOP_RADII * radius, gap))
        .collect();
    let ranges: Vec<[f64; 2]> = claims
        .iter()
        .map(|c| query_range(c).map(|i| i as f64))
        .collect();
    let correct = ok.iter().filter(|x| **x).count();
    (covered(&ranges, &ok, events), claims.len(), correct, ok)
}

/// The naive baseline with the revisit rules of the truth: a match at
/// least [`REVISIT_GAP`] of the input's length back, within the revisit
/// radius in the input's own median steps, its best `top_k` loops.
fn naive(truth: &[Vector3<f64>], radius: f64, top_k: usize) -> Naive {
    let steps: Vec<f64> = truth
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .filter(|d| *d > 0.0)
        .collect();
    Naive {
        min_gap_share: REVISIT_GAP,
        threshold_steps: radius / median(&steps).max(f64::MIN_POSITIVE),
        top_k,
        ..Naive::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_online_replay_is_judged_like_the_loops() {
        // A square driven three times, streamed as it is: the detector
        // finds its revisits, and its candidates are judged by the loop
        // rules.
        let lap = crate::test_paths::square_loop(0, 0.0);
        let path: Vec<Vector3<f64>> = lap.iter().chain(&lap).chain(&lap).copied().collect();
        let s = Session {
            kind: Kind::Car,
            name: "square".into(),
            recording: "square".into(),
            frame: None,
            input: path.clone(),
            truth: path,
            judged: true,
        };
        let r = run(&s, Input::Truth, 1, true).expect("the drive revisits");
        let o = r.online.expect("replayed");
        assert!(
            r.events > 0 && o.covered > 0 && o.covered <= r.events,
            "{o:?}"
        );
        assert!(o.correct() > 0 && o.correct() <= o.candidates(), "{o:?}");
    }

    #[test]
    fn a_square_driven_twice_has_one_event_at_any_scale() {
        for unit in [0.01, 1.0, 100.0] {
            let path: Vec<_> = crate::test_paths::square_loop(0, 0.0)
                .iter()
                .chain(&crate::test_paths::square_loop(0, 0.0))
                .map(|p| p * unit)
                .collect();
            let (events, radius) = truth_events(&path);
            assert!((radius / unit - REVISIT_RADIUS * 100.0 * 2f64.sqrt()).abs() < 1e-6);
            assert_eq!(events.len(), 1, "unit {unit}: {events:?}");
            assert!(
                events[0].first <= 400 && events[0].last == 799,
                "{events:?}"
            );
        }
    }
}
