//! Pose streams for the online detector, drawn by `arbitrary` as a short
//! program (drive, stand, jump, revisit, mess with the clock) rather than
//! raw coordinates: random coordinates never get past the warm-up or form a
//! segment, so the search and the worker would go unfuzzed. Every number is
//! a [`Num`], which reaches NaN, infinities, the extremes and subnormals as
//! often as ordinary values.

use arbitrary::Arbitrary;
use nalgebra::{UnitQuaternion, Vector3};
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput, Pushed};

/// Poses pushed at most per input: enough for several warm-ups' worth of
/// path and revisits, few enough that one input runs in well under a second.
pub const MAX_POSES: usize = 12_000;

/// One run: detector settings, then the program that makes the poses.
#[derive(Debug, Arbitrary)]
pub struct Run {
    settings: Settings,
    ops: Vec<Op>,
}

/// The detector settings a caller may reasonably choose.
#[derive(Debug, Arbitrary)]
struct Settings {
    /// Warm-up poses: `8 + warmup`, or the default for 255 (short warm-ups
    /// let short inputs reach the streams and the worker).
    warmup: u8,
    /// `Overflow::MergeLatest` instead of `Overflow::Block`.
    merge_latest: bool,
    /// Two matching threads instead of one.
    two_workers: bool,
    /// Proximity probe off.
    no_proximity: bool,
    /// Drifting-map probe off.
    no_drift_probe: bool,
    /// Poll every `poll_every` pushes (0: only at `Op::Poll`).
    poll_every: u8,
}

/// A number, with the awkward ones as likely as the rest.
#[derive(Debug, Clone, Copy, Arbitrary)]
pub enum Num {
    /// An integer.
    Int(i16),
    /// Thousandths.
    Milli(i32),
    /// Any bit pattern.
    Bits(u64),
    /// NaN.
    Nan,
    /// +inf.
    Inf,
    /// -inf.
    NegInf,
    /// The largest finite value, signed.
    Max(bool),
    /// The smallest normal positive value.
    MinPositive,
    /// A subnormal.
    Subnormal(u16),
    /// `±10^e` for `e` in -324..=308: scales from subnormal to overflow.
    Power(bool, i16),
    /// -0.0.
    NegZero,
}

impl Num {
    /// The value.
    pub fn get(self) -> f64 {
        match self {
            Num::Int(i) => f64::from(i),
            Num::Milli(i) => f64::from(i) * 1e-3,
            Num::Bits(b) => f64::from_bits(b),
            Num::Nan => f64::NAN,
            Num::Inf => f64::INFINITY,
            Num::NegInf => f64::NEG_INFINITY,
            Num::Max(negative) => sign(negative, f64::MAX),
            Num::MinPositive => f64::MIN_POSITIVE,
            Num::Subnormal(m) => f64::from_bits(u64::from(m.max(1))),
            Num::Power(negative, e) => {
                sign(negative, 10f64.powi(i32::from(e.rem_euclid(633)) - 324))
            }
            Num::NegZero => -0.0,
        }
    }
}

fn sign(negative: bool, v: f64) -> f64 {
    if negative {
        -v
    } else {
        v
    }
}

/// One instruction of the pose program.
#[derive(Debug, Arbitrary)]
enum Op {
    /// `n` poses along an arc: step length, turn per step (radians), climb.
    Drive {
        n: u8,
        step: Num,
        turn: Num,
        climb: Num,
    },
    /// One pose at a place (a jump, a glitch, a re-initialisation).
    At { x: Num, y: Num, z: Num },
    /// `n` poses standing still, jittering by up to `jitter`.
    Stand { n: u8, jitter: Num },
    /// The last pose again `n` times, same time included (duplicates).
    Repeat { n: u8 },
    /// Drive again over `n` earlier poses from `from`, shifted, in either
    /// direction: a revisit, for the search to find.
    Revisit {
        from: u16,
        n: u16,
        dx: Num,
        dy: Num,
        backwards: bool,
    },
    /// The clock.
    Clock(Clock),
    /// Every `every`-th pose from now on is a keyframe (0: none), ids from
    /// `first`.
    Keyframes { every: u8, first: u64 },
    /// Poll the candidates now.
    Poll,
}

/// What the clock does to the poses that follow.
#[derive(Debug, Arbitrary)]
enum Clock {
    /// Timestamps from `start`, `dt` apart.
    Start { start: Num, dt: Num },
    /// A new step between timestamps (0 or negative: duplicates, out of
    /// order).
    Step(Num),
    /// Time goes back by this much once.
    Back(Num),
    /// No timestamps.
    Off,
}

/// The state of the program: where the robot is and what it sends.
struct Robot {
    position: Vector3<f64>,
    heading: f64,
    t: Option<f64>,
    dt: f64,
    keyframe_every: u8,
    next_keyframe: u64,
    /// Every position pushed, for revisits.
    path: Vec<Vector3<f64>>,
}

impl Robot {
    fn pose(&mut self) -> PoseInput {
        let index = self.path.len();
        self.path.push(self.position);
        let keyframe = match self.keyframe_every {
            0 => None,
            k if index.is_multiple_of(usize::from(k)) => {
                let id = self.next_keyframe;
                self.next_keyframe = self.next_keyframe.wrapping_add(1);
                Some(id)
            }
            _ => None,
        };
        let orientation = self
            .heading
            .is_finite()
            .then(|| UnitQuaternion::from_euler_angles(0.0, 0.0, self.heading));
        PoseInput {
            t: self.t,
            position: self.position,
            orientation,
            keyframe,
        }
    }

    fn tick(&mut self) {
        if let Some(t) = &mut self.t {
            *t += self.dt;
        }
    }
}

/// The detector under test, with what it said so far.
struct Harness {
    detector: Detector,
    poll_every: usize,
    pushed: usize,
    accepted: usize,
    rejected: usize,
    events: Vec<CandidateEvent>,
}

impl Harness {
    fn push(&mut self, pose: &PoseInput) {
        match self.detector.push(pose) {
            Pushed::Accepted(i) => {
                assert_eq!(i, self.pushed, "accepted under another index");
                self.accepted += 1;
            }
            Pushed::Rejected(i, _) => {
                assert_eq!(i, self.pushed, "rejected under another index");
                self.rejected += 1;
            }
        }
        self.pushed += 1;
        if self.poll_every > 0 && self.pushed.is_multiple_of(self.poll_every) {
            self.poll();
        }
    }

    fn poll(&mut self) {
        self.events.extend(self.detector.poll());
    }
}

/// Runs the program into a detector, polling as it goes, then finishes it
/// and checks what came out.
pub fn run(input: Run) {
    let s = &input.settings;
    let mut config = OnlineConfig::default();
    if s.warmup != u8::MAX {
        config.warmup_min_poses = 8 + usize::from(s.warmup);
    }
    config.workers = if s.two_workers { 2 } else { 1 };
    config.proximity = !s.no_proximity;
    config.drift_probe = !s.no_drift_probe;
    let overflow = if s.merge_latest {
        Overflow::MergeLatest
    } else {
        Overflow::Block
    };
    let mut h = Harness {
        detector: Detector::new(config, overflow),
        poll_every: usize::from(s.poll_every),
        pushed: 0,
        accepted: 0,
        rejected: 0,
        events: Vec::new(),
    };
    let mut robot = Robot {
        position: Vector3::zeros(),
        heading: 0.0,
        t: None,
        dt: 0.1,
        keyframe_every: 0,
        next_keyframe: 0,
        path: Vec::new(),
    };
    for op in input.ops {
        let room = MAX_POSES - h.pushed;
        if room == 0 {
            break;
        }
        match op {
            Op::Drive {
                n,
                step,
                turn,
                climb,
            } => {
                let (step, turn, climb) = (step.get(), turn.get(), climb.get());
                for _ in 0..usize::from(n).min(room) {
                    robot.heading += turn;
                    let (sin, cos) = robot.heading.sin_cos();
                    robot.position += Vector3::new(step * cos, step * sin, climb);
                    robot.tick();
                    let pose = robot.pose();
                    h.push(&pose);
                }
            }
            Op::At { x, y, z } => {
                robot.position = Vector3::new(x.get(), y.get(), z.get());
                robot.tick();
                let pose = robot.pose();
                h.push(&pose);
            }
            Op::Stand { n, jitter } => {
                let jitter = jitter.get();
                let here = robot.position;
                for k in 0..usize::from(n).min(room) {
                    // A fixed pattern: what matters is its size, not chance.
                    let phase = k as f64 * 2.399_963;
                    robot.position = here + jitter * Vector3::new(phase.cos(), phase.sin(), 0.0);
                    robot.tick();
                    let pose = robot.pose();
                    h.push(&pose);
                }
                robot.position = here;
            }
            Op::Repeat { n } => {
                for _ in 0..usize::from(n).min(room) {
                    let pose = robot.pose();
                    h.push(&pose);
                }
            }
            Op::Revisit {
                from,
                n,
                dx,
                dy,
                backwards,
            } => {
                let len = robot.path.len();
                if len == 0 {
                    continue;
                }
                let from = usize::from(from) % len;
                let n = usize::from(n).min(room);
                let shift = Vector3::new(dx.get(), dy.get(), 0.0);
                let stretch: Vec<Vector3<f64>> = if backwards {
                    robot.path[..=from].iter().rev().take(n).copied().collect()
                } else {
                    robot.path[from..].iter().take(n).copied().collect()
                };
                for p in stretch {
                    robot.position = p + shift;
                    robot.tick();
                    let pose = robot.pose();
                    h.push(&pose);
                }
            }
            Op::Clock(Clock::Start { start, dt }) => {
                robot.t = Some(start.get());
                robot.dt = dt.get();
            }
            Op::Clock(Clock::Step(dt)) => robot.dt = dt.get(),
            Op::Clock(Clock::Back(by)) => {
                if let Some(t) = &mut robot.t {
                    *t -= by.get();
                }
            }
            Op::Clock(Clock::Off) => robot.t = None,
            Op::Keyframes { every, first } => {
                robot.keyframe_every = every;
                robot.next_keyframe = first;
            }
            Op::Poll => h.poll(),
        }
    }
    h.poll();
    let Harness {
        detector,
        pushed,
        accepted,
        rejected,
        mut events,
        ..
    } = h;
    let (last, summary) = detector.finish();
    events.extend(last);

    assert_eq!(summary.poses as usize, pushed, "poses pushed");
    assert_eq!(summary.accepted as usize, accepted, "poses accepted");
    let g = summary.guards;
    assert_eq!(
        (g.non_finite + g.out_of_order + g.duplicate) as usize,
        rejected,
        "poses rejected"
    );
    assert_eq!(summary.workers_lost, 0, "the worker was lost");
    assert_eq!(
        summary.worker.candidates as usize,
        events.len(),
        "candidates settled but not delivered"
    );
    for (k, e) in events.iter().enumerate() {
        check_event(k, e, pushed);
    }
}

/// A candidate refers to poses that were pushed, in order, and carries a
/// finite similarity and a score in [0, 1].
fn check_event(k: usize, e: &CandidateEvent, pushed: usize) {
    assert_eq!(e.id, k as u64 + 1, "candidate ids are not 1, 2, ...");
    assert!(e.at_pose < pushed, "at_pose {} of {pushed}", e.at_pose);
    let h = &e.hypothesis;
    for (name, r) in [("query", h.a_range), ("match", h.b_range)] {
        assert!(
            r[0] <= r[1] && r[1] < pushed,
            "{name} range {r:?} of {pushed} poses"
        );
    }
    assert!(
        (0.0..=1.0).contains(&h.score),
        "score {} outside [0, 1]",
        h.score
    );
    assert!(
        h.scale.is_finite() && h.scale > 0.0,
        "scale {} is not a finite positive number",
        h.scale
    );
    assert!(
        h.rotation
            .iter()
            .chain(h.translation.iter())
            .all(|v| v.is_finite()),
        "a non-finite similarity: {h:?}"
    );
}
