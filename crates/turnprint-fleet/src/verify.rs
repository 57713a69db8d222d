//! Cross-robot candidates verified on images (`stream --fleet --verify`).
//!
//! The fleet crate moves keyframes; what renders, stores and compares
//! images is the caller's ([`Verification`]: the CLI's verifier sidecar).
//! For each cross-robot candidate the robot asks the other for its keyframe
//! at the candidate's middle correspondence, on a thread of its own (a
//! robot that is gone costs a timeout there, never the replay), and hands
//! the pair to its verifier; every candidate then ends in one `confirmed`,
//! `rejected` or `expired` event that names the other robot, and the
//! confirmed ones lead the robot's estimate of the other's frame
//! ([`crate::Fleet::confirm`]). The robot's own loop candidates are
//! verified as `stream --verify` does, on its own keyframes.

use std::collections::HashMap;
use std::sync::Arc;
use std::thread::JoinHandle;

use crossbeam::channel::{unbounded, Receiver, Sender};
use serde_json::Value;

use std::time::{Duration, Instant};

use serde_json::json;
use turnprint::online::CandidateEvent;
use turnprint::Hypothesis;

use crate::fleet::{CrossCandidate, Refused};
use crate::keyframe::Keyframe;
use crate::payload::Refusal;
use crate::transport::{KeyframeSource, Transport, KEYFRAME_TIMEOUT};

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
    /// Why the keyframe the other robot sent was refused, when it was.
    pub refused: Option<Refusal>,
}

/// The pose pair a hypothesis is verified at: its middle correspondence
/// (this robot's pose, the other's), or its ranges' starts without any.
pub fn verified_at(h: &turnprint::Hypothesis) -> (usize, usize) {
    h.correspondences
        .get(h.correspondences.len() / 2)
        .copied()
        .unwrap_or((h.a_range[0], h.b_range[0]))
}

/// Starts the thread that fetches the other robots' keyframes: requests in,
/// answers out, until the request side is dropped.
pub fn fetcher(transport: Arc<Transport>) -> (Sender<Request>, Receiver<Fetched>, JoinHandle<()>) {
    let (tx, requests) = unbounded::<Request>();
    let (answers, rx) = unbounded();
    let thread = std::thread::spawn(move || {
        for request in requests {
            let robot = request.candidate.robot.clone();
            let theirs = verified_at(&request.candidate.hypothesis).1 as u64;
            let (keyframe, refused) = match transport.fetch_keyframe(&robot, theirs) {
                Err(why) => (Err(why), None),
                Ok(bytes) => match Keyframe::decode(&bytes) {
                    Ok(k) => (Ok(k), None),
                    Err(e) => (
                        Err(format!("{robot}'s keyframe {theirs} refused: {e}")),
                        Some(e),
                    ),
                },
            };
            let answer = Fetched {
                request,
                keyframe,
                refused,
            };
            if answers.send(answer).is_err() {
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

/// How long, after the candidates stop, a stream waits for their verdicts
/// at most: a keyframe fetch and the verifier's own expiry (which ends
/// every candidate it holds) with room to spare.
const VERDICT_WAIT: Duration = Duration::from_secs(20);

/// How often the wait for the last verdicts looks for them.
const POLL: Duration = Duration::from_millis(50);

/// A stream's verification while it runs: this robot's keyframes served,
/// the other robots' fetched, every candidate handed to `verification`.
pub struct Verifying<'a> {
    verification: &'a mut dyn Verification,
    requests: Option<Sender<Request>>,
    answers: Receiver<Fetched>,
    fetcher: Option<JoinHandle<()>>,
    /// Requests sent and not yet answered.
    fetching: usize,
    /// Keyframes the other robots sent that were refused, by reason.
    refused: Refused,
    /// Cross-robot candidates handed over and not yet ended, by id.
    open: HashMap<u64, CrossCandidate>,
    /// Cross-robot candidates confirmed and not yet taken.
    confirmed: Vec<CrossCandidate>,
}

impl<'a> Verifying<'a> {
    /// Serves this robot's keyframes over `transport` and starts fetching
    /// the others'.
    pub fn start(
        transport: &Arc<Transport>,
        verification: &'a mut dyn Verification,
    ) -> Result<Verifying<'a>, String> {
        transport.serve_keyframes(verification.source())?;
        let (requests, answers, thread) = fetcher(transport.clone());
        Ok(Verifying {
            verification,
            requests: Some(requests),
            answers,
            fetcher: Some(thread),
            fetching: 0,
            refused: Refused::default(),
            open: HashMap::new(),
            confirmed: Vec::new(),
        })
    }

    /// Asks for the other robot's keyframe of cross-robot candidate `id`.
    pub fn cross(&mut self, id: u64, candidate: CrossCandidate) {
        if let Some(tx) = &self.requests {
            // Kept with the one correspondence its keyframes are taken at:
            // what a confirmation vouches for.
            let kept = CrossCandidate {
                hypothesis: Hypothesis {
                    correspondences: vec![verified_at(&candidate.hypothesis)],
                    ..candidate.hypothesis.clone()
                },
                ..candidate.clone()
            };
            if tx.send(Request { id, candidate }).is_ok() {
                self.fetching += 1;
                self.open.insert(id, kept);
            }
        }
    }

    /// The cross-robot candidates confirmed since the last call.
    pub fn confirmed(&mut self) -> Vec<CrossCandidate> {
        std::mem::take(&mut self.confirmed)
    }

    /// Notes the ending of a cross-robot candidate among `events`.
    fn note(&mut self, events: &[Value]) {
        for e in events {
            let (Some(kind), Some(id), Some(_)) = (
                e.get("event").and_then(Value::as_str),
                e.get("id").and_then(Value::as_u64),
                e.get("robot"),
            ) else {
                continue;
            };
            if let Some(c) = self.open.remove(&id) {
                if kind == "confirmed" {
                    self.confirmed.push(c);
                }
            }
        }
    }

    /// Hands this robot's own candidate over: its ending when it cannot be
    /// verified.
    pub fn own(&mut self, e: &CandidateEvent) -> Option<Value> {
        self.verification.submit_own(e.id, &e.hypothesis)
    }

    /// The events of the keyframes fetched and the verdicts arrived since
    /// the last call.
    pub fn events(&mut self) -> Vec<Value> {
        let mut events = Vec::new();
        for f in self.answers.try_iter() {
            self.fetching -= 1;
            match f.refused {
                Some(Refusal::Garbage(_)) => self.refused.garbage += 1,
                Some(Refusal::Version(_)) => self.refused.version += 1,
                None => {}
            }
            let Request { id, candidate } = f.request;
            match f.keyframe {
                Ok(k) => events.extend(self.verification.submit(id, &candidate, k)),
                Err(why) => events.push(ended("expired", id, &candidate, json!({"reason": why}))),
            }
        }
        events.extend(self.verification.poll());
        self.note(&events);
        events
    }

    /// Waits until every candidate has ended (at most the fetch timeout and
    /// 20 s more), writing their events with `write`, and expires
    /// those still open; the summary's counts.
    pub fn finish<E>(
        &mut self,
        write: &mut dyn FnMut(&Value) -> Result<(), E>,
    ) -> Result<Value, E> {
        self.requests = None;
        let deadline = Instant::now() + KEYFRAME_TIMEOUT + VERDICT_WAIT;
        while (self.fetching > 0 || self.verification.open() > 0) && Instant::now() < deadline {
            self.events().iter().try_for_each(&mut *write)?;
            std::thread::sleep(POLL);
        }
        if let Some(t) = self.fetcher.take() {
            let _ = t.join();
        }
        self.events().iter().try_for_each(&mut *write)?;
        let expired = self
            .verification
            .expire_all("the stream ended before its verdict");
        self.note(&expired);
        expired.iter().try_for_each(&mut *write)?;
        let mut summary = self.verification.summary();
        if let Some(o) = summary.as_object_mut() {
            o.insert("refused_keyframes".into(), json!(self.refused));
        }
        Ok(summary)
    }
}
