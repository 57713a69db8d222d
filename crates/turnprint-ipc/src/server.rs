//! The verifier process's loop: takes keyframes and candidates from iceoryx2,
//! hands them to a [`FrameVerifier`] (the vision code) and sends verdicts back.
//!
//! The loop sleeps on a WaitSet attached to the `to_verifier` event and wakes
//! only when a client has sent something. A separate thread publishes the
//! status heartbeat (instance id and counters), so a long verification never
//! looks like a dead verifier.
//!
//! Bounds, and what happens at them:
//! * keyframe queue: [`KEYFRAME_QUEUE`] images in shared memory; a flood
//!   overwrites the oldest unread ones (iceoryx2 safe overflow). The loss is
//!   seen as a gap in the publisher's sequence numbers and counted in
//!   `keyframes_dropped_queue`.
//! * feature memory: after each keyframe the verifier's
//!   [`FrameVerifier::memory_bytes`] is brought back under the cap by
//!   [`FrameVerifier::evict_oldest`]; a verifier that neither evicts nor caps
//!   itself gets no new keyframes while over the cap
//!   (`keyframes_dropped_memory`). `OrbVerifier` caps itself (least recently
//!   used keyframes go first) at the same number.
//!
//! Keyframes are read before every candidate, so a candidate never overtakes
//! a keyframe it names that was sent before it.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use iceoryx2::identifiers::UniquePublisherId;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;

use super::client::random_u64;
use super::payload::{
    pixel_format, reason, CandidateMsg, KeyframeHeader, VerdictMsg, VerifierStatus, IPC_VERSION,
};
use super::services::{self, ServiceNames, KEYFRAME_QUEUE};
use super::IpcError;

type S = ipc::Service;

/// What the verifier process needs from the vision code.
pub trait FrameVerifier {
    /// Called when a keyframe arrives; keep features, not the image.
    fn add_keyframe(&mut self, header: &KeyframeHeader, image: &[u8]) -> Result<(), String>;
    /// Decide a candidate; return the verdict.
    fn verify(&mut self, candidate: &CandidateMsg) -> VerdictMsg;
    /// Bytes currently held (for the memory cap and reports).
    fn memory_bytes(&self) -> usize;
    /// Forgets the oldest keyframe to make room; false if nothing can go.
    fn evict_oldest(&mut self) -> bool {
        false
    }
    /// Keyframes the verifier evicted by itself (under a cap of its own)
    /// since the last call, so that the status counts every eviction.
    fn take_evicted(&mut self) -> u64 {
        0
    }
}

/// Settings of the verifier loop.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// Service prefix shared with the clients.
    pub prefix: String,
    /// Cap on [`FrameVerifier::memory_bytes`].
    pub max_memory_bytes: usize,
    /// Period of the status heartbeat.
    pub heartbeat_period: Duration,
    /// Period of the statistics line on stderr; `None` for none.
    pub report_period: Option<Duration>,
}

impl ServerConfig {
    /// Defaults: 512 MiB cap, 50 ms heartbeat, a stderr report every 10 s.
    pub fn new(prefix: impl Into<String>) -> Self {
        Self {
            prefix: prefix.into(),
            max_memory_bytes: 512 << 20,
            heartbeat_period: Duration::from_millis(50),
            report_period: Some(Duration::from_secs(10)),
        }
    }
}

/// Counters shared between the loop and the heartbeat thread.
#[derive(Debug, Default)]
struct Counters {
    keyframes_received: AtomicU64,
    keyframes_added: AtomicU64,
    keyframes_dropped_queue: AtomicU64,
    keyframes_dropped_memory: AtomicU64,
    keyframes_failed: AtomicU64,
    keyframes_evicted: AtomicU64,
    candidates_received: AtomicU64,
    verdicts_sent: AtomicU64,
    bad_messages: AtomicU64,
    memory_bytes: AtomicU64,
}

impl Counters {
    fn bump(c: &AtomicU64) {
        c.fetch_add(1, Ordering::Relaxed);
    }

    fn snapshot(&self, instance: u64, seq: u64, max_memory_bytes: usize) -> VerifierStatus {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        VerifierStatus {
            version: IPC_VERSION,
            _pad: 0,
            instance,
            seq,
            keyframes_received: g(&self.keyframes_received),
            keyframes_added: g(&self.keyframes_added),
            keyframes_dropped_queue: g(&self.keyframes_dropped_queue),
            keyframes_dropped_memory: g(&self.keyframes_dropped_memory),
            keyframes_failed: g(&self.keyframes_failed),
            keyframes_evicted: g(&self.keyframes_evicted),
            candidates_received: g(&self.candidates_received),
            verdicts_sent: g(&self.verdicts_sent),
            bad_messages: g(&self.bad_messages),
            memory_bytes: g(&self.memory_bytes),
            max_memory_bytes: max_memory_bytes as u64,
        }
    }
}

/// One line of statistics for stderr.
pub fn format_status(s: &VerifierStatus) -> String {
    format!(
        "keyframes: {} received, {} added, {} dropped (queue), {} dropped (memory), {} failed, \
         {} evicted; candidates: {} received, {} verdicts; memory {:.1}/{:.1} MiB; {} bad messages",
        s.keyframes_received,
        s.keyframes_added,
        s.keyframes_dropped_queue,
        s.keyframes_dropped_memory,
        s.keyframes_failed,
        s.keyframes_evicted,
        s.candidates_received,
        s.verdicts_sent,
        s.memory_bytes as f64 / (1 << 20) as f64,
        s.max_memory_bytes as f64 / (1 << 20) as f64,
        s.bad_messages
    )
}

fn err(what: &str, e: impl std::fmt::Debug) -> IpcError {
    IpcError(format!("{what}: {e:?}"))
}

/// The ports of the verifier loop.
struct Ports {
    keyframes: Subscriber<S, [u8], KeyframeHeader>,
    candidates: Subscriber<S, CandidateMsg, ()>,
    verdicts: Publisher<S, VerdictMsg, ()>,
    to_client: Notifier<S>,
}

/// The loop's state besides the verifier.
struct Loop<'a, V: FrameVerifier + ?Sized> {
    node: &'a Node<S>,
    verifier: &'a mut V,
    ports: Ports,
    counters: Arc<Counters>,
    instance: u64,
    max_memory_bytes: usize,
    /// Last keyframe sequence number per publisher, to count queue drops.
    last_seq: HashMap<UniquePublisherId, u64>,
}

impl<V: FrameVerifier + ?Sized> Loop<'_, V> {
    /// Handles everything queued: all keyframes before each candidate.
    /// Returns true when SIGINT/SIGTERM arrived meanwhile.
    fn drain(&mut self) -> Result<bool, IpcError> {
        let started = Instant::now();
        loop {
            // A zero wait only checks for a termination request, so a long
            // backlog does not delay shutdown; short drains skip the syscall.
            if started.elapsed() > Duration::from_millis(10)
                && self.node.wait(Duration::ZERO).is_err()
            {
                return Ok(true);
            }
            while let Some(sample) = self
                .ports
                .keyframes
                .receive()
                .map_err(|e| err("keyframes", e))?
            {
                let origin = sample.origin();
                self.keyframe(origin, sample.user_header(), sample.payload());
            }
            match self
                .ports
                .candidates
                .receive()
                .map_err(|e| err("candidates", e))?
            {
                Some(sample) => {
                    let c = *sample.payload();
                    drop(sample);
                    self.candidate(&c)?;
                }
                None => return Ok(false),
            }
        }
    }

    fn keyframe(&mut self, origin: UniquePublisherId, h: &KeyframeHeader, image: &[u8]) {
        let c = &self.counters;
        Counters::bump(&c.keyframes_received);
        if h.version != IPC_VERSION {
            Counters::bump(&c.bad_messages);
            return;
        }
        // Gaps count as drops only among keyframes sent after the publisher
        // heard this instance: earlier ones may predate our subscriber.
        let last = self.last_seq.insert(origin, h.seq);
        if h.verifier_instance == self.instance {
            let base = match last {
                Some(l) if l >= h.instance_first_seq => l,
                _ => h.instance_first_seq.saturating_sub(1),
            };
            if h.seq > base + 1 {
                c.keyframes_dropped_queue
                    .fetch_add(h.seq - base - 1, Ordering::Relaxed);
            }
        }
        let needed = h.stride as usize * h.height as usize;
        if h.pixel_format != pixel_format::GRAY8 || h.stride < h.width || image.len() < needed {
            Counters::bump(&c.keyframes_failed);
            eprintln!(
                "turnprint-verifier: keyframe {}: unusable image ({} bytes, {}x{} stride {}, format {})",
                h.keyframe_id,
                image.len(),
                h.width,
                h.height,
                h.stride,
                h.pixel_format
            );
            return;
        }
        let max = self.max_memory_bytes;
        while self.verifier.memory_bytes() > max && self.verifier.evict_oldest() {
            Counters::bump(&c.keyframes_evicted);
        }
        if self.verifier.memory_bytes() > max {
            Counters::bump(&c.keyframes_dropped_memory);
            return;
        }
        let verifier = &mut *self.verifier;
        match catch_unwind(AssertUnwindSafe(|| {
            verifier.add_keyframe(h, &image[..needed])
        })) {
            Ok(Ok(())) => Counters::bump(&c.keyframes_added),
            Ok(Err(e)) => {
                Counters::bump(&c.keyframes_failed);
                eprintln!("turnprint-verifier: keyframe {}: {e}", h.keyframe_id);
            }
            Err(_) => {
                Counters::bump(&c.keyframes_failed);
                eprintln!(
                    "turnprint-verifier: keyframe {}: vision code panicked",
                    h.keyframe_id
                );
            }
        }
        while self.verifier.memory_bytes() > max && self.verifier.evict_oldest() {
            Counters::bump(&c.keyframes_evicted);
        }
        c.keyframes_evicted
            .fetch_add(self.verifier.take_evicted(), Ordering::Relaxed);
        c.memory_bytes
            .store(self.verifier.memory_bytes() as u64, Ordering::Relaxed);
    }

    fn candidate(&mut self, cand: &CandidateMsg) -> Result<(), IpcError> {
        Counters::bump(&self.counters.candidates_received);
        let mut verdict = if cand.version != IPC_VERSION {
            Counters::bump(&self.counters.bad_messages);
            VerdictMsg::rejected(
                cand.candidate_id,
                reason::BAD_CANDIDATE,
                &format!("message version {} != {IPC_VERSION}", cand.version),
                0,
            )
        } else {
            let verifier = &mut *self.verifier;
            catch_unwind(AssertUnwindSafe(|| verifier.verify(cand))).unwrap_or_else(|_| {
                VerdictMsg::rejected(
                    cand.candidate_id,
                    reason::INTERNAL_ERROR,
                    "vision code panicked",
                    0,
                )
            })
        };
        self.send(&mut verdict, cand.candidate_id)
    }

    fn send(&mut self, verdict: &mut VerdictMsg, candidate_id: u64) -> Result<(), IpcError> {
        verdict.version = IPC_VERSION;
        verdict.candidate_id = candidate_id;
        verdict.instance = self.instance;
        let sample = self
            .ports
            .verdicts
            .loan_uninit()
            .map_err(|e| err("verdict loan", e))?;
        sample
            .write_payload(*verdict)
            .send()
            .map_err(|e| err("verdict send", e))?;
        Counters::bump(&self.counters.verdicts_sent);
        let _ = self.ports.to_client.notify();
        Ok(())
    }

    /// Answers every queued candidate with "shutting down" before exit, so
    /// clients learn their fate now rather than at their timeout.
    fn refuse_queued(&mut self) {
        while let Ok(Some(sample)) = self.ports.candidates.receive() {
            let id = sample.payload().candidate_id;
            drop(sample);
            let mut v =
                VerdictMsg::rejected(id, reason::SHUTTING_DOWN, "verifier shutting down", 0);
            if self.send(&mut v, id).is_err() {
                break;
            }
        }
    }
}

/// Publishes the status heartbeat from its own node until `stop` is set.
fn heartbeat(
    names: ServiceNames,
    instance: u64,
    counters: Arc<Counters>,
    config: ServerConfig,
    stop: Arc<AtomicBool>,
) -> Result<(), IpcError> {
    let node = NodeBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<S>()
        .map_err(|e| err("heartbeat node", e))?;
    let publisher = services::status(&node, &names)?
        .publisher_builder()
        .create()
        .map_err(|e| err("status publisher", e))?;
    let notifier = services::event(&node, &names.to_client)?
        .notifier_builder()
        .create()
        .map_err(|e| err("heartbeat notifier", e))?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<S>()
        .map_err(|e| err("heartbeat waitset", e))?;
    let _tick = waitset
        .attach_interval(config.heartbeat_period)
        .map_err(|e| err("heartbeat interval", e))?;
    let mut seq = 0u64;
    let mut last_report = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        seq += 1;
        let status = counters.snapshot(instance, seq, config.max_memory_bytes);
        if let Ok(sample) = publisher.loan_uninit() {
            let _ = sample.write_payload(status).send();
            let _ = notifier.notify();
        }
        if let Some(period) = config.report_period {
            if last_report.elapsed() >= period {
                last_report = Instant::now();
                eprintln!("turnprint-verifier: {}", format_status(&status));
            }
        }
        waitset
            .wait_and_process_once(|_| CallbackProgression::Continue)
            .map_err(|e| err("heartbeat wait", e))?;
    }
    Ok(())
}

/// Runs the verifier loop until SIGINT/SIGTERM; returns the final counters.
///
/// Stale resources of dead processes (a verifier killed with `kill -9`) are
/// removed first, so a restarted verifier takes over the same services.
pub fn run<V: FrameVerifier + ?Sized>(
    config: &ServerConfig,
    verifier: &mut V,
) -> Result<VerifierStatus, IpcError> {
    let names = ServiceNames::new(&config.prefix)?;
    let instance = random_u64();
    let node = NodeBuilder::new()
        .create::<S>()
        .map_err(|e| err("node", e))?;
    let cleaned = node.try_cleanup_dead_nodes();
    if cleaned.cleanups + cleaned.failed_cleanups > 0 {
        eprintln!(
            "turnprint-verifier: removed stale resources of {} dead processes ({} failed)",
            cleaned.cleanups, cleaned.failed_cleanups
        );
    }
    let ports = Ports {
        keyframes: services::keyframes(&node, &names)?
            .subscriber_builder()
            .buffer_size(KEYFRAME_QUEUE)
            .create()
            .map_err(|e| err("keyframe subscriber", e))?,
        candidates: services::candidates(&node, &names)?
            .subscriber_builder()
            .buffer_size(services::CANDIDATE_QUEUE)
            .create()
            .map_err(|e| err("candidate subscriber", e))?,
        verdicts: services::verdicts(&node, &names)?
            .publisher_builder()
            .create()
            .map_err(|e| err("verdict publisher", e))?,
        to_client: services::event(&node, &names.to_client)?
            .notifier_builder()
            .create()
            .map_err(|e| err("notifier", e))?,
    };
    let listener = services::event(&node, &names.to_verifier)?
        .listener_builder()
        .create()
        .map_err(|e| err("listener", e))?;
    let waitset = WaitSetBuilder::new()
        .create::<S>()
        .map_err(|e| err("waitset", e))?;
    let _guard = waitset
        .attach_notification(&listener)
        .map_err(|e| err("waitset attach", e))?;

    let counters = Arc::new(Counters::default());
    let stop = Arc::new(AtomicBool::new(false));
    let beat = {
        let (names, counters, config, stop) = (
            names.clone(),
            counters.clone(),
            config.clone(),
            stop.clone(),
        );
        std::thread::Builder::new()
            .name("heartbeat".into())
            .spawn(move || heartbeat(names, instance, counters, config, stop))
            .map_err(|e| err("heartbeat thread", e))?
    };
    eprintln!(
        "turnprint-verifier: serving prefix {:?} as instance {instance:016x}",
        config.prefix
    );

    let mut lp = Loop {
        node: &node,
        verifier,
        ports,
        counters: counters.clone(),
        instance,
        max_memory_bytes: config.max_memory_bytes,
        last_seq: HashMap::new(),
    };
    let result = (|| loop {
        // Anything sent before the listener existed is already queued.
        if lp.drain()? {
            return Ok(());
        }
        let run = waitset
            .wait_and_process_once(|_| {
                let _ = listener.try_wait(|_| {});
                CallbackProgression::Continue
            })
            .map_err(|e| err("wait", e))?;
        match run {
            WaitSetRunResult::TerminationRequest | WaitSetRunResult::Interrupt => return Ok(()),
            _ => {}
        }
    })();
    lp.refuse_queued();
    stop.store(true, Ordering::Relaxed);
    match beat.join() {
        Ok(Err(e)) => eprintln!("turnprint-verifier: heartbeat stopped: {e}"),
        Err(_) => eprintln!("turnprint-verifier: heartbeat thread panicked"),
        Ok(Ok(())) => {}
    }
    let status = counters.snapshot(instance, 0, config.max_memory_bytes);
    eprintln!("turnprint-verifier: final: {}", format_status(&status));
    result.map(|()| status)
}
