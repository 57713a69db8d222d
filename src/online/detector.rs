//! The online detector: push one pose at a time, poll candidates.
//!
//! ```text
//! push(pose) ── guards ── frontend streams ── outbox ──(bounded queue)──▶ worker
//!    O(1) amortised, never waits (MergeLatest)             history, search, verify
//! poll() ◀────────────────────────── candidates ◀──────────────────────────┘
//! ```
//!
//! With [`OnlineConfig::workers`] above 1, the worker runs the matchings of
//! the hand-overs it finds queued on that many threads, over its one
//! history ([`super::worker`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use crossbeam::channel::{bounded, unbounded, Receiver, Sender, TrySendError};
use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

use super::events::CandidateEvent;
use super::frontend::{Frontend, Outbox, TrackParams};
use super::guard::{GuardCounts, Rejection, TimeGuard};
use super::search::Frame;
use super::worker::{spawn, Message, Overflow, Settle, WorkerState, WorkerStats};
use super::OnlineConfig;

/// Track samples past which a deferred outbox is sealed (see `send`): its
/// largest copy on the caller's thread is then about 50 kB.
const SEALED_CHUNK: usize = 1024;

/// Messages the queue holds at least with [`Overflow::Block`]. A replay
/// wants throughput, not fresh results: the caller runs ahead over the
/// cheap periodic probes, and the worker never waits for the next message.
/// With the live queue of 4 it did, 3-4 ms of KITTI 00's 35 ms stream
/// (KITTI 00 streamed 40 times with each, interleaved, three times over:
/// median 36.5 -> 33.5 ms). The candidates do not depend on it.
const REPLAY_QUEUE: usize = 64;

/// One pose as odometry delivers it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseInput {
    /// Timestamp (seconds), if any: must increase.
    pub t: Option<f64>,
    /// Position.
    pub position: Vector3<f64>,
    /// Orientation, if any (carried for the caller; the method uses positions).
    pub orientation: Option<UnitQuaternion<f64>>,
    /// Keyframe id of this pose, if it is one.
    pub keyframe: Option<u64>,
}

impl PoseInput {
    /// A pose with a position only.
    pub fn at(position: Vector3<f64>) -> Self {
        PoseInput {
            t: None,
            position,
            orientation: None,
            keyframe: None,
        }
    }
}

impl From<&crate::trajectory::Pose> for PoseInput {
    /// A read pose as odometry would deliver it (no keyframe).
    fn from(p: &crate::trajectory::Pose) -> Self {
        PoseInput {
            t: p.t,
            position: p.position,
            orientation: p.orientation,
            keyframe: None,
        }
    }
}

/// What happened to one pushed pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// Taken (its index).
    Accepted(usize),
    /// Dropped by a guard (its index and why).
    Rejected(usize, Rejection),
}

/// Counts and timing of a run.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Summary {
    /// Poses pushed.
    pub poses: u64,
    /// Poses accepted.
    pub accepted: u64,
    /// What the guards did.
    pub guards: GuardCounts,
    /// Messages handed to the worker.
    pub messages: u64,
    /// Sends deferred because the queue was full ([`Overflow::MergeLatest`]).
    pub deferred: u64,
    /// Sends that waited for a full queue to drain ([`Overflow::Block`]).
    pub waited: u64,
    /// What the worker did.
    pub worker: WorkerStats,
    /// 1 when the worker's thread stopped before the end (a panic): the
    /// samples handed over after it are dropped, and no candidate comes.
    /// The CLI reports it as an error.
    pub workers_lost: u64,
    /// Wall time from the first push to the end of `finish` (seconds).
    pub wall_s: f64,
    /// Time spent inside `push` on the caller's thread (seconds).
    pub push_s: f64,
}

/// The online loop-closure detector.
pub struct Detector {
    config: OnlineConfig,
    overflow: Overflow,
    guard: TimeGuard,
    front: Frontend,
    outbox: Outbox,
    /// Sealed outboxes of deferred hand-overs, oldest first.
    pending: Vec<Outbox>,
    poses: usize,
    summary: Summary,
    started: Option<Instant>,
    /// The worker, until it is lost.
    worker: Option<Link>,
    events: Receiver<CandidateEvent>,
    /// Candidates settled so far, counted where a lost worker leaves them.
    emitted: Arc<AtomicU64>,
    /// Outbox size (track samples) that triggers a hand-over without a new
    /// boundary: the periodic proximity probe.
    flush_samples: usize,
    /// A send was deferred since the last one went through.
    merging: bool,
    /// Where copies of the finalised samples go, when asked for
    /// ([`Detector::tap_finalised`]).
    tap: Option<Sender<Outbox>>,
    /// The drift correction's thread, when asked for.
    #[cfg(feature = "correct")]
    correction: Option<super::correction::Link>,
    /// The last accepted pose and the rejected poses before the first, so
    /// that the corrected path keeps one pose per pushed index.
    #[cfg(feature = "correct")]
    last_good: (Option<crate::Pose>, usize),
}

/// The caller's end of the worker.
struct Link {
    /// Its queue.
    tx: Sender<Message>,
    /// With [`Overflow::Block`], its word that its queue is half empty (see
    /// `send`).
    room: Receiver<()>,
    thread: std::thread::JoinHandle<WorkerStats>,
}

impl Link {
    /// Closes the queue and waits for the worker's figures (`None`: it was
    /// lost).
    fn join(self) -> Option<WorkerStats> {
        drop(self.tx);
        self.thread.join().ok()
    }
}

impl Detector {
    /// A detector with its worker thread.
    pub fn new(config: OnlineConfig, overflow: Overflow) -> Detector {
        let capacity = match overflow {
            Overflow::MergeLatest => config.queue_capacity,
            Overflow::Block => config.queue_capacity.max(REPLAY_QUEUE),
        };
        let (etx, events) = unbounded();
        let emitted = Arc::new(AtomicU64::new(0));
        let (wtx, wrx) = bounded(capacity.max(1));
        let (room_tx, room_rx) = bounded(1);
        let room_tx = (overflow == Overflow::Block).then_some(room_tx);
        let settle = Settle::new(&config, emitted.clone());
        let worker = Link {
            tx: wtx,
            room: room_rx,
            thread: spawn(WorkerState::new(config.clone()), wrx, etx, settle, room_tx),
        };
        let flush_samples = if config.proximity {
            config.probe_every.max(1)
        } else {
            4096
        };
        Detector {
            front: Frontend::Warmup(Vec::with_capacity(config.warmup_min_poses)),
            config,
            overflow,
            guard: TimeGuard::default(),
            outbox: Outbox::default(),
            pending: Vec::new(),
            poses: 0,
            summary: Summary::default(),
            started: None,
            worker: Some(worker),
            events,
            emitted,
            flush_samples,
            merging: false,
            tap: None,
            #[cfg(feature = "correct")]
            correction: None,
            #[cfg(feature = "correct")]
            last_good: (None, 0),
        }
    }

    /// Keeps a drift-corrected estimate of the path up to date on a thread
    /// of its own: each time loops arrive (the candidates at the shape cut,
    /// or only those handed to [`Detector::close_loop`]) the pose graph of
    /// [`crate::correct`] is solved again and a [`Correction`] event sent.
    ///
    /// [`Correction`]: super::correction::Correction
    #[cfg(feature = "correct")]
    pub fn with_correction(
        mut self,
        config: crate::correct::CorrectConfig,
        input: super::correction::LoopInput,
    ) -> Detector {
        self.correction = Some(super::correction::Link::spawn(config, input));
        self
    }

    /// A loop to enter the corrected estimate (a verifier's confirmed
    /// candidate); ignored without [`Detector::with_correction`].
    #[cfg(feature = "correct")]
    pub fn close_loop(&self, h: &crate::Hypothesis) {
        if let Some(c) = &self.correction {
            c.close_loop(h);
        }
    }

    /// The corrected pose of pushed pose `i` (see
    /// [`super::correction::Link::pose_at`]); `None` without correction or
    /// before pose `i` is pushed.
    #[cfg(feature = "correct")]
    pub fn corrected_pose(&self, i: usize) -> Option<crate::Pose> {
        self.correction.as_ref()?.pose_at(i)
    }

    /// Re-optimisations since the last call.
    #[cfg(feature = "correct")]
    pub fn poll_corrections(&self) -> Vec<super::correction::Correction> {
        self.correction
            .as_ref()
            .map(|c| c.poll())
            .unwrap_or_default()
    }

    /// The pose at push index `index` for the corrected path: the pose
    /// itself, or for one a guard dropped, the last good pose (a stop).
    #[cfg(feature = "correct")]
    fn record(&mut self, pose: &PoseInput, accepted: bool) {
        let Some(c) = &mut self.correction else {
            return;
        };
        if accepted {
            let p = crate::Pose {
                t: pose.t,
                position: pose.position,
                orientation: pose.orientation,
            };
            for _ in 0..=self.last_good.1 {
                c.pose(p.clone());
            }
            self.last_good = (Some(p), 0);
        } else if let Some(p) = &self.last_good.0 {
            c.pose(p.clone());
        } else {
            self.last_good.1 += 1;
        }
    }

    /// Starts with given track parameters instead of a warm-up (e.g. the
    /// batch path's, to compare both).
    pub fn with_params(config: OnlineConfig, overflow: Overflow, params: TrackParams) -> Detector {
        let mut d = Detector::new(config, overflow);
        let (mut counts, mut out) = (GuardCounts::default(), Outbox::default());
        d.front
            .start_with(params, &d.config, &mut counts, &mut out, Vec::new());
        d
    }

    /// Feeds one pose. Never waits with [`Overflow::MergeLatest`].
    pub fn push(&mut self, pose: &PoseInput) -> Pushed {
        let t0 = Instant::now();
        self.started.get_or_insert(t0);
        let index = self.poses;
        self.poses += 1;
        self.summary.poses += 1;
        let p = [pose.position.x, pose.position.y, pose.position.z];
        let result = match self.guard.check(pose.t, &p, &mut self.summary.guards) {
            Err(r) => {
                let g = &mut self.summary.guards;
                match r {
                    Rejection::NonFinite => g.non_finite += 1,
                    Rejection::OutOfOrder => g.out_of_order += 1,
                    Rejection::Duplicate => g.duplicate += 1,
                }
                #[cfg(feature = "correct")]
                self.record(pose, false);
                Pushed::Rejected(index, r)
            }
            Ok(()) => {
                #[cfg(feature = "correct")]
                self.record(pose, true);
                self.summary.accepted += 1;
                let before = self.outbox_lengths();
                if let Some(k) = pose.keyframe {
                    self.outbox.keyframes.push((index, k));
                }
                self.front.push(
                    index,
                    pose.position,
                    &self.config,
                    &mut self.summary.guards,
                    &mut self.outbox,
                );
                self.copy_to_tap(before);
                if !self.outbox.bounds.is_empty() || self.outbox.grid.len() >= self.flush_samples {
                    self.send();
                }
                Pushed::Accepted(index)
            }
        };
        self.summary.push_s += t0.elapsed().as_secs_f64();
        result
    }

    /// Sends a copy of every sample finalised from now on, as it is
    /// finalised, to the returned channel: the detector's history as its
    /// worker takes it in, for sharing it (a fleet's robots share their
    /// segments). The stream ends when the detector finishes.
    pub fn tap_finalised(&mut self) -> Receiver<Outbox> {
        let (tx, rx) = unbounded();
        self.tap = Some(tx);
        rx
    }

    /// Lengths of the outbox's parts (grid, signature, bounds, keyframes).
    fn outbox_lengths(&self) -> [usize; 4] {
        let o = &self.outbox;
        [o.grid.len(), o.sig.len(), o.bounds.len(), o.keyframes.len()]
    }

    /// Copies what the outbox gained since `before` to the tap, if any.
    fn copy_to_tap(&self, before: [usize; 4]) {
        let Some(tap) = &self.tap else {
            return;
        };
        let o = &self.outbox;
        let copy = Outbox {
            grid: o.grid[before[0]..].to_vec(),
            sig: o.sig[before[1]..].to_vec(),
            bounds: o.bounds[before[2]..].to_vec(),
            keyframes: o.keyframes[before[3]..].to_vec(),
        };
        if !copy.is_empty() {
            // A caller that dropped its end no longer wants the copies.
            let _ = tap.send(copy);
        }
    }

    fn frame(&self) -> Option<Frame> {
        let p = self.front.params()?;
        Some(Frame {
            plane: p.plane,
            step: p.grid_step,
            bandwidth: p.smoother.bandwidth,
            poses: self.poses,
        })
    }

    /// Hands the outbox to the worker (or keeps it, per the overflow
    /// policy).
    fn send(&mut self) {
        let Some(frame) = self.frame() else {
            return;
        };
        self.prune_lost();
        let Some(w) = &self.worker else {
            // The worker is lost: nothing would match the samples.
            self.outbox = Outbox::default();
            self.pending.clear();
            return;
        };
        let m = Message {
            earlier: std::mem::take(&mut self.pending),
            out: std::mem::take(&mut self.outbox),
            at_pose: self.poses - 1,
            frame,
            merged: self.merging,
        };
        let sent = match self.overflow {
            Overflow::Block => {
                // A full queue is waited out until it is half empty, not
                // one message at a time: waking the caller for every
                // message it takes cost the worker 1.8 % of KITTI 00's
                // stream, now 0.4 % (perf samples). The send after the
                // word still blocks, so a stale word costs one wake, never
                // a message (and a live detector's last hand-over, which
                // has no word to wait for, just blocks).
                match w.tx.try_send(m) {
                    Err(TrySendError::Full(m)) => {
                        self.summary.waited += 1;
                        let _ = w.room.recv();
                        w.tx.send(m).is_ok()
                    }
                    r => r.is_ok(),
                }
            }
            // Only this thread sends, so a queue with room keeps it until
            // the send.
            Overflow::MergeLatest if !w.tx.is_full() => w.tx.try_send(m).is_ok(),
            Overflow::MergeLatest => {
                self.summary.deferred += 1;
                self.merging = true;
                // While the worker lags the records pile up; grown in one
                // buffer, each doubling would copy all of them on the
                // caller's thread (pushes of 5-50 ms after minutes of
                // lag). Past SEALED_CHUNK samples the outbox is sealed and
                // a fresh one started: no copy exceeds that.
                let Message {
                    mut earlier, out, ..
                } = m;
                if out.grid.len() >= SEALED_CHUNK {
                    earlier.push(out);
                } else {
                    self.outbox = out;
                }
                self.pending = earlier;
                false
            }
        };
        if sent {
            self.summary.messages += 1;
            self.merging = false;
        }
    }

    /// Lets go of the worker if its thread has ended before its queue was
    /// closed (a panic), so that its full queue does not block the caller
    /// nor pile the samples up in the outbox for ever.
    fn prune_lost(&mut self) {
        if let Some(w) = self.worker.take_if(|w| w.thread.is_finished()) {
            w.join();
            self.summary.workers_lost += 1;
        }
    }

    /// 1 once the worker is lost (its thread panicked), as found at the
    /// last hand-over.
    pub fn workers_lost(&self) -> u64 {
        self.summary.workers_lost
    }

    /// Candidates that arrived since the last poll.
    pub fn poll(&self) -> Vec<CandidateEvent> {
        let events: Vec<CandidateEvent> = self.events.try_iter().collect();
        self.correct_with(&events);
        events
    }

    /// Hands candidates to the correction ([`hand_over`]).
    fn correct_with(&self, _events: &[CandidateEvent]) {
        #[cfg(feature = "correct")]
        if let Some(c) = &self.correction {
            hand_over(c, _events, self.config.min_score);
        }
    }

    /// The candidate channel itself (for `select!` or a blocking receive).
    pub fn events(&self) -> &Receiver<CandidateEvent> {
        &self.events
    }

    /// Poses pushed so far.
    pub fn poses(&self) -> usize {
        self.poses
    }

    /// Track parameters in use (after warm-up).
    pub fn params(&self) -> Option<TrackParams> {
        self.front.params().copied()
    }

    /// Ends the stream: finalises the last samples and segments, waits for
    /// the worker, and returns the remaining candidates and the summary.
    // Only the correction, a feature, is taken out of `self` here.
    #[cfg_attr(not(feature = "correct"), allow(unused_mut))]
    pub fn finish(mut self) -> (Vec<CandidateEvent>, Summary) {
        // A correction nobody will read ends with its thread's current solve.
        #[cfg(feature = "correct")]
        {
            self.correction = None;
        }
        self.drain()
    }

    /// [`Detector::finish`], and the correction's end: the path solved once
    /// more with every pose and loop, and the re-optimisations not yet
    /// polled (`None` without [`Detector::with_correction`]).
    #[cfg(feature = "correct")]
    pub fn finish_corrected(
        self,
    ) -> (
        Vec<CandidateEvent>,
        Summary,
        Option<super::correction::Finished>,
    ) {
        let (events, summary, link) = self.finish_keeping_correction();
        (events, summary, link.map(|l| l.finish()))
    }

    /// [`Detector::finish`], handing back the correction's thread still
    /// running, for loops confirmed after the stream ends (a verifier's
    /// late verdicts).
    #[cfg(feature = "correct")]
    pub fn finish_keeping_correction(
        mut self,
    ) -> (
        Vec<CandidateEvent>,
        Summary,
        Option<super::correction::Link>,
    ) {
        let correction = self.correction.take();
        let cut = self.config.min_score;
        let (events, summary) = self.drain();
        if let Some(c) = &correction {
            hand_over(c, &events, cut);
        }
        (events, summary, correction)
    }

    fn drain(mut self) -> (Vec<CandidateEvent>, Summary) {
        let mut counts = self.summary.guards;
        let before = self.outbox_lengths();
        if let super::frontend::Frontend::Warmup(_) = self.front {
            self.front
                .start(&self.config, &mut counts, &mut self.outbox);
        }
        if let super::frontend::Frontend::Running(s) = &mut self.front {
            s.flush(&mut counts, &mut self.outbox);
        }
        self.copy_to_tap(before);
        self.tap = None;
        self.summary.guards = counts;
        if !self.outbox.is_empty() || !self.pending.is_empty() {
            // The last hand-over always waits: nothing may be lost at the end.
            let overflow = self.overflow;
            self.overflow = Overflow::Block;
            self.send();
            self.overflow = overflow;
        }
        if let Some(w) = self.worker.take() {
            match w.join() {
                Some(stats) => self.summary.worker = stats,
                None => self.summary.workers_lost += 1,
            }
        }
        self.summary.worker.candidates = self.emitted.load(Ordering::Relaxed);
        if let Some(t0) = self.started {
            self.summary.wall_s = t0.elapsed().as_secs_f64();
        }
        (self.events.try_iter().collect(), self.summary)
    }
}

/// Hands candidates to a correction that takes them
/// ([`super::correction::LoopInput::Candidates`]): with no verifier to judge
/// the loops, only those at the shape cut ([`OnlineConfig::min_score`]).
/// The candidates emitted below it (the drifting-map probe's and the
/// network's from [`OnlineConfig::drift_min_score`], proximity ones from a
/// third of the cut, `gate::PROXIMITY_CUT_SHARE`) are there for a verifier
/// to judge; short and loosely fitted, in a graph they pull the path by
/// metres where the odometry was right (EuRoC VI-SLAM MH_04: an 18-pose
/// loop at scale 1.12, 0.17 -> 0.53 m).
#[cfg(feature = "correct")]
fn hand_over(c: &super::correction::Link, events: &[CandidateEvent], min_score: f64) {
    if c.input == super::correction::LoopInput::Candidates {
        for e in events.iter().filter(|e| e.hypothesis.score >= min_score) {
            c.close_loop(&e.hypothesis);
        }
    }
}

impl Drop for Detector {
    fn drop(&mut self) {
        if let Some(w) = self.worker.take() {
            w.join();
        }
    }
}
