//! Cross-robot candidates verified on images (`stream --fleet --verify`).
//!
//! The fleet crate moves keyframes; what renders, stores and compares
//! images is the caller's ([`Verification`]: the CLI's verifier sidecar).
//! For each cross-robot candidate the robot asks the other for its keyframe
//! at the candidate's middle correspondence, on a thread of its own (a
//! robot that is gone costs a timeout there, never the replay), and hands
//! the pair to its verifier; every candidate then ends in one `confirmed`,
//! `rejected` or `expired` event that names the other robot. The robot's
//! own loop candidates are verified as `stream --verify` does, on its own
//! keyframes.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use crossbeam::channel::{unbounded, Receiver, Sender};
use serde_json::Value;

use crate::fleet::CrossCandidate;
use crate::keyframe::Keyframe;
use crate::payload::Refusal;
use crate::transport::{KeyframeSource, Transport};

/// What verifies cross-robot candidates on images.
pub trait Verification {
    /// This robot's keyframes as served to the others: the encoded
    /// keyframe nearest a pose index.
    fn source(&self) -> KeyframeSource;
    /// Hands candidate `id` to the verifier with the other robot's
    /// keyframe `theirs`; an ending event when it cannot be verified at all.
    fn submit(&mut self, id: u64, candidate: &CrossCandidate, theirs: Keyframe) -> Option<Value>;
    /// Hands this robot's own loop candidate `id` to the verifier (both
    /// keyframes its own); an ending event when it cannot be verified.
    fn submit_own(&mut self, id: u64, loop_: &turnprint::Hypothesis) -> Option<Value>;
    /// The ending events of the verdicts that have arrived.
    fn poll(&mut self) -> Vec<Value>;
    /// Candidates handed over and not yet ended.
    fn open(&self) -> usize;
    /// Ends every open candidate as `expired` with `reason`: their events.
    fn expire_all(&mut self, reason: &str) -> Vec<Value>;
    /// Counts for the summary.
    fn summary(&self) -> Value;
}

/// A cross-robot candidate waiting for the other robot's keyframe.
pub struct Request {
    /// The candidate's id in this robot's output.
    pub id: u64,
    /// The candidate.
    pub candidate: CrossCandidate,
}

/// The answer to a [`Request`]: the keyframe, or why there is none.
pub struct Fetched {
    /// The request.
    pub request: Request,
    /// The other robot's keyframe, or why it could not be had.
    pub keyframe: Result<Keyframe, String>,
}

/// Keyframes the other robots sent that were refused, by reason.
#[derive(Debug, Default)]
pub struct RefusedKeyframes {
    /// Not a keyframe of ours, cut short or inconsistent.
    pub garbage: AtomicU64,
    /// A newer payload version.
    pub version: AtomicU64,
}

/// The pose pair a candidate is verified at: its middle correspondence
/// (this robot's pose, the other's), or its ranges' starts without any.
pub fn verified_at(c: &CrossCandidate) -> (usize, usize) {
    let h = &c.hypothesis;
    h.correspondences
        .get(h.correspondences.len() / 2)
        .copied()
        .unwrap_or((h.a_range[0], h.b_range[0]))
}

/// Starts the thread that fetches the other robots' keyframes: requests in,
/// answers out, until the request side is dropped.
pub fn fetcher(
    transport: Arc<Transport>,
    refused: Arc<RefusedKeyframes>,
) -> (Sender<Request>, Receiver<Fetched>, JoinHandle<()>) {
    let (tx, requests) = unbounded::<Request>();
    let (answers, rx) = unbounded();
    let thread = std::thread::spawn(move || {
        for request in requests {
            let robot = request.candidate.robot.clone();
            let theirs = verified_at(&request.candidate).1 as u64;
            let keyframe = transport.fetch_keyframe(&robot, theirs).and_then(|bytes| {
                Keyframe::decode(&bytes).map_err(|e| {
                    let counter = match e {
                        Refusal::Garbage(_) => &refused.garbage,
                        Refusal::Version(_) => &refused.version,
                    };
                    counter.fetch_add(1, Ordering::Relaxed);
                    format!("{robot}'s keyframe {theirs} refused: {e}")
                })
            });
            if answers.send(Fetched { request, keyframe }).is_err() {
                return;
            }
        }
    });
    (tx, rx, thread)
}

/// An ending event of cross-robot candidate `id`: `kind` (`confirmed`,
/// `rejected` or `expired`), the other robot, the candidate's ranges and
/// the fields of `extra`.
pub fn ended(kind: &str, id: u64, c: &CrossCandidate, extra: Value) -> Value {
    let mut v = serde_json::json!({
        "event": kind,
        "id": id,
        "robot": c.robot,
        "query_range": c.hypothesis.a_range,
        "match_range": c.hypothesis.b_range,
    });
    if let (Some(o), Value::Object(e)) = (v.as_object_mut(), extra) {
        o.extend(e);
    }
    v
}
