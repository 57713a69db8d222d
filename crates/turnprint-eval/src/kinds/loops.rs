//! Loop runs of every kind that revisits: `find_loops`, the online
//! detector replaying the same input pose by pose, and the naive
//! nearest-earlier-position baseline on each judged session, scored against
//! the revisit events of its truth.
//!
//! Inputs per session: an estimate as recorded (its own drift); for a
//! reference (motion capture, GPS) the truth itself, the truth under a
//! random walk (heading 0.3 rad and log-scale 0.05 one-sigma at the path's
//! end) and the truth under a systematic bias (heading 0.2 rad and
//! log-scale 0.15 at the end, signs drawn: wheels of unequal radii, a
//! monocular VO's growing scale). Every input is put under a random
//! similarity.
//!
//! A log without a true path but with measured relations (CARMEN ACES) is
//! judged by them: its revisit events are the relations that close loops
//! ([`revisit_events`]), and a loop is right when the relations joining its
//! passes agree with its similarity ([`loop_misses`]).

// Frame names as in Sophus: `a_T_b` maps points from b to a.
#![allow(non_snake_case)]

use std::time::Instant;

use nalgebra::Vector3;
use rand::{rngs::StdRng, Rng, SeedableRng};
use serde::Serialize;

use super::catalog::Measured;
use super::{extent, Kind, Session, EVENT_MIN_RADII, LOOP_RADII, REVISIT_GAP, REVISIT_RADIUS};
use crate::baseline::Naive;
use crate::checks::{loop_correct_apart, median, LoopClaim};
use crate::drift::{DriftBias, DriftModel};
use crate::loops::{covered, query_range, TOP_K};
use crate::relations::{loop_misses, revisit_events, RevisitEvent};
use crate::revisits::{arc_lengths, events, nearest_earlier_apart, true_offset, Event};
use crate::similarity::random_similarity;
use crate::EVENT_MAX_GAP;
use turnprint::geometry::Similarity3;
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

/// The inputs a session is run with: a reference as it is and under both
/// drift models; an estimate (or a log judged by its relations, which
/// hold for its own poses only) as recorded.
pub fn inputs(s: &Session) -> Vec<Input> {
    match s.input == s.truth && s.relations.is_none() {
        true => vec![Input::Truth, Input::Walk, Input::Bias],
        false => vec![Input::Estimate],
    }
}

/// Runs both methods (and the online detector when `online`) on one
/// session and input; `None` when the session's loops are not judged or it
/// has no revisit event.
pub fn run(s: &Session, input: Input, seed: u64, online: bool) -> Option<LoopRun> {
    let (positions, input_T_session) = input_positions(s, input, seed);
    let referee = Referee::new(s, input_T_session)?;

    let mut config = Config::for_loops();
    // The first ten of the ranked fifty are the top ten (ranking keeps the
    // best in order and stops at the count).
    config.top_k = WIDE_K;
    let start = Instant::now();
    let found = find_loops(&Trajectory::from_positions(&s.name, &positions), &config);
    let seconds = start.elapsed().as_secs_f64();
    let (mut claims, error) = match found {
        Ok(h) => (
            h.iter()
                .map(|h| (LoopClaim::from(h), h.similarity()))
                .collect::<Vec<_>>(),
            None,
        ),
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    claims.sort_by(|x, y| y.0.score.total_cmp(&x.0.score));
    let wide = claims.clone();
    claims.truncate(TOP_K);
    // The naive loops are sorted and cut too: its first ten are its top
    // ten. Each claims its passes coincide where the input has them.
    let naive_wide: Vec<(LoopClaim, Similarity3)> = naive(&s.truth, referee.radius(), WIDE_K)
        .loops(&positions)
        .into_iter()
        .map(|c| (c, Similarity3::identity()))
        .collect();
    let naive = &naive_wide[..naive_wide.len().min(TOP_K)];

    let (t, n) = (referee.judge(&claims), referee.judge(naive));
    let covered_wide = [referee.judge(&wide).0, referee.judge(&naive_wide).0];
    let online = online.then(|| run_online(&positions, &referee));
    Some(LoopRun {
        kind: s.kind,
        session: s.name.clone(),
        input,
        events: referee.event_ranges().len(),
        event_ranges: referee.event_ranges(),
        covered: [t.0, n.0],
        covered_wide,
        rank1_correct: [t.3.first() == Some(&true), n.3.first() == Some(&true)],
        returned: [t.1, n.1],
        correct: [t.2, n.2],
        loops: claims
            .iter()
            .zip(&t.3)
            .map(|(c, ok)| (c.0, *ok, referee.offset(c)))
            .collect(),
        seconds,
        error,
        online,
    })
}

/// The input a loop run is given: the estimate, or the truth as it is,
/// under a random walk or under a bias; then under a random similarity,
/// returned beside it (`input_T_session`).
fn input_positions(s: &Session, input: Input, seed: u64) -> (Vec<Vector3<f64>>, Similarity3) {
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
    (positions.iter().map(|p| sim.apply(p)).collect(), sim)
}

/// Replays `positions` through the online detector, one pose at a time
/// (the caller waits for the matcher, so the candidates do not depend on
/// timing), and judges every candidate.
fn run_online(positions: &[Vector3<f64>], referee: &Referee) -> OnlineRun {
    let start = Instant::now();
    let mut detector = Detector::new(OnlineConfig::default(), Overflow::Block);
    let mut events = Vec::new();
    for p in positions {
        detector.push(&PoseInput::at(*p));
        events.extend(detector.poll());
    }
    events.extend(detector.finish().0);
    let seconds = start.elapsed().as_secs_f64();
    let claims: Vec<(LoopClaim, Similarity3)> = events
        .iter()
        .map(|e| ((&e.hypothesis).into(), e.hypothesis.similarity()))
        .collect();
    let (covered, _, _, ok) = referee.judge(&claims);
    OnlineRun {
        covered,
        claims: claims
            .iter()
            .zip(ok)
            .zip(&events)
            .map(|((c, ok), e)| (c.0, ok, referee.offset(c), e.source.name().to_string()))
            .collect(),
        seconds,
    }
}

/// What judges a session's loops, each claim with its similarity in the
/// input's frame (`query_T_match`).
enum Referee<'a> {
    /// The true path: a claim is judged by [`loop_correct_apart`] with the
    /// revisit gap, so that the laps of a circuit flown again and again
    /// count.
    Truth {
        truth: &'a [Vector3<f64>],
        /// Cumulative length of the truth.
        arc: Vec<f64>,
        events: Vec<Event>,
        radius: f64,
    },
    /// Measured relations ([`crate::relations`]), read against the log's
    /// own poses: a claim is right when the relations joining its passes
    /// place its query poses within [`LOOP_RADII`] revisit radii of where
    /// its similarity puts them (median); a claim no relation joins is
    /// counted wrong, as nothing shows it right. Only revisits judge, so
    /// that a claim pairing a stretch with its neighbourhood is not
    /// called right by the odometry's own motion. Revisits are sparse (88
    /// relations over ACES's 7375 poses), so a claim's passes are
    /// widened by `join` of road each way, the distance within which
    /// relations make one event.
    Relations {
        measured: &'a Measured,
        /// Cumulative length of the log.
        arc: Vec<f64>,
        /// The relations that close a loop (those of the events).
        revisit: Vec<bool>,
        events: Vec<RevisitEvent>,
        radius: f64,
        join: f64,
        input_T_session: Similarity3,
    },
}

impl<'a> Referee<'a> {
    /// `None` when nothing judges the session's loops or it revisits
    /// nothing.
    fn new(s: &'a Session, input_T_session: Similarity3) -> Option<Self> {
        let referee = if let Some(measured) = s.relations.as_deref() {
            // The relations' units are the log's: its revisit radius is
            // taken from its own extent, as a truth's is.
            let radius = REVISIT_RADIUS * extent(&s.input);
            let join = EVENT_MIN_RADII * radius;
            let arc = arc_lengths(&s.input);
            // A revisit as the truth's rules have it: passes at least the
            // revisit gap of road apart.
            let apart = REVISIT_GAP * arc.last().copied().unwrap_or(0.0);
            let events = revisit_events(&measured.poses, &measured.relations, join, apart);
            let mut revisit = vec![false; measured.relations.len()];
            for k in events.iter().flat_map(|e| &e.relations) {
                revisit[*k] = true;
            }
            Referee::Relations {
                measured,
                arc,
                revisit,
                events,
                radius,
                join,
                input_T_session,
            }
        } else if s.judged {
            let (events, radius) = truth_events(&s.truth);
            Referee::Truth {
                truth: &s.truth,
                arc: arc_lengths(&s.truth),
                events,
                radius,
            }
        } else {
            return None;
        };
        (!referee.event_ranges().is_empty()).then_some(referee)
    }

    fn radius(&self) -> f64 {
        match self {
            Referee::Truth { radius, .. } | Referee::Relations { radius, .. } => *radius,
        }
    }

    /// Each event's revisiting poses and the earlier poses they match.
    fn event_ranges(&self) -> Vec<[usize; 4]> {
        match self {
            Referee::Truth { events, .. } => events
                .iter()
                .map(|e| [e.first, e.last, e.match_first, e.match_last])
                .collect(),
            Referee::Relations { events, .. } => events
                .iter()
                .map(|e| [e.query[0], e.query[1], e.matched[0], e.matched[1]])
                .collect(),
        }
    }

    /// The median of a claim's misses over the revisits joining its
    /// passes, in the log's units, and those revisits; `None` where none
    /// joins them (and for a truth).
    fn miss(&self, (c, input_T): &(LoopClaim, Similarity3)) -> Option<(f64, Vec<usize>)> {
        let Referee::Relations {
            measured,
            arc,
            revisit,
            join,
            input_T_session,
            ..
        } = self
        else {
            return None;
        };
        // The claim's similarity in the log's frame: into the input's
        // frame, the claim's similarity there, and back.
        let session_T = input_T_session
            .inverse()
            .compose(input_T)
            .compose(input_T_session);
        let matched = [
            c.matched[0].min(c.matched[1]),
            c.matched[0].max(c.matched[1]),
        ];
        let (joined, misses): (Vec<usize>, Vec<f64>) = loop_misses(
            &measured.poses,
            &measured.relations,
            widened(arc, query_range(c), *join),
            widened(arc, matched, *join),
            &session_T,
        )
        .into_iter()
        .filter(|(k, _)| revisit[*k])
        .unzip();
        (!misses.is_empty()).then(|| (median(&misses), joined))
    }

    /// The true median offset between a claim's passes in revisit radii
    /// (relations: its median miss; NaN where none joins it).
    fn offset(&self, claim: &(LoopClaim, Similarity3)) -> f64 {
        match self {
            Referee::Truth { truth, radius, .. } => {
                true_offset(claim.0.query, claim.0.matched, truth) / radius
            }
            Referee::Relations { radius, .. } => {
                self.miss(claim).map_or(f64::NAN, |m| m.0 / radius)
            }
        }
    }

    /// Scores ranked claims: the events a correct claim touches (truth: its
    /// query range; relations: one of the event's relations joins its
    /// passes), the claims, the correct ones, each claim's verdict.
    fn judge(&self, claims: &[(LoopClaim, Similarity3)]) -> (usize, usize, usize, Vec<bool>) {
        let (covered, ok) = match self {
            Referee::Truth {
                truth,
                arc,
                events,
                radius,
            } => {
                let gap = REVISIT_GAP * arc.last().copied().unwrap_or(0.0);
                let ok: Vec<bool> = claims
                    .iter()
                    .map(|c| loop_correct_apart(&c.0, truth, arc, LOOP_RADII * radius, gap))
                    .collect();
                let ranges: Vec<[f64; 2]> = claims
                    .iter()
                    .map(|c| query_range(&c.0).map(|i| i as f64))
                    .collect();
                (covered(&ranges, &ok, events), ok)
            }
            Referee::Relations { events, radius, .. } => {
                let mut joined: Vec<usize> = Vec::new();
                let ok: Vec<bool> = claims
                    .iter()
                    .map(|c| match self.miss(c) {
                        Some((m, relations)) if m <= LOOP_RADII * radius => {
                            joined.extend(relations);
                            true
                        }
                        _ => false,
                    })
                    .collect();
                let covered = events
                    .iter()
                    .filter(|e| e.relations.iter().any(|r| joined.contains(r)))
                    .count();
                (covered, ok)
            }
        };
        let correct = ok.iter().filter(|x| **x).count();
        (covered, claims.len(), correct, ok)
    }
}

/// The poses of `range` and those within `margin` of road beyond either
/// end (`arc`: cumulative length).
fn widened(arc: &[f64], [a, b]: [usize; 2], margin: f64) -> [usize; 2] {
    let (Some(start), Some(end)) = (arc.get(a), arc.get(b)) else {
        return [a, b];
    };
    [
        arc.partition_point(|s| *s < start - margin),
        arc.partition_point(|s| *s <= end + margin)
            .saturating_sub(1)
            .max(b),
    ]
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
    use crate::relations::Relation;
    use nalgebra::{UnitQuaternion, Vector2};
    use turnprint::Pose;

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
            relations: None,
        };
        let r = run(&s, Input::Truth, 1, true).expect("the drive revisits");
        let o = r.online.expect("replayed");
        assert!(
            r.events > 0 && o.covered > 0 && o.covered <= r.events,
            "{o:?}"
        );
        assert!(o.correct() > 0 && o.correct() <= o.candidates(), "{o:?}");
    }

    /// A square driven three times, timed and headed along its road, its
    /// x drifting by `drift` a lap (as odometry's does), with relations
    /// from each later pass to every earlier one at every tenth pose,
    /// measuring the passes `side` apart.
    fn square_with_relations(drift: f64, side: f64) -> Session {
        let lap = crate::test_paths::square_loop(0, 0.0);
        let n = lap.len() as f64;
        let path: Vec<Vector3<f64>> = (0..3 * lap.len())
            .map(|i| lap[i % lap.len()] + Vector3::x() * (drift * i as f64 / n))
            .collect();
        let poses: Vec<Pose> = path
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let next = path[(i + 1).min(path.len() - 1)] - path[i.saturating_sub(1)];
                Pose {
                    t: Some(i as f64),
                    position: *p,
                    orientation: Some(UnitQuaternion::from_axis_angle(
                        &Vector3::z_axis(),
                        next.y.atan2(next.x),
                    )),
                }
            })
            .collect();
        let relations = (lap.len()..path.len())
            .step_by(10)
            .flat_map(|i| {
                (lap.len()..=i)
                    .step_by(lap.len())
                    .map(move |back| (i - back, i))
            })
            .map(|(a, b)| Relation {
                t: [a as f64, b as f64],
                translation: Vector2::new(0.0, side),
                yaw: 0.0,
            })
            .collect();
        Session {
            kind: Kind::Wheeled,
            name: "square".into(),
            recording: "square".into(),
            frame: None,
            input: path.clone(),
            truth: path,
            judged: false,
            relations: Some(std::sync::Arc::new(Measured { poses, relations })),
        }
    }

    #[test]
    fn a_log_without_a_truth_is_judged_by_its_relations() {
        // The relations say the passes coincide where the odometry has
        // them 15 and 30 apart: the loops that lay them on one another are right,
        // batch and online.
        let s = square_with_relations(15.0, 0.0);
        assert_eq!(inputs(&s), vec![Input::Estimate]);
        let r = run(&s, Input::Estimate, 1, true).expect("judged by its relations");
        assert!(r.events > 0, "{r:?}");
        assert!(r.covered[0] > 0 && r.rank1_correct[0], "{r:?}");
        let o = r.online.as_ref().expect("replayed");
        assert!(o.covered > 0 && o.correct() > 0, "{o:?}");
        // Passes that coincide in the odometry against relations measuring
        // them 30 apart (ten revisit radii): no loop is right.
        let r = run(&square_with_relations(0.0, 30.0), Input::Estimate, 1, true).unwrap();
        assert!(r.events > 0 && r.returned[0] > 0, "{r:?}");
        assert_eq!((r.covered[0], r.correct[0]), (0, 0), "{r:?}");
        assert_eq!(r.online.unwrap().correct(), 0);
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
