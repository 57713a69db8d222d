//! The detector's side of the verifier link: publishes keyframes, sends
//! candidates, and turns verdicts, silence and restarts into one [`Outcome`]
//! per candidate.
//!
//! Every submitted candidate ends exactly once as [`Outcome::Confirmed`],
//! [`Outcome::Rejected`] or [`Outcome::Expired`]. Expiry covers what the
//! verifier cannot answer for: its deadline passed (`timeout`), no verifier
//! was ever heard (`verifier absent`), its heartbeats stopped (`verifier gone`,
//! e.g. after `kill -9`) or a new verifier instance took over (`verifier
//! restarted`: the old one's queue died with it).
//!
//! Liveness comes from the verifier's status heartbeats: a verifier is alive
//! while its last heartbeat is younger than [`ClientConfig::liveness_timeout`].
//! The client never blocks longer than asked and needs no verifier at all.
//!
//! Verdicts wait in a queue of [`VERDICT_QUEUE`](super::services::VERDICT_QUEUE);
//! a caller that lets more pile up between polls loses the oldest, and those
//! candidates end as `timeout`.

use std::collections::{HashMap, VecDeque};
use std::fmt;
use std::hash::{BuildHasher, Hasher};
use std::mem::MaybeUninit;
use std::time::{Duration, Instant};

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::sample_mut_uninit::SampleMutUninit;
use nalgebra::{Matrix3, Vector3};

use super::payload::{
    matrix_to_rows, pixel_format, status, CameraParams, CandidateMsg, KeyframeHeader, VerdictMsg,
    VerifierStatus, IPC_VERSION,
};
use super::services::{self, ServiceNames};
use super::IpcError;

/// Thread-safe flavour, so the client can live in a detector worker thread.
type S = ipc_threadsafe::Service;

/// Settings of a [`VerifierClient`].
#[derive(Debug, Clone)]
pub struct ClientConfig {
    /// Service prefix shared with the verifier (`--prefix`).
    pub prefix: String,
    /// A candidate without a verdict after this long expires with `timeout`.
    pub timeout: Duration,
    /// The verifier counts as gone when no heartbeat came for this long.
    pub liveness_timeout: Duration,
    /// Image bytes the keyframe publisher preallocates per sample; larger
    /// images grow the shared segment (powers of two).
    pub max_image_bytes: usize,
}

impl ClientConfig {
    /// Defaults: 2 s candidate timeout, 500 ms liveness, 1 MiB images.
    pub fn new(prefix: impl Into<String>) -> Self {
        Self {
            prefix: prefix.into(),
            timeout: Duration::from_secs(2),
            liveness_timeout: Duration::from_millis(500),
            max_image_bytes: 1 << 20,
        }
    }
}

/// A loop-closure candidate as the detector knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Keyframe on the query side (the newer place).
    pub query_keyframe: u64,
    /// Keyframe on the match side.
    pub match_keyframe: u64,
    /// Pose index of the query keyframe.
    pub query_pose: u64,
    /// Pose index of the match keyframe.
    pub match_pose: u64,
    /// Shape similarity `p_match = scale * rotation * p_query + translation`: scale.
    pub scale: f64,
    /// Shape similarity: rotation.
    pub rotation: Matrix3<f64>,
    /// Shape similarity: translation.
    pub translation: Vector3<f64>,
    /// Shape score (higher is better).
    pub score: f64,
}

impl Candidate {
    /// A candidate between two keyframes with an identity similarity hint.
    pub fn between(query_keyframe: u64, match_keyframe: u64) -> Self {
        Self {
            query_keyframe,
            match_keyframe,
            query_pose: 0,
            match_pose: 0,
            scale: 1.0,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            score: 0.0,
        }
    }

    /// The detector's candidate as the verifier takes it
    /// (`p_match = s R p_query + t`, the inverse of the hypothesis, which
    /// maps match points onto the query part). `None` without keyframes.
    #[allow(non_snake_case)]
    pub fn from_event(event: &turnprint::online::CandidateEvent) -> Option<Self> {
        let k = event.keyframes?;
        let h = &event.hypothesis;
        let inv_scale = 1.0 / h.scale;
        let match_R_query = h.rotation.transpose();
        Some(Self {
            query_keyframe: k.query_keyframe,
            match_keyframe: k.match_keyframe,
            query_pose: k.query_pose as u64,
            match_pose: k.match_pose as u64,
            scale: inv_scale,
            rotation: match_R_query,
            translation: -(match_R_query * h.translation) * inv_scale,
            score: h.score,
        })
    }

    fn to_msg(self, candidate_id: u64) -> CandidateMsg {
        CandidateMsg {
            version: IPC_VERSION,
            _pad: 0,
            candidate_id,
            query_keyframe: self.query_keyframe,
            match_keyframe: self.match_keyframe,
            query_pose: self.query_pose,
            match_pose: self.match_pose,
            scale: self.scale,
            rotation: matrix_to_rows(&self.rotation),
            translation: [self.translation.x, self.translation.y, self.translation.z],
            score: self.score,
        }
    }
}

/// Why a candidate ended without a verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExpiryReason {
    /// No verdict before the deadline although the verifier was alive.
    Timeout,
    /// No verifier was heard when the candidate was sent.
    VerifierAbsent,
    /// The verifier's heartbeats stopped (crash, `kill -9`, hang).
    VerifierGone,
    /// A new verifier instance appeared; the old one's work is lost.
    VerifierRestarted,
    /// The candidate could not be written to shared memory.
    SendFailed,
}

impl fmt::Display for ExpiryReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ExpiryReason::Timeout => "timeout",
            ExpiryReason::VerifierAbsent => "verifier absent",
            ExpiryReason::VerifierGone => "verifier gone",
            ExpiryReason::VerifierRestarted => "verifier restarted",
            ExpiryReason::SendFailed => "send failed",
        })
    }
}

/// How one candidate ended.
#[derive(Debug, Clone, PartialEq)]
#[allow(non_snake_case)]
pub enum Outcome {
    /// The images confirm the candidate: a loop-closure constraint.
    Confirmed {
        /// Id returned by [`VerifierClient::submit`].
        id: u64,
        /// The candidate as submitted (keyframes, poses, hint, score).
        candidate: Candidate,
        /// Rotation mapping query-camera bearings into the match camera.
        match_R_query: Matrix3<f64>,
        /// The query camera's centre seen from the match camera, unit length
        /// (zero for a pure rotation).
        match_t_query: Vector3<f64>,
        /// Inliers supporting the pose.
        inliers: u32,
        /// Verifier instance that decided.
        instance: u64,
    },
    /// The images do not support the candidate.
    Rejected {
        /// Id returned by [`VerifierClient::submit`].
        id: u64,
        /// The candidate as submitted.
        candidate: Candidate,
        /// Reason code (see [`crate::payload::reason`]).
        reason_code: u32,
        /// Reason text.
        reason: String,
        /// Inliers found (below the threshold).
        inliers: u32,
    },
    /// The candidate got no verdict.
    Expired {
        /// Id returned by [`VerifierClient::submit`].
        id: u64,
        /// The candidate as submitted.
        candidate: Candidate,
        /// Why it expired.
        reason: ExpiryReason,
    },
}

impl Outcome {
    /// The candidate id this outcome ends.
    pub fn id(&self) -> u64 {
        match self {
            Outcome::Confirmed { id, .. }
            | Outcome::Rejected { id, .. }
            | Outcome::Expired { id, .. } => *id,
        }
    }

    /// The candidate this outcome ends.
    pub fn candidate(&self) -> &Candidate {
        match self {
            Outcome::Confirmed { candidate, .. }
            | Outcome::Rejected { candidate, .. }
            | Outcome::Expired { candidate, .. } => candidate,
        }
    }
}

/// Counters of a client's traffic.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClientStats {
    /// Keyframes handed to shared memory.
    pub keyframes_sent: u64,
    /// Keyframes that could not be sent (no free sample, bad size).
    pub keyframes_failed: u64,
    /// Candidates submitted.
    pub submitted: u64,
    /// Candidates confirmed.
    pub confirmed: u64,
    /// Candidates rejected.
    pub rejected: u64,
    /// Candidates expired.
    pub expired: u64,
    /// Verdicts that came after their candidate had expired.
    pub late_verdicts: u64,
    /// Messages of another layout version, dropped.
    pub bad_messages: u64,
}

/// What the client knows about the verifier.
#[derive(Debug, Clone, Copy)]
enum Liveness {
    /// Nothing heard yet; candidates wait for the first heartbeat.
    Unknown { since: Instant },
    /// Heartbeats arrive from this instance.
    Alive { instance: u64, last_seen: Instant },
    /// No verifier: candidates expire at once.
    Absent,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    candidate: Candidate,
    deadline: Instant,
    /// Verifier instance believed alive at submission, 0 if none yet.
    instance: u64,
}

/// The detector's connection to the verifier sidecar (see the module docs).
pub struct VerifierClient {
    node: Node<S>,
    keyframe_pub: Publisher<S, [u8], KeyframeHeader>,
    candidate_pub: Publisher<S, CandidateMsg, ()>,
    verdict_sub: Subscriber<S, VerdictMsg, ()>,
    status_sub: Subscriber<S, VerifierStatus, ()>,
    notifier: Notifier<S>,
    listener: Listener<S>,
    config: ClientConfig,
    tag: u64,
    counter: u32,
    keyframe_seq: u64,
    /// Verifier instance heard at the last keyframe, and the first keyframe
    /// `seq` sent while hearing it.
    keyframe_epoch: (u64, u64),
    pending: HashMap<u64, Pending>,
    ready: VecDeque<Outcome>,
    liveness: Liveness,
    last_status: Option<VerifierStatus>,
    stats: ClientStats,
}

/// A random non-zero 64-bit value (process, time and std's random keys).
pub(crate) fn random_u64() -> u64 {
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0),
    );
    h.finish().max(1)
}

fn err(what: &str, e: impl fmt::Debug) -> IpcError {
    IpcError(format!("{what}: {e:?}"))
}

impl VerifierClient {
    /// Opens (or creates) the services under `config.prefix`. Succeeds with
    /// or without a running verifier.
    pub fn new(config: ClientConfig) -> Result<Self, IpcError> {
        let names = ServiceNames::new(&config.prefix)?;
        // The host process owns its signals: a client never swallows SIGINT.
        let node = NodeBuilder::new()
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<S>()
            .map_err(|e| err("node", e))?;
        let keyframe_pub = services::keyframes(&node, &names)?
            .publisher_builder()
            .initial_max_slice_len(config.max_image_bytes)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| err("keyframe publisher", e))?;
        let candidate_pub = services::candidates(&node, &names)?
            .publisher_builder()
            .create()
            .map_err(|e| err("candidate publisher", e))?;
        let verdict_sub = services::verdicts(&node, &names)?
            .subscriber_builder()
            .buffer_size(services::VERDICT_QUEUE)
            .create()
            .map_err(|e| err("verdict subscriber", e))?;
        let status_sub = services::status(&node, &names)?
            .subscriber_builder()
            .buffer_size(services::STATUS_QUEUE)
            .create()
            .map_err(|e| err("status subscriber", e))?;
        let notifier = services::event(&node, &names.to_verifier)?
            .notifier_builder()
            .create()
            .map_err(|e| err("notifier", e))?;
        let listener = services::event(&node, &names.to_client)?
            .listener_builder()
            .create()
            .map_err(|e| err("listener", e))?;
        Ok(Self {
            node,
            keyframe_pub,
            candidate_pub,
            verdict_sub,
            status_sub,
            notifier,
            listener,
            config,
            tag: random_u64() << 32,
            counter: 0,
            keyframe_seq: 0,
            keyframe_epoch: (0, 0),
            pending: HashMap::new(),
            ready: VecDeque::new(),
            liveness: Liveness::Unknown {
                since: Instant::now(),
            },
            last_status: None,
            stats: ClientStats::default(),
        })
    }

    /// Publishes a GRAY8 keyframe: `image` is `height` rows of
    /// `image.len() / height` bytes, copied once into the loaned shared-memory
    /// sample that the verifier then reads in place.
    pub fn publish_keyframe(
        &mut self,
        keyframe_id: u64,
        timestamp: f64,
        camera: &CameraParams,
        image: &[u8],
    ) -> Result<(), IpcError> {
        let height = camera.height as usize;
        if height == 0
            || !image.len().is_multiple_of(height)
            || image.len() / height < camera.width as usize
        {
            self.stats.keyframes_failed += 1;
            return Err(IpcError(format!(
                "keyframe {keyframe_id}: {} bytes do not make {} rows of at least {} pixels",
                image.len(),
                camera.height,
                camera.width
            )));
        }
        let stride = (image.len() / height) as u32;
        self.send_keyframe(keyframe_id, timestamp, camera, stride, |sample| {
            sample.write_from_slice(image)
        })
    }

    /// Publishes a GRAY8 keyframe that `fill` renders straight into shared
    /// memory (`stride * height` bytes, zeroed first): no copy at all.
    pub fn publish_keyframe_with(
        &mut self,
        keyframe_id: u64,
        timestamp: f64,
        camera: &CameraParams,
        stride: u32,
        fill: impl FnOnce(&mut [u8]),
    ) -> Result<(), IpcError> {
        if stride < camera.width {
            self.stats.keyframes_failed += 1;
            return Err(IpcError(format!(
                "keyframe {keyframe_id}: stride {stride} below width {}",
                camera.width
            )));
        }
        self.send_keyframe(keyframe_id, timestamp, camera, stride, |sample| {
            let mut sample = sample.write_from_fn(|_| 0u8);
            fill(sample.payload_mut());
            sample
        })
    }

    /// Loans `stride * height` bytes, lets `write` initialise them, sends.
    fn send_keyframe(
        &mut self,
        keyframe_id: u64,
        timestamp: f64,
        camera: &CameraParams,
        stride: u32,
        write: impl FnOnce(
            SampleMutUninit<S, [MaybeUninit<u8>], KeyframeHeader>,
        ) -> SampleMut<S, [u8], KeyframeHeader>,
    ) -> Result<(), IpcError> {
        let len = stride as usize * camera.height as usize;
        let mut sample = match self.keyframe_pub.loan_slice_uninit(len) {
            Ok(s) => s,
            Err(e) => {
                self.stats.keyframes_failed += 1;
                return Err(err(&format!("keyframe {keyframe_id}: loan"), e));
            }
        };
        self.keyframe_seq += 1;
        let heard = self.verifier_instance().unwrap_or(0);
        if heard != self.keyframe_epoch.0 {
            self.keyframe_epoch = (heard, self.keyframe_seq);
        }
        *sample.user_header_mut() = KeyframeHeader {
            version: IPC_VERSION,
            pixel_format: pixel_format::GRAY8,
            keyframe_id,
            seq: self.keyframe_seq,
            verifier_instance: heard,
            instance_first_seq: self.keyframe_epoch.1,
            timestamp,
            camera: *camera,
            width: camera.width,
            height: camera.height,
            stride,
            _pad: 0,
        };
        if let Err(e) = write(sample).send() {
            self.stats.keyframes_failed += 1;
            return Err(err(&format!("keyframe {keyframe_id}: send"), e));
        }
        self.stats.keyframes_sent += 1;
        // A missing verifier is not an error: nobody to wake.
        let _ = self.notifier.notify();
        Ok(())
    }

    /// Sends a candidate to the verifier and returns its id; its outcome comes
    /// from [`poll`](Self::poll) or [`wait`](Self::wait), exactly once.
    pub fn submit(&mut self, candidate: Candidate) -> u64 {
        let now = Instant::now();
        self.refresh(now);
        self.counter = self.counter.wrapping_add(1);
        let id = self.tag | self.counter as u64;
        self.stats.submitted += 1;
        let instance = match self.liveness {
            Liveness::Absent => {
                self.expire_now(id, candidate, ExpiryReason::VerifierAbsent);
                return id;
            }
            Liveness::Unknown { .. } => 0,
            Liveness::Alive { instance, .. } => instance,
        };
        let sent = self
            .candidate_pub
            .loan_uninit()
            .map_err(|e| err("loan", e))
            .and_then(|s| {
                s.write_payload(candidate.to_msg(id))
                    .send()
                    .map_err(|e| err("send", e))
            });
        if sent.is_err() {
            self.expire_now(id, candidate, ExpiryReason::SendFailed);
            return id;
        }
        let _ = self.notifier.notify();
        self.pending.insert(
            id,
            Pending {
                candidate,
                deadline: now + self.config.timeout,
                instance,
            },
        );
        id
    }

    /// Outcomes decided since the last call; never blocks.
    pub fn poll(&mut self) -> Vec<Outcome> {
        // Consume wake-ups so a later `wait` blocks until something new.
        let _ = self.listener.try_wait(|_| {});
        self.refresh(Instant::now());
        self.ready.drain(..).collect()
    }

    /// Outcomes, waiting up to `timeout` for at least one; returns early as
    /// soon as there is one, and never later than `timeout`.
    pub fn wait(&mut self, timeout: Duration) -> Vec<Outcome> {
        let end = Instant::now() + timeout;
        loop {
            let out = self.poll();
            let now = Instant::now();
            if !out.is_empty() || now >= end {
                return out;
            }
            let wake = self.next_deadline().map_or(end, |d| d.min(end));
            let nap = wake
                .saturating_duration_since(now)
                .max(Duration::from_micros(50));
            let _ = self.listener.timed_wait(|_| {}, nap.min(end - now));
        }
    }

    /// Waits up to `timeout` until a verifier's heartbeat is heard; true if so.
    pub fn wait_for_verifier(&mut self, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        loop {
            let _ = self.listener.try_wait(|_| {});
            let now = Instant::now();
            self.refresh(now);
            if let Liveness::Alive { .. } = self.liveness {
                return true;
            }
            if now >= end {
                return false;
            }
            let _ = self.listener.timed_wait(|_| {}, end - now);
        }
    }

    /// The instance id of the verifier currently heard, if any.
    pub fn verifier_instance(&self) -> Option<u64> {
        match self.liveness {
            Liveness::Alive { instance, .. } => Some(instance),
            _ => None,
        }
    }

    /// The newest status (statistics) message of the verifier.
    pub fn verifier_status(&self) -> Option<&VerifierStatus> {
        self.last_status.as_ref()
    }

    /// Candidates still waiting for an outcome (not counting ones decided but
    /// not yet returned by `poll`).
    pub fn outstanding(&self) -> usize {
        self.pending.len()
    }

    /// Traffic counters of this client.
    pub fn stats(&self) -> &ClientStats {
        &self.stats
    }

    /// The settings this client runs with.
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// The earliest moment something may expire without a message arriving.
    fn next_deadline(&self) -> Option<Instant> {
        let liveness = match self.liveness {
            Liveness::Unknown { since } => Some(since + self.config.liveness_timeout),
            Liveness::Alive { last_seen, .. } => Some(last_seen + self.config.liveness_timeout),
            Liveness::Absent => None,
        };
        let candidates = self.pending.values().map(|p| p.deadline).min();
        match (liveness, candidates) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn expire_now(&mut self, id: u64, candidate: Candidate, reason: ExpiryReason) {
        self.stats.expired += 1;
        self.ready.push_back(Outcome::Expired {
            id,
            candidate,
            reason,
        });
    }

    /// Expires every pending candidate for which `which` holds.
    fn expire_where(&mut self, reason: ExpiryReason, which: impl Fn(&Pending) -> bool) {
        let mut ids: Vec<u64> = self
            .pending
            .iter()
            .filter(|(_, p)| which(p))
            .map(|(&id, _)| id)
            .collect();
        ids.sort_unstable();
        for id in ids {
            if let Some(p) = self.pending.remove(&id) {
                self.expire_now(id, p.candidate, reason);
            }
        }
    }

    /// Reads verdicts and heartbeats, then applies liveness and deadlines.
    fn refresh(&mut self, now: Instant) {
        // Verdicts first: an answer that arrived counts even if its verifier
        // has since been replaced.
        while let Ok(Some(sample)) = self.verdict_sub.receive() {
            let v = *sample.payload();
            drop(sample);
            self.apply_verdict(&v);
        }
        let mut newest = None;
        while let Ok(Some(sample)) = self.status_sub.receive() {
            let s = *sample.payload();
            if s.version != IPC_VERSION {
                self.stats.bad_messages += 1;
                continue;
            }
            newest = Some(s);
        }
        if let Some(s) = newest {
            self.apply_heartbeat(&s, now);
        }
        match self.liveness {
            Liveness::Alive { last_seen, .. }
                if now.duration_since(last_seen) > self.config.liveness_timeout =>
            {
                self.expire_where(ExpiryReason::VerifierGone, |_| true);
                self.liveness = Liveness::Absent;
                // Frees what a killed verifier held in our services, so its
                // successor starts clean.
                let _ = self.node.try_cleanup_dead_nodes();
            }
            Liveness::Unknown { since }
                if now.duration_since(since) > self.config.liveness_timeout =>
            {
                self.expire_where(ExpiryReason::VerifierAbsent, |_| true);
                self.liveness = Liveness::Absent;
            }
            _ => {}
        }
        self.expire_where(ExpiryReason::Timeout, |p| p.deadline <= now);
    }

    fn apply_verdict(&mut self, v: &VerdictMsg) {
        if v.version != IPC_VERSION {
            self.stats.bad_messages += 1;
            return;
        }
        let Some(p) = self.pending.remove(&v.candidate_id) else {
            // Another client's candidate, or one that already expired.
            if v.candidate_id & !0xffff_ffff == self.tag {
                self.stats.late_verdicts += 1;
            }
            return;
        };
        let outcome = if v.status == status::CONFIRMED {
            self.stats.confirmed += 1;
            Outcome::Confirmed {
                id: v.candidate_id,
                candidate: p.candidate,
                match_R_query: v.rotation_matrix(),
                match_t_query: Vector3::from(v.translation),
                inliers: v.inliers,
                instance: v.instance,
            }
        } else {
            self.stats.rejected += 1;
            Outcome::Rejected {
                id: v.candidate_id,
                candidate: p.candidate,
                reason_code: v.reason_code,
                reason: v.reason_text(),
                inliers: v.inliers,
            }
        };
        self.ready.push_back(outcome);
    }

    fn apply_heartbeat(&mut self, s: &VerifierStatus, now: Instant) {
        self.last_status = Some(*s);
        match self.liveness {
            Liveness::Alive { instance, .. } if instance != s.instance => {
                self.expire_where(ExpiryReason::VerifierRestarted, |p| p.instance == instance);
            }
            Liveness::Unknown { .. } => {
                // Candidates sent before the first heartbeat belong to it.
                for p in self.pending.values_mut() {
                    p.instance = s.instance;
                }
            }
            _ => {}
        }
        self.liveness = Liveness::Alive {
            instance: s.instance,
            last_seen: now,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_send<T: Send>() {}

    #[test]
    fn client_can_move_to_a_worker_thread() {
        assert_send::<VerifierClient>();
    }

    #[test]
    fn expiry_reasons_read_as_documented() {
        assert_eq!(ExpiryReason::VerifierGone.to_string(), "verifier gone");
        assert_eq!(
            ExpiryReason::VerifierRestarted.to_string(),
            "verifier restarted"
        );
        assert_eq!(ExpiryReason::VerifierAbsent.to_string(), "verifier absent");
        assert_eq!(ExpiryReason::Timeout.to_string(), "timeout");
    }
}

#[cfg(test)]
mod from_event_tests {
    use super::Candidate;
    use nalgebra::{Rotation3, Vector3};
    use turnprint::online::events::KeyframePair;
    use turnprint::online::{CandidateEvent, Source};
    use turnprint::Hypothesis;

    /// The hint handed to the verifier is the inverse of the hypothesis:
    /// it maps the query keyframe's position onto the match keyframe's.
    #[test]
    fn from_event_inverts_the_hypothesis() {
        let rotation = *Rotation3::from_euler_angles(0.1, -0.2, 0.7).matrix();
        let (scale, translation) = (2.5, Vector3::new(3.0, -1.0, 4.0));
        let p_match = Vector3::new(10.0, 5.0, -2.0);
        let p_query = scale * (rotation * p_match) + translation;
        let hypothesis = Hypothesis {
            rank: 1,
            score: 0.9,
            zncc: 0.9,
            reversed: false,
            a_range: [100, 200],
            b_range: [0, 100],
            scale,
            rotation,
            translation,
            rmse: 0.0,
            turning: 1.0,
            length: 100.0,
            length_ratio: 1.0,
            correspondences: Vec::new(),
        };
        let pair = KeyframePair {
            query_keyframe: 7,
            query_pose: 150,
            match_keyframe: 3,
            match_pose: 50,
        };
        let event = CandidateEvent {
            id: 1,
            at_pose: 200,
            hypothesis,
            source: Source::Shape,
            keyframes: Some(pair),
            query_keyframes: vec![7],
            match_keyframes: vec![3],
        };
        let c = Candidate::from_event(&event).expect("keyframes given");
        assert_eq!((c.query_keyframe, c.match_keyframe), (7, 3));
        assert_eq!((c.query_pose, c.match_pose), (150, 50));
        let mapped = c.scale * (c.rotation * p_query) + c.translation;
        assert!((mapped - p_match).norm() < 1e-9, "{mapped} vs {p_match}");
        let no_keyframes = CandidateEvent {
            keyframes: None,
            ..event
        };
        assert!(Candidate::from_event(&no_keyframes).is_none());
    }
}
