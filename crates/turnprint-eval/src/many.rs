//! Many paths placed in one frame by [`merge_many`]: the batch measurement
//! of the many-maps issue (`examples/evaluate_many.rs`).
//!
//! - **Chains**: 3-5 windows cut along one real drive (KITTI ground truth,
//!   the monocular ORB-SLAM2 estimates, car GPS: the catalog's sessions),
//!   consecutive windows sharing 30-60 % of a window's length and at least
//!   one window sharing no road with the first, so that it can only be
//!   placed through the others. (Asking it of every window after the
//!   second left almost no chain on the drives that loop back over the
//!   first window's road, 00, 02, 05 and 08, and filled the sample with
//!   the short straight ones.) Each window is under its own random
//!   similarity (scale 0.01-100, any rotation) and reversed at random. One
//!   or two strangers join each chain: windows of another recording (one of
//!   another car drive, one of another kind), shuffled in after the first
//!   window, which is the frame everything is placed in. A window misplaced
//!   or left out gets a [`Cause`], from the placement and from its pairs
//!   re-matched alone.
//! - **Multi-session sets**: every group of reference sessions the catalog
//!   records in one frame (EuRoC's machine hall and Vicon rooms, UZH-FPV's
//!   hangar, TUM-VI's room, each folder of pedestrian GPX tracks after the
//!   east-north-up conversion, KAIST-VIO's flights), merged whole once per
//!   group of its sessions joined by shared road, that group's best-joined
//!   session first.
//!
//! Every rule is a fraction of a length, so a 30 m flight and a 3 km drive
//! are judged alike:
//! - a window is placed correctly when its poses, mapped by the placement and
//!   taken from the first window's frame to the truth, land within
//!   [`MERGE_TOLERANCE`] of the window's length of their true positions
//!   (median): the rule, the tolerance of every merge case;
//! - a chain is drawn again unless every window's own best similarity onto
//!   its truth meets that rule (an estimate that bends more within a window
//!   cannot be placed right by any similarity: "unattainable");
//! - two paths share road as in [`crate::kinds`]: poses within [`SAME_ROAD`]
//!   of the first's extent; a window shares no road with the first when
//!   less than [`NO_ROAD_SHARE`] of its length does;
//! - a stranger is right when it is left out (`frames[i]` is `None`);
//! - a session of a set is right when placed within [`MERGE_TOLERANCE`] of
//!   its extent (not its length: a hand-held camera walks 150 m in a 5 m
//!   room, and TUM-VI room2 placed upside down at 0.84 times its size lies
//!   within 1 % of its length but 33 % of its extent) of its truth in the
//!   common frame (the first recording's, which is its own truth), and when
//!   left out exactly if no chain of sessions sharing road (at least
//!   [`SET_SHARE`] of the shorter one's length) joins it to the first.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::time::Instant;

use nalgebra::Vector3;
use rand::{rngs::StdRng, seq::IndexedRandom, Rng, SeedableRng};
use serde::Serialize;

use crate::checks::{median, overlap, road_turning_deg};
use crate::kinds::{catalog, extent, Kind, Session, MERGE_TOLERANCE, SAME_ROAD};
use crate::revisits::arc_lengths;
use crate::similarity::random_similarity;
use crate::windows::{frame_at_arc, random_window};
use crate::Source;
use turnprint::geometry::{Plane, Similarity3};
use turnprint::pipeline::placement::{MIN_OVERLAP_SCORE, STRONG_OVERLAP_SCORE};
use turnprint::pipeline::{match_paths, merge_many, Config, Placement};
use turnprint::{Result, Trajectory};

/// Windows per chain, inclusive: the 3-5.
pub const CHAIN_WINDOWS: (usize, usize) = (3, 5);
/// Consecutive windows share this fraction of a window's length: the
/// issue's 30-60 %.
pub const LINK_SHARE: (f64, f64) = (0.3, 0.6);
/// A chain spans this fraction of its drive: long windows, so that the
/// short drives (KITTI 04 is 390 m) still give chains.
pub const SPAN_SHARE: (f64, f64) = (0.6, 1.0);
/// A window shares no road with the first when less than this fraction of
/// its length lies on the first's road: a crossing or two ends touching,
/// not a road driven in common (the kinds' merge cases count up to 20 % a
/// glancing touch).
pub const NO_ROAD_SHARE: f64 = 0.05;
/// Strangers per chain, inclusive.
pub const STRANGERS: (usize, usize) = (1, 2);
/// A stranger is a window of this fraction of its session (as the kinds'
/// negatives).
pub const STRANGER_SHARE: (f64, f64) = (0.25, 0.5);
/// Fewest poses of a window (the catalog's fewest per session).
pub const MIN_POSES: usize = 20;
/// Two sessions of a set share road when at least this fraction of the
/// shorter one's length is common road (the kinds' merge cases redraw
/// below it).
pub const SET_SHARE: f64 = 0.2;
/// A chain has shape at every link when the road each window shares with
/// the one before it turns at least this much (degrees, summed over 10 m
/// steps: one street corner); a window on a straight link cannot be placed
/// by the shape of its turns. Reported beside the rate, not a filter.
pub const SHAPED_LINK_DEG: f64 = 90.0;
/// Draws per chain case before the source is given up.
const MAX_DRAWS: usize = 50;

/// Settings of one run.
#[derive(Debug, Clone)]
pub struct ManyOptions {
    /// The data folder (the shared layout).
    pub data: std::path::PathBuf,
    /// Seed of every draw.
    pub seed: u64,
    /// Chain cases in all, the sources taking turns.
    pub cases: usize,
    /// Sources of the chains: [`Source::Gt`], [`Source::Mono`],
    /// [`Source::Gps`] (and [`Source::Stereo`], S-PTAM).
    pub sources: Vec<Source>,
    /// Run the chains.
    pub chains: bool,
    /// Run the multi-session sets.
    pub sets: bool,
}

impl Default for ManyOptions {
    fn default() -> Self {
        ManyOptions {
            data: std::path::PathBuf::from("../shared/data"),
            seed: 1,
            cases: 120,
            sources: vec![Source::Gt, Source::Mono, Source::Gps],
            chains: true,
            sets: true,
        }
    }
}

/// The catalog's sessions of a chain source.
fn of_source(s: &Session, source: Source) -> bool {
    match source {
        Source::Gt => s.kind == Kind::Car,
        Source::Mono => s.kind == Kind::CarOdometry && s.name.starts_with("ORB-SLAM2 mono"),
        Source::Stereo => s.kind == Kind::CarOdometry && s.name.starts_with("S-PTAM"),
        Source::Gps => s.kind == Kind::CarGps,
        Source::Drift => false,
    }
}

/// A path as `merge_many` sees it, with the truth of each pose.
#[derive(Debug, Clone)]
pub struct Piece {
    /// Session name and pose range.
    pub name: String,
    /// The disguised input.
    pub input: Vec<Vector3<f64>>,
    /// The true position of each input pose (the session's truth frame).
    pub truth: Vec<Vector3<f64>>,
    /// The best similarity of the input onto its truth.
    pub truth_t_input: Similarity3,
    /// Road length of the truth.
    pub length: f64,
    /// The pose order is reversed.
    pub reversed: bool,
    /// Scale of the random similarity.
    pub scale: f64,
}

impl Piece {
    /// `input` (already disguised) with its truth; `None` when the input
    /// has no shape to fit a similarity to.
    pub fn new(name: String, input: Vec<Vector3<f64>>, truth: Vec<Vector3<f64>>) -> Option<Self> {
        let truth_t_input = Similarity3::fit(&input, &truth)?;
        let length = arc_lengths(&truth).last().copied().unwrap_or(0.0);
        (length > 0.0).then_some(Piece {
            name,
            input,
            truth,
            truth_t_input,
            length,
            reversed: false,
            scale: 1.0,
        })
    }

    /// Poses `[w0, w1]` of a session, reversed or not, under a random
    /// similarity.
    fn cut(rng: &mut impl Rng, s: &Session, w: [usize; 2], reversed: bool) -> Option<Self> {
        let (mut input, mut truth) = (s.input[w[0]..=w[1]].to_vec(), s.truth[w[0]..=w[1]].to_vec());
        if input.len() < MIN_POSES {
            return None;
        }
        if reversed {
            input.reverse();
            truth.reverse();
        }
        let sim = random_similarity(rng, extent(&input).max(f64::MIN_POSITIVE));
        let input = input.iter().map(|p| sim.apply(p)).collect();
        let name = format!("{} [{}..{}]", s.name, w[0], w[1]);
        let mut piece = Piece::new(name, input, truth)?;
        piece.reversed = reversed;
        piece.scale = sim.scale;
        Some(piece)
    }

    /// Median distance, over the length, of the poses mapped into the truth
    /// frame by `truth_t_input` from their truth.
    pub fn error(&self, truth_t_input: &Similarity3) -> f64 {
        median_miss(&self.input, &self.truth, |p| truth_t_input.apply(p)) / self.length
    }

    /// The piece's share of length on `other`'s road (radius: [`SAME_ROAD`]
    /// of `other`'s extent), and the turning (degrees) of that road.
    fn common_with(&self, other: &Piece) -> (f64, f64) {
        let common = overlap(&other.truth, &self.truth, SAME_ROAD * extent(&other.truth));
        let turning = road_turning_deg(&on_ground(&self.truth), &common.b);
        // An empty sum is -0.
        ((common.length / self.length).max(0.0), turning.max(0.0))
    }
}

/// Median distance of the `input` poses mapped by `map` from their `truth`.
fn median_miss(
    input: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    map: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> f64 {
    let d: Vec<f64> = input
        .iter()
        .zip(truth)
        .map(|(p, q)| (map(p) - q).norm())
        .collect();
    median(&d)
}

/// The points in their best-fit plane's coordinates with the plane as x-z,
/// the ground plane [`road_turning_deg`] measures headings in.
fn on_ground(points: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let plane = Plane::fit(points);
    points
        .iter()
        .map(|p| {
            let l = plane.local(p);
            Vector3::new(l.x, l.z, l.y)
        })
        .collect()
}

/// What `merge_many` did with one window of a chain.
#[derive(Debug, Clone, Serialize)]
pub struct WindowOutcome {
    /// Index in the chain (0 is the reference, not listed).
    pub index: usize,
    /// Session name and pose range.
    pub name: String,
    /// Poses.
    pub poses: usize,
    /// Road length of its truth (m).
    pub length: f64,
    /// Reversed pose order.
    pub reversed: bool,
    /// Scale of its random similarity.
    pub scale: f64,
    /// It shares road with the first window.
    pub shares_first: bool,
    /// Its share of length on the previous window's road.
    pub link_share: f64,
    /// Turning (degrees) of the road it shares with the previous window.
    pub link_turning_deg: f64,
    /// Its best similarity's error over its length: what no placement can
    /// beat.
    pub fit_error: f64,
    /// It was placed.
    pub placed: bool,
    /// The placement's median error over its length.
    pub error: Option<f64>,
    /// Placed within the tolerance.
    pub correct: bool,
    /// What it was placed through: `"window k"` or `"stranger"`.
    pub via: Option<String>,
    /// Why it is wrong or not placed.
    pub why: Option<String>,
    /// The cause, in short.
    pub cause: Option<Cause>,
}

/// What `merge_many` did with one stranger.
#[derive(Debug, Clone, Serialize)]
pub struct StrangerOutcome {
    /// Session name and pose range.
    pub name: String,
    /// Its session's kind.
    pub kind: Kind,
    /// Poses.
    pub poses: usize,
    /// It was left out (right).
    pub left_out: bool,
    /// What it was placed through, when placed.
    pub via: Option<String>,
    /// Score of the overlap that placed it.
    pub score: Option<f64>,
}

/// One chain case and its outcome.
#[derive(Debug, Clone, Serialize)]
pub struct ChainCase {
    /// Source of the chain.
    pub source: Source,
    /// Session of the chain.
    pub session: String,
    /// Windows in the chain, the first included.
    pub windows: usize,
    /// Every window after the first.
    pub outcomes: Vec<WindowOutcome>,
    /// The strangers.
    pub strangers: Vec<StrangerOutcome>,
    /// The least turning (degrees) of the road a window shares with the
    /// one before it.
    pub least_link_turning_deg: f64,
    /// Wall time (s) of `merge_many`.
    pub seconds: f64,
    /// `merge_many` failed, with its message (nothing placed).
    pub error: Option<String>,
}

/// A chain drawn: its windows (first the reference) and, per window after
/// the first, whether it shares road with the first, its share on the
/// previous window's road and that road's turning.
struct Chain {
    windows: Vec<Piece>,
    shares_first: Vec<bool>,
    links: Vec<(f64, f64)>,
}

/// A chain draw: made, unattainable (a window bends beyond the tolerance),
/// or nothing (too short, or every window on the first's road).
enum Draw {
    Made(Chain),
    Unattainable,
    Nothing,
}

/// Draws a chain along session `s` (see the module doc).
fn draw_chain(rng: &mut impl Rng, s: &Session) -> Draw {
    let arc = arc_lengths(&s.truth);
    let Some(&total) = arc.last() else {
        return Draw::Nothing;
    };
    let n = rng.random_range(CHAIN_WINDOWS.0..=CHAIN_WINDOWS.1);
    let links: Vec<f64> = (1..n)
        .map(|_| rng.random_range(LINK_SHARE.0..=LINK_SHARE.1))
        .collect();
    let span = rng.random_range(SPAN_SHARE.0..=SPAN_SHARE.1) * total;
    let length = span / (1.0 + links.iter().map(|o| 1.0 - o).sum::<f64>());
    let mut start = rng.random_range(0.0..=total - span);
    let mut windows = Vec::with_capacity(n);
    for k in 0..n {
        if k > 0 {
            start += (1.0 - links[k - 1]) * length;
        }
        let w = [
            frame_at_arc(&arc, start),
            frame_at_arc(&arc, start + length),
        ];
        let reversed = rng.random::<bool>();
        match Piece::cut(rng, s, w, reversed) {
            Some(piece) => windows.push(piece),
            None => return Draw::Nothing,
        }
    }
    let mut shares_first = vec![true];
    let mut link_roads = vec![(1.0, 0.0)];
    for k in 1..n {
        shares_first.push(windows[k].common_with(&windows[0]).0 >= NO_ROAD_SHARE);
        link_roads.push(windows[k].common_with(&windows[k - 1]));
    }
    if shares_first.iter().all(|s| *s) {
        return Draw::Nothing;
    }
    let attainable = windows
        .iter()
        .all(|w| w.error(&w.truth_t_input) <= MERGE_TOLERANCE);
    if !attainable {
        return Draw::Unattainable;
    }
    Draw::Made(Chain {
        windows,
        shares_first,
        links: link_roads,
    })
}

/// Draws a stranger for a chain along `chain`: a window of a session of
/// another recording and frame, of a car (another drive) or, when `car` is
/// false, of any other kind.
fn draw_stranger(
    rng: &mut impl Rng,
    sessions: &[Session],
    chain: &Session,
    car: bool,
) -> Option<(Kind, Piece)> {
    let cars = [Kind::Car, Kind::CarOdometry, Kind::CarGps];
    let others: Vec<&Session> = sessions
        .iter()
        .filter(|s| s.recording != chain.recording && (s.frame.is_none() || s.frame != chain.frame))
        .filter(|s| cars.contains(&s.kind) == car)
        .collect();
    let s = *others.choose(rng)?;
    let arc = arc_lengths(&s.truth);
    let length = rng.random_range(STRANGER_SHARE.0..=STRANGER_SHARE.1) * arc.last()?;
    let w = random_window(rng, &arc, length, length)?;
    let reversed = rng.random::<bool>();
    Some((s.kind, Piece::cut(rng, s, w, reversed)?))
}

/// Who a path given to `merge_many` is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Member {
    Window(usize),
    Stranger(usize),
}

impl Member {
    fn label(self) -> String {
        match self {
            Member::Window(k) => format!("window {k}"),
            Member::Stranger(_) => "stranger".into(),
        }
    }
}

/// Error over `b`'s length of an overlap `a_t_b` between two pieces of one
/// truth frame (the windows of a chain; `None` with a stranger).
fn overlap_error(a: &Piece, b: &Piece, a_t_b: &Similarity3) -> f64 {
    b.error(&a.truth_t_input.compose(a_t_b))
}

/// Runs `merge_many` on a chain and its strangers, and judges the outcome.
fn run_chain(
    rng: &mut impl Rng,
    source: Source,
    session: &Session,
    chain: Chain,
    strangers: Vec<(Kind, Piece)>,
) -> ChainCase {
    let n = chain.windows.len();
    let mut members: Vec<Member> = (0..n).map(Member::Window).collect();
    for k in 0..strangers.len() {
        let at = rng.random_range(1..=members.len());
        members.insert(at, Member::Stranger(k));
    }
    let piece = |m: Member| match m {
        Member::Window(k) => &chain.windows[k],
        Member::Stranger(k) => &strangers[k].1,
    };
    let paths: Vec<Trajectory> = members
        .iter()
        .map(|m| Trajectory::from_positions(piece(*m).name.clone(), &piece(*m).input))
        .collect();
    let start = Instant::now();
    let result = merge_many(&paths, &Config::for_matching());
    let seconds = start.elapsed().as_secs_f64();
    let (placement, failure) = match result {
        Ok(p) => (Some(p), None),
        Err(e) => (None, Some(e.to_string())),
    };
    let at = |m: Member| members.iter().position(|x| *x == m).unwrap_or(0);
    let frame = |m: Member| placement.as_ref().and_then(|p| p.frames[at(m)]);
    let via = |m: Member| {
        placement
            .as_ref()
            .and_then(|p| p.via[at(m)])
            .map(|q| members[q])
    };
    let first = &chain.windows[0];
    let mut outcomes: Vec<WindowOutcome> = (1..n)
        .map(|k| {
            let w = &chain.windows[k];
            let error = frame(Member::Window(k)).map(|f| w.error(&first.truth_t_input.compose(&f)));
            WindowOutcome {
                index: k,
                name: w.name.clone(),
                poses: w.input.len(),
                length: w.length,
                reversed: w.reversed,
                scale: w.scale,
                shares_first: chain.shares_first[k],
                link_share: chain.links[k].0,
                link_turning_deg: chain.links[k].1,
                fit_error: w.error(&w.truth_t_input),
                placed: error.is_some(),
                error,
                correct: error.is_some_and(|e| e <= MERGE_TOLERANCE),
                via: via(Member::Window(k)).map(Member::label),
                why: None,
                cause: None,
            }
        })
        .collect();
    let correct: Vec<bool> = std::iter::once(true)
        .chain(outcomes.iter().map(|o| o.correct))
        .collect();
    for o in outcomes.iter_mut().filter(|o| !o.correct) {
        let (cause, why) = match &placement {
            Some(p) => diagnose(&chain, &members, &piece, p, &correct, o.index),
            None => (
                Cause::Failed,
                format!("merge_many failed: {}", failure.as_deref().unwrap_or("")),
            ),
        };
        o.cause = Some(cause);
        o.why = Some(why);
    }
    let strangers = strangers
        .iter()
        .enumerate()
        .map(|(k, (kind, s))| {
            let m = Member::Stranger(k);
            let score = placement.as_ref().and_then(|p| {
                p.used
                    .iter()
                    .find(|e| e.a == at(m) || e.b == at(m))
                    .map(|e| e.hypothesis.score)
            });
            StrangerOutcome {
                name: s.name.clone(),
                kind: *kind,
                poses: s.input.len(),
                left_out: frame(m).is_none(),
                via: via(m).map(Member::label),
                score,
            }
        })
        .collect();
    ChainCase {
        source,
        session: session.name.clone(),
        windows: n,
        least_link_turning_deg: chain.links[1..]
            .iter()
            .map(|l| l.1)
            .fold(f64::INFINITY, f64::min),
        outcomes,
        strangers,
        seconds,
        error: failure,
    }
}

/// Why a window is misplaced or left out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    /// `merge_many` failed.
    Failed,
    /// Placed through a wrong pairwise match with a window placed right.
    WrongMatch,
    /// Placed through a misplaced window or a stranger.
    ThroughMisplaced,
    /// Not placed: its right overlap with a window placed right was
    /// contradicted (outvoted by a wrong overlap with another placed path).
    Outvoted,
    /// Not placed: no window beside it was placed right.
    ChainBroke,
    /// Not placed: the match with a window beside it is right but weak
    /// (between the edge and the strong score) and nothing corroborated it.
    Uncorroborated,
    /// Not placed: the match with the windows beside it is wrong.
    WrongLink,
    /// Not placed: no match with the windows beside it reaches the edge
    /// score.
    NoLink,
}

impl Cause {
    /// Every cause, in table order.
    pub const ALL: [Cause; 8] = [
        Cause::Failed,
        Cause::WrongMatch,
        Cause::ThroughMisplaced,
        Cause::Outvoted,
        Cause::ChainBroke,
        Cause::Uncorroborated,
        Cause::WrongLink,
        Cause::NoLink,
    ];

    /// Name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Cause::Failed => "merge_many failed",
            Cause::WrongMatch => "placed through a wrong pairwise match",
            Cause::ThroughMisplaced => "placed through a misplaced window or a stranger",
            Cause::Outvoted => "right link contradicted by a wrong overlap",
            Cause::ChainBroke => "chain broke before it",
            Cause::Uncorroborated => "right link weak, not corroborated",
            Cause::WrongLink => "link matched wrongly",
            Cause::NoLink => "link not found (below the edge score)",
        }
    }
}

/// Why window `k` of a chain is misplaced or left out: what it was placed
/// through, or what became of its overlaps with the placed paths
/// (re-matched alone, as `merge_many` matches each pair).
fn diagnose<'a>(
    chain: &Chain,
    members: &[Member],
    piece: &dyn Fn(Member) -> &'a Piece,
    placement: &Placement,
    correct: &[bool],
    k: usize,
) -> (Cause, String) {
    let at = |m: Member| members.iter().position(|x| *x == m).unwrap_or(0);
    let p = at(Member::Window(k));
    let w = &chain.windows[k];
    // Whether an overlap is right (`None` with a stranger), and its text.
    let judged = |e: &turnprint::pipeline::placement::Overlap| {
        let (ma, mb) = (members[e.a], members[e.b]);
        let (right, verdict) = match (ma, mb) {
            (Member::Window(_), Member::Window(_)) => {
                let err = overlap_error(piece(ma), piece(mb), &e.hypothesis.similarity());
                match err <= MERGE_TOLERANCE {
                    true => (Some(true), "right".to_string()),
                    false => (Some(false), format!("wrong ({:.0} % off)", 100.0 * err)),
                }
            }
            _ => (None, "a stranger".to_string()),
        };
        let text = format!(
            "{}-{} score {:.2} {verdict}",
            ma.label(),
            mb.label(),
            e.hypothesis.score
        );
        (right, text)
    };
    if let Some(q) = placement.via[p] {
        let edge = placement
            .used
            .iter()
            .find(|e| (e.a == p && e.b == q) || (e.a == q && e.b == p));
        let how = edge.map_or(String::new(), |e| judged(e).1);
        return match members[q] {
            Member::Stranger(_) => (
                Cause::ThroughMisplaced,
                format!("placed through a stranger: {how}"),
            ),
            Member::Window(j) if !correct[j] => (
                Cause::ThroughMisplaced,
                format!("placed through window {j}, itself misplaced: {how}"),
            ),
            Member::Window(j) => {
                let shared = w.common_with(&chain.windows[j]).0;
                (
                    Cause::WrongMatch,
                    format!(
                        "pairwise match wrong: {how}; they share {:.0} % of its length",
                        100.0 * shared
                    ),
                )
            }
        };
    }
    let contradicted: Vec<(Option<bool>, String)> = placement
        .contradicted
        .iter()
        .filter(|e| e.a == p || e.b == p)
        .map(judged)
        .collect();
    // Its rank-1 match with every placed path, re-run alone: the windows
    // beside it always, the others where the match makes an edge.
    let config = Config::for_matching();
    let mut links = Vec::new();
    let mut broke = true;
    // Of the windows beside it placed right: a right weak match, a wrong
    // match making an edge.
    let (mut weak_right, mut wrong) = (false, false);
    for (q, &m) in members.iter().enumerate() {
        if q == p || placement.frames[q].is_none() {
            continue;
        }
        let other = piece(m);
        let beside = matches!(m, Member::Window(j) if j + 1 == k || j == k + 1);
        let beside_right = beside && matches!(m, Member::Window(j) if correct[j]);
        broke &= !beside_right;
        let a = Trajectory::from_positions("a", &other.input);
        let b = Trajectory::from_positions("b", &w.input);
        let rank1 = match_paths(&a, &b, &config)
            .ok()
            .and_then(|h| h.into_iter().next());
        let score = rank1.as_ref().map_or(0.0, |h| h.score);
        if !beside && score < MIN_OVERLAP_SCORE {
            continue;
        }
        let road = match m {
            Member::Window(_) => {
                let (share, turning) = w.common_with(other);
                format!(
                    " (sharing {:.0} % of its length, turning {turning:.0}°)",
                    100.0 * share
                )
            }
            Member::Stranger(_) => String::new(),
        };
        let verdict = match rank1 {
            None => "no hypothesis".to_string(),
            Some(h) => {
                let level = if h.score < MIN_OVERLAP_SCORE {
                    "below the edge score"
                } else if h.score < STRONG_OVERLAP_SCORE {
                    "weak"
                } else {
                    "strong"
                };
                let right = match m {
                    Member::Stranger(_) => "a look-alike".to_string(),
                    Member::Window(_) => {
                        let err = overlap_error(other, w, &h.similarity());
                        let edge = h.score >= MIN_OVERLAP_SCORE;
                        if err <= MERGE_TOLERANCE {
                            weak_right |= beside_right && edge;
                            "right".to_string()
                        } else {
                            wrong |= beside_right && edge;
                            format!("wrong ({:.0} % off)", 100.0 * err)
                        }
                    }
                };
                format!("rank-1 score {:.2} ({level}), {right}", h.score)
            }
        };
        links.push(format!("with {}{road}: {verdict}", m.label()));
    }
    let outvoted = contradicted.iter().any(|(right, _)| *right == Some(true));
    let cause = if outvoted {
        Cause::Outvoted
    } else if broke {
        Cause::ChainBroke
    } else if weak_right {
        Cause::Uncorroborated
    } else if wrong {
        Cause::WrongLink
    } else {
        Cause::NoLink
    };
    let mut why = String::from("not placed");
    if broke {
        why.push_str(", no window beside it placed right");
    }
    if !links.is_empty() {
        let _ = write!(why, "; {}", links.join("; "));
    }
    if !contradicted.is_empty() {
        let texts: Vec<&str> = contradicted.iter().map(|(_, t)| t.as_str()).collect();
        let _ = write!(why, "; contradicted: {}", texts.join(", "));
    }
    (cause, why)
}

/// One session of a multi-session set and what became of it.
#[derive(Debug, Clone, Serialize)]
pub struct SetPath {
    /// Session name.
    pub name: String,
    /// Poses.
    pub poses: usize,
    /// Road length of its truth.
    pub length: f64,
    /// Its largest share of common road with another session of the set,
    /// over the shorter one's length (above 1 where the other runs over the
    /// shorter one's road more than once).
    pub best_share: f64,
    /// A chain of sessions sharing road joins it to the first.
    pub placeable: bool,
    /// It was placed.
    pub placed: bool,
    /// The session it was placed through.
    pub via: Option<String>,
    /// Median error of the placement over its extent: right within
    /// [`MERGE_TOLERANCE`].
    pub error: Option<f64>,
    /// Median error of the placement over its length.
    pub error_of_length: Option<f64>,
    /// Scale of the placement (1 when right).
    pub scale: Option<f64>,
    /// Rotation angle (degrees) of the placement (0 when right).
    pub turn_deg: Option<f64>,
    /// Placed within the tolerance, or left out when not placeable.
    pub right: bool,
}

/// A multi-session set merged whole.
#[derive(Debug, Clone, Serialize)]
pub struct SetCase {
    /// The frame the set shares.
    pub set: String,
    /// The reference session (the frame of the placement).
    pub first: String,
    /// Every other session.
    pub paths: Vec<SetPath>,
    /// Wall time (s) of `merge_many`.
    pub seconds: f64,
    /// `merge_many` failed, with its message.
    pub error: Option<String>,
}

/// The multi-session sets: reference sessions (their input is their truth)
/// grouped by frame, KAIST-VIO's flights as one (each starts at the origin
/// of its own frame, the take-off spot: the three squares' bounding boxes
/// agree within 0.2 m, the circles' lower corners within 0.1 m, a tenth of
/// a flight's tolerance of 2 % of 30-64 m), groups of one left out.
fn sets(sessions: &[Session]) -> BTreeMap<String, Vec<&Session>> {
    let mut sets: BTreeMap<String, Vec<&Session>> = BTreeMap::new();
    for s in sessions {
        if s.input != s.truth || s.kind == Kind::Wheeled {
            continue;
        }
        let frame = s
            .frame
            .clone()
            .or_else(|| s.name.starts_with("kaist-vio").then(|| "kaist-vio".into()));
        if let Some(frame) = frame {
            sets.entry(frame).or_default().push(s);
        }
    }
    sets.retain(|_, v| v.len() >= 2);
    sets
}

/// Merges a set once per group of sessions joined by shared road (of two
/// or more; once in all when there is none), the group's best-joined
/// session first (then its longest) and every other session of the set
/// in: the sessions outside the group are its strangers. Pedestrians' GPS
/// is judged on the ground plane: one place's elevation differs by up to
/// 180 m between the devices of one walk (Guichet's start: 306 m in two
/// Strava tracks, 126 m in the third), where their east and north agree
/// within 3 m.
fn run_set(name: &str, members: &[&Session]) -> Vec<SetCase> {
    let n = members.len();
    let flat = members.iter().all(|s| s.kind == Kind::Walker);
    let ground = |p: &Vector3<f64>| match flat {
        true => Vector3::new(p.x, p.y, 0.0),
        false => *p,
    };
    let truths: Vec<Vec<Vector3<f64>>> = members
        .iter()
        .map(|s| s.truth.iter().map(ground).collect())
        .collect();
    let lengths: Vec<f64> = truths
        .iter()
        .map(|t| arc_lengths(t).last().copied().unwrap_or(0.0))
        .collect();
    let mut shares = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let common = overlap(&truths[i], &truths[j], SAME_ROAD * extent(&truths[i]));
            shares[i][j] = common.length / lengths[i].min(lengths[j]).max(f64::MIN_POSITIVE);
            shares[j][i] = shares[i][j];
        }
    }
    let joined = |i: usize, j: usize| i != j && shares[i][j] >= SET_SHARE;
    let degree = |i: usize| (0..n).filter(|&j| joined(i, j)).count();
    // The groups joined by shared road.
    let mut group = vec![usize::MAX; n];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for root in 0..n {
        if group[root] != usize::MAX {
            continue;
        }
        let id = groups.len();
        group[root] = id;
        let mut found = vec![root];
        let mut k = 0;
        while k < found.len() {
            let i = found[k];
            let reached: Vec<usize> = (0..n)
                .filter(|&j| joined(i, j) && group[j] == usize::MAX)
                .collect();
            for j in reached {
                group[j] = id;
                found.push(j);
            }
            k += 1;
        }
        groups.push(found);
    }
    let best = |of: &[usize]| {
        of.iter().copied().max_by(|&i, &j| {
            (degree(i), lengths[i])
                .partial_cmp(&(degree(j), lengths[j]))
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(j.cmp(&i))
        })
    };
    let mut firsts: Vec<usize> = groups
        .iter()
        .filter(|g| g.len() >= 2)
        .filter_map(|g| best(g))
        .collect();
    if firsts.is_empty() {
        firsts.extend(best(&(0..n).collect::<Vec<_>>()));
    }
    firsts
        .into_iter()
        .map(|first| {
            let mut order = vec![first];
            order.extend((0..n).filter(|&i| i != first));
            let paths: Vec<Trajectory> = order
                .iter()
                .map(|&i| Trajectory::from_positions(members[i].name.clone(), &members[i].input))
                .collect();
            let start = Instant::now();
            let result = merge_many(&paths, &Config::for_matching());
            let seconds = start.elapsed().as_secs_f64();
            let (placement, error) = match result {
                Ok(p) => (Some(p), None),
                Err(e) => (None, Some(e.to_string())),
            };
            let paths = order
                .iter()
                .enumerate()
                .skip(1)
                .map(|(at, &i)| {
                    let s = members[i];
                    let frame = placement.as_ref().and_then(|p| p.frames[at]);
                    let d = frame
                        .as_ref()
                        .map(|f| median_miss(&s.input, &truths[i], |p| ground(&f.apply(p))));
                    let error = d.map(|d| d / extent(&truths[i]));
                    let placeable = group[i] == group[first];
                    SetPath {
                        name: s.name.clone(),
                        poses: s.input.len(),
                        length: lengths[i],
                        best_share: (0..n)
                            .filter(|&j| j != i)
                            .map(|j| shares[i][j])
                            .fold(0.0, f64::max),
                        placeable,
                        placed: frame.is_some(),
                        via: placement
                            .as_ref()
                            .and_then(|p| p.via[at])
                            .map(|q| members[order[q]].name.clone()),
                        error,
                        error_of_length: d.map(|d| d / lengths[i]),
                        scale: frame.as_ref().map(|f| f.scale),
                        turn_deg: frame.as_ref().map(|f| f.angle().to_degrees()),
                        right: error.map_or(!placeable, |e| e <= MERGE_TOLERANCE),
                    }
                })
                .collect();
            SetCase {
                set: name.to_string(),
                first: members[first].name.clone(),
                paths,
                seconds,
                error,
            }
        })
        .collect()
}

/// Everything one run produced.
#[derive(Debug, Default, Serialize)]
pub struct ManyReport {
    /// Seed of every draw.
    pub seed: u64,
    /// Every chain case run.
    pub cases: Vec<ChainCase>,
    /// Chains drawn and not run, per source: some window bends beyond the
    /// tolerance under its best similarity.
    pub unattainable: Vec<Source>,
    /// Every multi-session set.
    pub sets: Vec<SetCase>,
    /// Files of the catalog left out, with the reason.
    pub skipped: Vec<(String, String)>,
    /// Wall time (s) of the whole run.
    pub seconds: f64,
}

/// Runs the measurement.
pub fn evaluate(opts: &ManyOptions) -> Result<ManyReport> {
    let started = Instant::now();
    let dir = crate::data::resolve_data_dir(&opts.data)?;
    let found = catalog(&dir);
    let sessions = &found.sessions;
    let mut report = ManyReport {
        seed: opts.seed,
        skipped: found.skipped.clone(),
        ..Default::default()
    };
    let mut rng = StdRng::seed_from_u64(opts.seed);
    let sources: Vec<Source> = opts
        .sources
        .iter()
        .copied()
        .filter(|src| sessions.iter().any(|s| of_source(s, *src)))
        .collect();
    let set_list = match opts.sets {
        true => sets(sessions),
        false => BTreeMap::new(),
    };
    let cases = if opts.chains && !sources.is_empty() {
        opts.cases
    } else {
        0
    };
    let bar = indicatif::ProgressBar::new((cases + set_list.len()) as u64);
    for c in 0..cases {
        let source = sources[c % sources.len()];
        let own: Vec<&Session> = sessions.iter().filter(|s| of_source(s, source)).collect();
        for _ in 0..MAX_DRAWS {
            let s = own[rng.random_range(0..own.len())];
            let chain = match draw_chain(&mut rng, s) {
                Draw::Made(chain) => chain,
                Draw::Unattainable => {
                    report.unattainable.push(source);
                    continue;
                }
                Draw::Nothing => continue,
            };
            let count = rng.random_range(STRANGERS.0..=STRANGERS.1);
            let strangers: Vec<(Kind, Piece)> = (0..count)
                .filter_map(|k| draw_stranger(&mut rng, sessions, s, k == 0))
                .collect();
            report
                .cases
                .push(run_chain(&mut rng, source, s, chain, strangers));
            break;
        }
        bar.inc(1);
    }
    for (name, members) in &set_list {
        report.sets.extend(run_set(name, members));
        bar.inc(1);
    }
    bar.finish_and_clear();
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// `n` of `d` as a percentage (`-` of none).
fn share_of(n: usize, d: usize) -> String {
    if d == 0 {
        return "-".into();
    }
    format!("{:.1} %", 100.0 * n as f64 / d as f64)
}

impl ManyReport {
    /// The chain table: one row per source and one for all.
    pub fn chain_table(&self) -> String {
        let mut out = String::from(
            "| source | cases | windows (after the first) | placed correctly | placed wrongly | not placed | sharing no road with the first: placed correctly | chains turning 90° at every link: windows placed correctly | strangers | left out | median s per merge | chains unattainable |\n\
             |---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n",
        );
        let mut sources: Vec<Source> = self.cases.iter().map(|c| c.source).collect();
        sources.sort();
        sources.dedup();
        let rows = sources
            .into_iter()
            .map(|s| (s.name(), Some(s)))
            .chain(std::iter::once(("all", None)));
        for (name, source) in rows {
            let of = |s: Source| source.is_none_or(|x| x == s);
            let cases: Vec<&ChainCase> = self.cases.iter().filter(|c| of(c.source)).collect();
            let windows: Vec<&WindowOutcome> = cases.iter().flat_map(|c| &c.outcomes).collect();
            let count =
                |f: &dyn Fn(&WindowOutcome) -> bool| windows.iter().filter(|w| f(w)).count();
            let apart = count(&|w| !w.shares_first);
            let shaped: Vec<&WindowOutcome> = cases
                .iter()
                .filter(|c| c.least_link_turning_deg >= SHAPED_LINK_DEG)
                .flat_map(|c| &c.outcomes)
                .collect();
            let shaped_right = shaped.iter().filter(|w| w.correct).count();
            let strangers: Vec<&StrangerOutcome> =
                cases.iter().flat_map(|c| &c.strangers).collect();
            let left = strangers.iter().filter(|s| s.left_out).count();
            let seconds: Vec<f64> = cases.iter().map(|c| c.seconds).collect();
            let _ = writeln!(
                out,
                "| {name} | {} | {} | {} | {} | {} | {} of {apart} ({}) | {shaped_right} of {} ({}) | {} | {} | {:.1} | {} |",
                cases.len(),
                windows.len(),
                share_of(count(&|w| w.correct), windows.len()),
                count(&|w| w.placed && !w.correct),
                count(&|w| !w.placed),
                count(&|w| !w.shares_first && w.correct),
                share_of(count(&|w| !w.shares_first && w.correct), apart),
                shaped.len(),
                share_of(shaped_right, shaped.len()),
                strangers.len(),
                share_of(left, strangers.len()),
                median(&seconds),
                self.unattainable.iter().filter(|s| of(**s)).count(),
            );
        }
        out
    }

    /// Windows misplaced or left out, by cause and source, with the median
    /// turning of the road each shares with the window before it.
    pub fn cause_table(&self) -> String {
        let mut sources: Vec<Source> = self.cases.iter().map(|c| c.source).collect();
        sources.sort();
        sources.dedup();
        let mut out = String::from("| cause |");
        for s in &sources {
            let _ = write!(out, " {} |", s.name());
        }
        out.push_str(" all | median turning of the link (°) |\n|---|");
        out.push_str(&"--:|".repeat(sources.len() + 2));
        out.push('\n');
        let of = |cause: Cause, source: Option<Source>| -> Vec<&WindowOutcome> {
            self.cases
                .iter()
                .filter(|c| source.is_none_or(|s| s == c.source))
                .flat_map(|c| &c.outcomes)
                .filter(|w| w.cause == Some(cause))
                .collect()
        };
        for cause in Cause::ALL {
            let all = of(cause, None);
            if all.is_empty() {
                continue;
            }
            let _ = write!(out, "| {} |", cause.name());
            for s in &sources {
                let _ = write!(out, " {} |", of(cause, Some(*s)).len());
            }
            let turning: Vec<f64> = all.iter().map(|w| w.link_turning_deg).collect();
            let _ = writeln!(out, " {} | {:.0} |", all.len(), median(&turning));
        }
        out
    }

    /// Every window misplaced or left out, and every stranger placed.
    pub fn failures(&self) -> String {
        let mut out = String::new();
        for (c, case) in self.cases.iter().enumerate() {
            for w in case.outcomes.iter().filter(|w| !w.correct) {
                let _ = writeln!(
                    out,
                    "- case {c} ({}, {} windows): window {} {} [{}] ({}{}, error {}): {}",
                    case.source.name(),
                    case.windows,
                    w.index,
                    w.name,
                    w.cause.map_or("", Cause::name),
                    if w.placed {
                        "placed wrongly"
                    } else {
                        "not placed"
                    },
                    if w.shares_first {
                        ""
                    } else {
                        ", no road with the first"
                    },
                    w.error
                        .map_or("-".into(), |e| format!("{:.1} % of its length", 100.0 * e)),
                    w.why.as_deref().unwrap_or(""),
                );
            }
            for s in case.strangers.iter().filter(|s| !s.left_out) {
                let _ = writeln!(
                    out,
                    "- case {c} ({}, {}): stranger {} placed through {} (score {})",
                    case.source.name(),
                    case.session,
                    s.name,
                    s.via.as_deref().unwrap_or("?"),
                    s.score.map_or("-".into(), |x| format!("{x:.2}")),
                );
            }
        }
        out
    }

    /// The multi-session table: one row per set.
    pub fn set_table(&self) -> String {
        let mut out = String::from(
            "| set | first | others | joined to the first by shared road | placed right | placed wrongly | not placed | joined to none | left out | s per merge |\n\
             |---|---|--:|--:|--:|--:|--:|--:|--:|--:|\n",
        );
        let row = |out: &mut String, set: &str, first: &str, paths: &[&SetPath], seconds: f64| {
            let count = |f: &dyn Fn(&SetPath) -> bool| paths.iter().filter(|p| f(p)).count();
            let joined = count(&|p| p.placeable);
            let apart = paths.len() - joined;
            let _ = writeln!(
                out,
                "| {set} | {first} | {} | {joined} | {} ({}) | {} | {} | {apart} | {} ({}) | {seconds:.1} |",
                paths.len(),
                count(&|p| p.placeable && p.right),
                share_of(count(&|p| p.placeable && p.right), joined),
                count(&|p| p.placeable && p.placed && !p.right),
                count(&|p| p.placeable && !p.placed),
                count(&|p| !p.placeable && !p.placed),
                share_of(count(&|p| !p.placeable && !p.placed), apart),
            );
        };
        for set in &self.sets {
            let paths: Vec<&SetPath> = set.paths.iter().collect();
            row(&mut out, &set.set, &set.first, &paths, set.seconds);
        }
        let all: Vec<&SetPath> = self.sets.iter().flat_map(|s| &s.paths).collect();
        let seconds: Vec<f64> = self.sets.iter().map(|s| s.seconds).collect();
        row(&mut out, "all", "", &all, median(&seconds));
        out
    }

    /// Every session of every set.
    pub fn set_paths(&self) -> String {
        let mut out = String::from(
            "| set (first) | session | poses | best share of road | joined to the first | placed via | error (extent) | error (length) | scale | turn |\n\
             |---|---|--:|--:|---|---|--:|--:|--:|--:|\n",
        );
        for set in &self.sets {
            for p in &set.paths {
                let f = |x: Option<f64>, k: f64, unit: &str| {
                    x.map_or("-".into(), |x| format!("{:.2}{unit}", k * x))
                };
                let _ = writeln!(
                    out,
                    "| {} ({}) | {} | {} | {:.0} % | {} | {} | {} | {} | {} | {} |",
                    set.set,
                    set.first,
                    p.name,
                    p.poses,
                    100.0 * p.best_share,
                    if p.placeable { "yes" } else { "no" },
                    p.via.as_deref().unwrap_or("-"),
                    f(p.error, 100.0, " %"),
                    f(p.error_of_length, 100.0, " %"),
                    f(p.scale, 1.0, ""),
                    f(p.turn_deg, 1.0, "°"),
                );
            }
        }
        out
    }

    /// All tables.
    pub fn markdown(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "Seed {}, {:.0} s in all.\n", self.seed, self.seconds);
        if !self.cases.is_empty() {
            let _ = writeln!(out, "{}", self.chain_table());
            let _ = writeln!(out, "{}", self.cause_table());
            let failures = self.failures();
            if !failures.is_empty() {
                let _ = writeln!(out, "{failures}");
            }
        }
        if !self.sets.is_empty() {
            let _ = writeln!(out, "{}", self.set_table());
            let _ = writeln!(out, "{}", self.set_paths());
        }
        for (file, why) in self.skipped.iter().filter(|(_, why)| why != "absent") {
            let _ = writeln!(out, "- left out: {file}: {why}");
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// A window under a known similarity is judged by the placement that
    /// undoes it: exact is right, one moved by 3 % of the length is wrong,
    /// whatever the units of the frame it is placed in.
    #[test]
    fn a_window_is_right_within_two_percent_of_its_length() {
        let truth: Vec<Vector3<f64>> = (0..200)
            .map(|i| {
                let a = i as f64 * 0.02;
                Vector3::new(100.0 * a.cos(), 0.0, 60.0 * a.sin())
            })
            .collect();
        let first_t_truth = Similarity3 {
            scale: 0.03,
            rotation: Rotation3::from_euler_angles(0.3, -1.0, 2.0).into_inner(),
            translation: Vector3::new(5.0, -7.0, 1.0),
        };
        let window_t_truth = Similarity3 {
            scale: 40.0,
            rotation: Rotation3::from_euler_angles(-2.0, 0.5, 0.1).into_inner(),
            translation: Vector3::new(-300.0, 20.0, 9.0),
        };
        let first_input: Vec<_> = truth.iter().map(|p| first_t_truth.apply(p)).collect();
        let first = Piece::new("first".into(), first_input, truth.clone()).unwrap();
        let input: Vec<_> = truth.iter().map(|p| window_t_truth.apply(p)).collect();
        let window = Piece::new("w".into(), input, truth.clone()).unwrap();
        assert!(window.error(&window.truth_t_input) < 1e-9);
        let right = first_t_truth.compose(&window_t_truth.inverse());
        let judged = |f: &Similarity3| window.error(&first.truth_t_input.compose(f));
        assert!(judged(&right) < 1e-9);
        let shift = Similarity3 {
            scale: 1.0,
            rotation: nalgebra::Matrix3::identity(),
            translation: Vector3::new(0.03 * window.length * first_t_truth.scale, 0.0, 0.0),
        };
        let off = judged(&shift.compose(&right));
        assert!((off - 0.03).abs() < 1e-6 && off > MERGE_TOLERANCE, "{off}");
        // Its overlap with the first, judged from the first's side, alike.
        assert!(overlap_error(&first, &window, &right) < 1e-9);
    }
}
