//! The online detector's drift correction: a thread of its own keeps the
//! path so far and its loops, re-optimises the pose graph of
//! [`crate::correct`] whenever loops arrive, and publishes the corrected
//! path, so that neither the caller's thread nor the matching worker waits
//! for a solve.
//!
//! ```text
//! push(pose) ──▶ poses ─┐
//! loops (candidates,    ├──▶ correction thread: correct_again_from ──▶ snapshot
//!  or confirmed only) ──┘                                    └──▶ Correction events
//! ```
//!
//! Loops that arrive while a solve runs are taken together by the next one,
//! which starts from the correction before it. The last one, at the
//! stream's end, starts from scratch, so that a stream ends the same
//! however its re-optimisations fell.

// Frame names as in Sophus: `a_T_b` maps points from b to a.
#![allow(non_snake_case)]

use std::sync::{Arc, RwLock};
use std::time::Instant;

use crossbeam::channel::{unbounded, Receiver, Sender};

use crate::correct::{
    correct_again_from, correct_with_loops, Bias, CorrectConfig, Corrected, LoopClosure,
};
use crate::geometry::Similarity3;
use crate::trajectory::{Pose, Trajectory};
use crate::Hypothesis;

/// Which loops enter the graph.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopInput {
    /// The candidates the detector emits at its shape cut (the graph's own
    /// gate turns the wrong ones away; those below the cut wait for a
    /// verifier).
    Candidates,
    /// Only the loops the caller hands over with
    /// [`super::Detector::close_loop`] (a verifier's confirmed ones).
    Confirmed,
}

/// One re-optimisation, as the `corrected` event of `stream` reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct Correction {
    /// Poses in the graph (the path up to that pose).
    pub poses: usize,
    /// Loops in the graph.
    pub loops: usize,
    /// Loops kept.
    pub kept: usize,
    /// Largest move of a pose against the previous correction (path units).
    pub largest_move: f64,
    /// Seconds the solve took on the correction thread.
    pub seconds: f64,
    /// The drift the same all along taken out of the odometry, if any.
    pub bias: Option<Bias>,
}

impl Correction {
    /// The `corrected` event of `stream` (`last`: the solve over the whole
    /// path at the end).
    pub fn to_json(&self, last: bool) -> serde_json::Value {
        serde_json::json!({
            "event": "corrected",
            "poses": self.poses,
            "loops": self.loops,
            "kept": self.kept,
            "largest_move": self.largest_move,
            "seconds": self.seconds,
            "bias": self.bias.map(|b| b.to_json()),
            "final": last,
        })
    }
}

impl Finished {
    /// Writes the re-optimisations not yet written and the final one as
    /// `corrected` events to `out`, and the corrected path as TUM to
    /// `file`; `started` is when the end began (the final event's time).
    pub fn write(
        self,
        name: &str,
        file: &std::path::Path,
        started: Instant,
        out: &mut dyn std::io::Write,
    ) -> crate::Result<()> {
        let io = |source| crate::Error::Io {
            path: "<stdout>".into(),
            source,
        };
        for c in &self.events {
            writeln!(out, "{}", c.to_json(false)).map_err(io)?;
        }
        let c = self.corrected.ok_or_else(|| {
            crate::Error::input(name, "the path cannot be corrected (it never moves)")
        })?;
        let last = Correction {
            poses: c.poses.len(),
            loops: c.loops.len(),
            kept: c.kept(),
            largest_move: 0.0,
            seconds: started.elapsed().as_secs_f64(),
            bias: c.bias,
        };
        crate::io::write_tum(file, &c.trajectory(file.display().to_string()))?;
        writeln!(out, "{}", last.to_json(true)).map_err(io)
    }
}

/// The latest corrected path.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Corrected poses `0..poses.len()`.
    pub poses: Vec<Pose>,
    /// `corrected_T_odometry` of the last corrected pose: poses after the
    /// snapshot follow it.
    pub tail: Similarity3,
}

/// The end of a corrected stream.
#[derive(Debug, Clone)]
pub struct Finished {
    /// The path solved once more with every pose and loop, from scratch
    /// (`correct_with_loops`: the same whenever the re-optimisations before
    /// it ran); `None` when it cannot be corrected (it never moves) or the
    /// thread was lost.
    pub corrected: Option<Corrected>,
    /// Re-optimisations not yet polled.
    pub events: Vec<Correction>,
}

enum Input {
    Pose(Pose),
    Loop(Hypothesis),
    /// Solve with everything so far and hand the result back.
    Finish(Sender<Option<Corrected>>),
}

/// The caller's end of the correction thread.
pub struct Link {
    tx: Sender<Input>,
    /// Raw poses as pushed, for the poses after the latest snapshot.
    raw: Vec<Pose>,
    snapshot: Arc<RwLock<Option<Arc<Snapshot>>>>,
    events: Receiver<Correction>,
    /// Which loops enter.
    pub input: LoopInput,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Link {
    /// Starts the correction thread.
    pub fn spawn(config: CorrectConfig, input: LoopInput) -> Link {
        // The drift check's two or three more solves per kept loop do not
        // fit a re-optimisation's budget (BENCHMARKS.md: 50 ms at 10 000
        // poses).
        let config = CorrectConfig {
            check_drift: false,
            ..config
        };
        let (tx, rx) = unbounded();
        let (etx, events) = unbounded();
        let snapshot = Arc::new(RwLock::new(None));
        let shared = snapshot.clone();
        let thread = std::thread::Builder::new()
            .name("turnprint-correct".into())
            .spawn(move || run(config, rx, etx, shared))
            .ok();
        Link {
            tx,
            raw: Vec::new(),
            snapshot,
            events,
            input,
            thread,
        }
    }

    /// A pose the detector accepted (in order: its index is its place).
    pub fn pose(&mut self, pose: Pose) {
        self.raw.push(pose.clone());
        let _ = self.tx.send(Input::Pose(pose));
    }

    /// A loop to enter the graph: `a_range` the later pass.
    pub fn close_loop(&self, h: &Hypothesis) {
        let _ = self.tx.send(Input::Loop(h.clone()));
    }

    /// Re-optimisations since the last call.
    pub fn poll(&self) -> Vec<Correction> {
        self.events.try_iter().collect()
    }

    /// The corrected pose of accepted pose `i`: from the latest solve, or,
    /// for a pose after it, the raw pose moved as the last solved pose was.
    /// `None` for an index not pushed yet.
    pub fn pose_at(&self, i: usize) -> Option<Pose> {
        let raw = self.raw.get(i)?;
        let snap = self.snapshot.read().ok()?.clone();
        Some(match snap {
            Some(s) if i < s.poses.len() => s.poses[i].clone(),
            Some(s) => moved(raw, &s.tail),
            None => raw.clone(),
        })
    }

    /// Waits for a last solve over every pose and loop and ends the thread.
    pub fn finish(mut self) -> Finished {
        let (tx, rx) = crossbeam::channel::bounded(1);
        let _ = self.tx.send(Input::Finish(tx));
        let corrected = rx.recv().ok().flatten();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        Finished {
            corrected,
            events: self.events.try_iter().collect(),
        }
    }
}

fn moved(raw: &Pose, corrected_T_odometry: &Similarity3) -> Pose {
    let r = crate::geometry::nearest_rotation(&corrected_T_odometry.rotation);
    Pose {
        t: raw.t,
        position: corrected_T_odometry.apply(&raw.position),
        orientation: raw
            .orientation
            .map(|q| nalgebra::UnitQuaternion::from_rotation_matrix(&r) * q),
    }
}

/// The thread: gathers poses and loops, solves when loops came in since the
/// last solve, publishes.
fn run(
    config: CorrectConfig,
    rx: Receiver<Input>,
    events: Sender<Correction>,
    snapshot: Arc<RwLock<Option<Arc<Snapshot>>>>,
) {
    let mut path = Trajectory {
        source: "stream".into(),
        poses: Vec::new(),
    };
    let mut loops: Vec<LoopClosure> = Vec::new();
    // The hypotheses of `loops`: a loop's levelling is measured on the
    // path it was made of, and the end makes every loop again of the whole.
    let mut held: Vec<Hypothesis> = Vec::new();
    let mut fresh = false;
    let mut last: Option<Arc<Snapshot>> = None;
    let mut finish: Option<Sender<Option<Corrected>>> = None;
    let mut kept: Vec<bool> = Vec::new();
    // The last correction: the next solves start from it.
    let mut previous: Option<Corrected> = None;
    'outer: while let Ok(first) = rx.recv() {
        let mut pending = vec![first];
        pending.extend(rx.try_iter());
        let mut hypotheses = Vec::new();
        for input in pending {
            match input {
                Input::Pose(p) => path.poses.push(p),
                Input::Loop(h) => hypotheses.push(h),
                Input::Finish(tx) => {
                    finish = Some(tx);
                }
            }
        }
        for h in &hypotheses {
            // Ranges beyond the poses received cannot happen (a candidate
            // follows its poses), but a bad one is dropped, not obeyed.
            if let Ok(l) = LoopClosure::from_hypothesis(&path, h) {
                loops.push(l);
                held.push(h.clone());
                fresh = true;
            }
        }
        if let Some(tx) = finish.take() {
            // The end is the correction of every loop from scratch, each
            // made of the whole path, not from the last re-optimisation,
            // whose choice depends on which loops had arrived when it ran:
            // the same stream ends the same.
            let whole: Vec<LoopClosure> = held
                .iter()
                .filter_map(|h| LoopClosure::from_hypothesis(&path, h).ok())
                .collect();
            let result = correct_with_loops(&path, &whole, &config).ok();
            let _ = tx.send(result);
            break 'outer;
        }
        if !fresh {
            continue;
        }
        fresh = false;
        let t0 = Instant::now();
        let Ok(c) = correct_again_from(&path, &loops, &kept, previous.as_ref(), &config) else {
            continue;
        };
        kept = c.loops.iter().map(|l| l.kept).collect();
        let seconds = t0.elapsed().as_secs_f64();
        let largest_move = c
            .poses
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let before = match &last {
                    Some(s) if i < s.poses.len() => s.poses[i].position,
                    Some(s) => s.tail.apply(&path.poses[i].position),
                    None => path.poses[i].position,
                };
                (p.position - before).norm()
            })
            .fold(0.0, f64::max);
        let tail = match (c.poses.last(), path.poses.last()) {
            (Some(after), Some(before)) => correction_of(before, after),
            _ => Similarity3::identity(),
        };
        let snap = Arc::new(Snapshot {
            poses: c.poses.clone(),
            tail,
        });
        if let Ok(mut s) = snapshot.write() {
            *s = Some(snap.clone());
        }
        last = Some(snap);
        let _ = events.send(Correction {
            poses: path.len(),
            loops: loops.len(),
            kept: c.kept(),
            largest_move,
            seconds,
            bias: c.bias,
        });
        previous = Some(c);
    }
}

/// `corrected_T_odometry` that takes pose `before` to `after` (the
/// rotation from the orientations where both have one, else none).
fn correction_of(before: &Pose, after: &Pose) -> Similarity3 {
    let rotation = match (before.orientation, after.orientation) {
        (Some(b), Some(a)) => *(a * b.inverse()).to_rotation_matrix().matrix(),
        _ => nalgebra::Matrix3::identity(),
    };
    Similarity3 {
        scale: 1.0,
        rotation,
        translation: after.position - rotation * before.position,
    }
}
