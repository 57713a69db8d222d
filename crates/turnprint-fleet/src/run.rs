//! `turnprint stream A --json --fleet NAME --robot ID`: one robot of a
//! fleet. The path is replayed through the online detector (its own
//! candidates are written as without `--fleet`); every hand-over of
//! finalised samples is published as a chunk; a matching thread takes in
//! the other robots' chunks, matches new segments on either side and
//! writes the cross-robot candidates; after the path and `linger` seconds,
//! the summary holds the estimate of every robot heard from. With a
//! [`Verification`], each cross-robot candidate is verified on the images of
//! both robots, and each of its own on its own ([`crate::verify`]).

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam::channel::{select, unbounded, Receiver, Sender};
use serde_json::{json, Value};
use turnprint::online::frontend::Outbox;
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput, TrackParams};
use turnprint::pipeline::prepare::MIN_POSES;
use turnprint::Trajectory;

use crate::fleet::{CrossCandidate, Fleet, Received};
use crate::history::Encoder;
use crate::payload::{Chunk, FrameInfo};
use crate::transport::{Endpoints, Incoming, Transport};
use crate::verify::{Verification, Verifying};

/// How often a robot publishes its status, and the least time between two
/// catch-up queries to one robot: a missed chunk is noticed within about
/// a second, and a robot asks for a history at most once a second.
const STATUS_EVERY: Duration = Duration::from_secs(1);

/// How long the matching thread waits for work before it looks whether it
/// should stop.
const IDLE: Duration = Duration::from_millis(50);

/// Refusals written to stderr, at most (a peer sending garbage in a loop
/// must not flood it; all are counted in the summary).
const REPORTED_REFUSALS: u64 = 10;

/// One robot's fleet options.
#[derive(Debug, Clone)]
pub struct Options {
    /// The fleet's name (key expressions `turnprint/<fleet>/...`).
    pub fleet: String,
    /// This robot's name.
    pub robot: String,
    /// Zenoh endpoints.
    pub endpoints: Endpoints,
    /// Poses per second of the replay (`None`: as fast as it can).
    pub rate: Option<f64>,
    /// Seconds of matching and listening after the last pose.
    pub linger: f64,
}

/// Why a fleet stream ended before its summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StreamError {
    /// The reader of the output stopped reading (`| head`): what it read
    /// is complete.
    OutputClosed,
    /// Bad options, a transport that cannot start, an output that fails:
    /// one clear line.
    Message(String),
}

impl std::fmt::Display for StreamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StreamError::OutputClosed => write!(f, "the output was closed"),
            StreamError::Message(m) => write!(f, "{m}"),
        }
    }
}

impl From<String> for StreamError {
    fn from(m: String) -> Self {
        StreamError::Message(m)
    }
}

/// The error for bad options or a transport that cannot start.
fn bad(why: impl Into<String>) -> StreamError {
    StreamError::Message(why.into())
}

/// The error of a failed write to the output.
fn output_error(e: std::io::Error) -> StreamError {
    match e.kind() {
        std::io::ErrorKind::BrokenPipe => StreamError::OutputClosed,
        _ => StreamError::Message(format!("<stdout>: {e}")),
    }
}

/// Writes one event as a JSON line.
fn write(out: &mut dyn Write, v: &Value) -> Result<(), StreamError> {
    writeln!(out, "{v}").map_err(output_error)
}

/// Sets `stop` when dropped: the threads of a stream that ends early
/// (its output closed) end with it.
struct StopOnDrop(Arc<AtomicBool>);

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// Streams `trajectory` (named `name`) as robot `options.robot` of the
/// fleet and writes JSON Lines to `out`; returns the summary.
pub fn stream(
    trajectory: &Trajectory,
    name: &str,
    config: &OnlineConfig,
    options: &Options,
    out: &mut dyn Write,
) -> Result<Value, StreamError> {
    run(trajectory, name, config, options, None, out)
}

/// As [`stream`], with every candidate verified by `verification`: a
/// cross-robot one on the keyframes of both robots (this robot serves its
/// own to the others), its own loops on its own.
pub fn stream_verified(
    trajectory: &Trajectory,
    name: &str,
    config: &OnlineConfig,
    options: &Options,
    verification: &mut dyn Verification,
    out: &mut dyn Write,
) -> Result<Value, StreamError> {
    run(trajectory, name, config, options, Some(verification), out)
}

fn run(
    trajectory: &Trajectory,
    name: &str,
    config: &OnlineConfig,
    options: &Options,
    verification: Option<&mut dyn Verification>,
    out: &mut dyn Write,
) -> Result<Value, StreamError> {
    for (what, v) in [("fleet", &options.fleet), ("robot", &options.robot)] {
        if !crate::valid_name(v) {
            return Err(bad(format!(
                "--{what} {v:?}: 1 to 64 letters, digits, '-', '_' or '.'"
            )));
        }
    }
    if options.rate.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
        return Err(bad("--rate: a positive number of poses per second"));
    }
    if !(options.linger.is_finite() && options.linger >= 0.0) {
        return Err(bad("--linger: a number of seconds, 0 or more"));
    }
    if trajectory.len() < MIN_POSES {
        return Err(bad(format!(
            "{name}: {} poses; the method needs at least {MIN_POSES}",
            trajectory.len()
        )));
    }
    let epoch = new_epoch();
    let (in_tx, in_rx) = unbounded();
    let transport = Arc::new(Transport::open(
        &options.fleet,
        &options.robot,
        &options.endpoints,
        in_tx,
    )?);
    // Late joiner or not: whatever the others have published so far.
    transport.catch_up("*");
    let mut verifying = match verification {
        Some(v) => Some(Verifying::start(&transport, v)?),
        None => None,
    };
    let mut next_id = 0u64;
    let mut cross_event = |c: CrossCandidate, verifying: &mut Option<Verifying>| -> Value {
        let id = next_id;
        next_id += 1;
        let mut event = c.to_json();
        if let Some(o) = event.as_object_mut() {
            o.insert("id".into(), json!(id));
        }
        if let Some(v) = verifying.as_mut() {
            v.cross(id, c);
        }
        event
    };
    // The robot's own candidates, handed to the verification too.
    let own_event = |e: &CandidateEvent,
                     verifying: &mut Option<Verifying>,
                     out: &mut dyn Write|
     -> Result<(), StreamError> {
        write(out, &e.to_json())?;
        match verifying.as_mut().and_then(|v| v.own(e)) {
            Some(ended) => write(out, &ended),
            None => Ok(()),
        }
    };
    // The endings of the verifications.
    let verdicts = |verifying: &mut Option<Verifying>, out: &mut dyn Write| {
        verifying.as_mut().map_or(Ok(()), |v| {
            v.events().iter().try_for_each(|e| write(out, e))
        })
    };
    let stop = Arc::new(AtomicBool::new(false));
    let _stop_on_drop = StopOnDrop(stop.clone());
    let status = status_thread(transport.clone(), epoch, stop.clone());
    let (own_tx, own_rx) = unbounded();
    let (cand_tx, cand_rx) = unbounded();
    let matcher = {
        let (robot, transport, stop) = (options.robot.clone(), transport.clone(), stop.clone());
        std::thread::Builder::new()
            .name("turnprint-fleet".into())
            .spawn(move || {
                let fleet = Fleet::new(&robot, epoch);
                matching(fleet, own_rx, in_rx, cand_tx, &transport, &stop)
            })
            .map_err(|e| format!("starting the matching thread: {e}"))?
    };
    let mut detector = Detector::new(config.clone(), Overflow::Block);
    let tap = detector.tap_finalised();
    let mut publisher = Chunker {
        encoder: Encoder::new(epoch),
        pending: Outbox::default(),
        dk: config.pipeline.signature.dk,
        transport: transport.clone(),
        own: own_tx,
    };
    let t0 = Instant::now();
    let mut cross = 0u64;
    for (i, pose) in trajectory.poses.iter().enumerate() {
        if let Some(rate) = options.rate {
            let due = t0 + Duration::from_secs_f64(i as f64 / rate);
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        detector.push(&PoseInput::from(pose));
        publisher.take(&tap);
        if !publisher.pending.bounds.is_empty() {
            publisher.publish(detector.params(), detector.poses(), false)?;
        }
        for e in detector.poll() {
            own_event(&e, &mut verifying, out)?;
        }
        for c in cand_rx.try_iter() {
            cross += 1;
            write(out, &cross_event(c, &mut verifying))?;
        }
        verdicts(&mut verifying, out)?;
    }
    let (params, poses) = (detector.params(), detector.poses());
    let (rest, summary) = detector.finish();
    publisher.take(&tap);
    publisher.publish(params, poses, true)?;
    for e in rest {
        own_event(&e, &mut verifying, out)?;
    }
    let linger_end = Instant::now() + Duration::from_secs_f64(options.linger);
    loop {
        let left = linger_end.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        if let Ok(c) = cand_rx.recv_timeout(left.min(IDLE)) {
            cross += 1;
            write(out, &cross_event(c, &mut verifying))?;
        }
        verdicts(&mut verifying, out)?;
    }
    stop.store(true, Ordering::Relaxed);
    let _ = status.join();
    let mut fleet = matcher
        .join()
        .map_err(|_| bad("the fleet's matching thread stopped on an internal error"))?;
    for c in cand_rx.try_iter() {
        cross += 1;
        write(out, &cross_event(c, &mut verifying))?;
    }
    // Every candidate ends: its keyframe fetched or not, its verdict in or
    // expired.
    let verified = match verifying.as_mut() {
        Some(v) => Some(v.finish(&mut |e| write(out, e))?),
        None => None,
    };
    // Where the verifier confirmed a cross-robot candidate, the estimate of
    // that robot leads with a placement that lays its keyframes' place
    // together.
    for c in verifying
        .as_mut()
        .map(|v| v.confirmed())
        .unwrap_or_default()
    {
        fleet.confirm(&c);
    }
    let sent = &transport.sent;
    let mut s = serde_json::to_value(summary).unwrap_or_default();
    if let Some(o) = s.as_object_mut() {
        o.insert("event".into(), json!("summary"));
        o.insert("path".into(), json!(name));
        o.insert("candidates".into(), json!(summary.worker.candidates));
        o.insert("fleet".into(), json!(options.fleet));
        o.insert("robot".into(), json!(options.robot));
        o.insert("robots".into(), fleet.robots_json());
        o.insert("refused".into(), json!(fleet.refused()));
        o.insert("cross_candidates".into(), json!(cross));
        o.insert(
            "sent".into(),
            json!({
                "published_bytes": sent.published.load(Ordering::Relaxed),
                "published": sent.messages.load(Ordering::Relaxed),
                "chunks": transport.chunks_published(),
                "replied_bytes": sent.replied.load(Ordering::Relaxed),
                "queries_answered": sent.queries.load(Ordering::Relaxed),
                "keyframes_served": sent.keyframes.load(Ordering::Relaxed),
                "keyframe_bytes": sent.keyframe_bytes.load(Ordering::Relaxed),
                "history_bytes": transport.stored_bytes(),
            }),
        );
        o.insert("fleet_state".into(), fleet.stats_json());
        o.insert("cpu_s".into(), json!(cpu_seconds()));
        if let Some(v) = verified {
            o.insert("verify".into(), v);
        }
    }
    write(out, &s)?;
    out.flush().map_err(output_error)?;
    Ok(s)
}

/// Cuts the tapped samples into chunks and publishes them.
struct Chunker {
    encoder: Encoder,
    pending: Outbox,
    dk: f64,
    transport: Arc<Transport>,
    own: Sender<Chunk>,
}

impl Chunker {
    /// Takes in what the detector finalised since the last call.
    fn take(&mut self, tap: &Receiver<Outbox>) {
        for o in tap.try_iter() {
            let p = &mut self.pending;
            p.grid.extend(o.grid);
            p.sig.extend(o.sig);
            p.bounds.extend(o.bounds);
        }
    }

    /// Publishes the pending samples as one chunk (the last one: `last`).
    fn publish(
        &mut self,
        params: Option<TrackParams>,
        poses: usize,
        last: bool,
    ) -> Result<(), String> {
        // Before the warm-up ends nothing is finalised, and a path too
        // short to end it has no frame to share.
        let Some(p) = params else {
            return Ok(());
        };
        let frame = FrameInfo {
            plane: p.plane,
            step: p.grid_step,
            bandwidth: p.smoother.bandwidth,
            dk: self.dk,
        };
        let pending = std::mem::take(&mut self.pending);
        let chunk = self.encoder.chunk(&pending, poses, frame, last);
        self.transport.publish_chunk(chunk.encode())?;
        let _ = self.own.send(chunk);
        Ok(())
    }
}

/// Publishes the robot's status every [`STATUS_EVERY`] until `stop`.
fn status_thread(transport: Arc<Transport>, epoch: u64, stop: Arc<AtomicBool>) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let mut next = Instant::now();
        while !stop.load(Ordering::Relaxed) {
            if Instant::now() >= next {
                let _ = transport.publish_status(epoch);
                next += STATUS_EVERY;
            }
            std::thread::sleep(IDLE);
        }
    })
}

/// The matching thread: takes in own and received chunks, matches what is
/// new whenever the queues are empty, and sends the candidates' JSON; ends
/// with one last matching once `stop` is set.
fn matching(
    mut fleet: Fleet,
    own: Receiver<Chunk>,
    incoming: Receiver<Incoming>,
    candidates: Sender<CrossCandidate>,
    transport: &Transport,
    stop: &AtomicBool,
) -> Fleet {
    let mut asked: std::collections::HashMap<String, Instant> = Default::default();
    let mut reported = 0;
    let mut take = |fleet: &mut Fleet, m: Incoming| match fleet.receive(&m.robot, &m.bytes) {
        Received::CatchUp => {
            let due = asked
                .get(&m.robot)
                .is_none_or(|t| t.elapsed() >= STATUS_EVERY);
            if due {
                asked.insert(m.robot.clone(), Instant::now());
                transport.catch_up(&m.robot);
            }
        }
        Received::Refused(why) => {
            reported += 1;
            if reported <= REPORTED_REFUSALS {
                eprintln!("turnprint: refused a fleet payload: {why}");
            }
        }
        Received::Applied | Received::Ignored => {}
    };
    loop {
        let stopping = stop.load(Ordering::Relaxed);
        select! {
            recv(own) -> c => if let Ok(c) = c { own_chunk(&mut fleet, &c) },
            recv(incoming) -> m => if let Ok(m) = m { take(&mut fleet, m) },
            default(IDLE) => {},
        }
        for c in own.try_iter() {
            own_chunk(&mut fleet, &c);
        }
        for m in incoming.try_iter() {
            take(&mut fleet, m);
        }
        for c in fleet.match_new(stopping) {
            let _ = candidates.send(c);
        }
        if stopping {
            return fleet;
        }
    }
}

/// Takes in one of this robot's own chunks.
fn own_chunk(fleet: &mut Fleet, c: &Chunk) {
    if let Err(why) = fleet.own_chunk(c) {
        // The detector's own samples: a bug if it happens, not the input.
        eprintln!("turnprint: own chunk not taken in: {why}");
    }
    if c.last {
        fleet.own_ended();
    }
}

/// A session id: a restarted robot's differs from its earlier one's.
fn new_epoch() -> u64 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    nanos ^ (u64::from(std::process::id()) << 40)
}

/// CPU time of this process so far (user and system, seconds), where the
/// system tells it (`/proc`).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which may hold spaces): state is the
    // first, utime and stime the 12th and 13th.
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    // Linux reports in USER_HZ, 100 on every architecture it runs on.
    Some(ticks / 100.0)
}
