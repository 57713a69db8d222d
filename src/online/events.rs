//! What the detector reports, and the ledger that makes sure every
//! candidate handed to a verifier ends as confirmed, rejected or expired.

use std::collections::HashMap;

use serde_json::{json, Value};

use crate::Hypothesis;

/// Which search found a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// The shape search (ZNCC of the newest segments against the history).
    Shape,
    /// The proximity probe (nearest earlier position in the map's frame).
    Proximity,
    /// The drifting-map probe ([`super::OnlineConfig::drift_probe`]): its
    /// score is low by design, the verifier decides.
    DriftProbe,
    /// The newest stretch registered onto the whole road network
    /// ([`super::register`]), where the drifting-map probe's seed found a
    /// road but no candidate: a drifted revisit that entered and left the
    /// earlier road by other roads. Emitted like the drift probe's.
    Network,
}

impl Source {
    /// The name in the JSON events.
    pub fn name(self) -> &'static str {
        match self {
            Source::Shape => "shape",
            Source::Proximity => "proximity",
            Source::DriftProbe => "drift-probe",
            Source::Network => "network",
        }
    }
}

/// A loop-closure candidate produced when a segment was finalised.
#[derive(Debug, Clone)]
pub struct CandidateEvent {
    /// Unique id (increasing).
    pub id: u64,
    /// Index of the pose whose arrival finalised the segment.
    pub at_pose: usize,
    /// The hypothesis: `a_range` is the query (later) part, `b_range` the
    /// match; the similarity maps match points onto the query part.
    pub hypothesis: Hypothesis,
    /// Which search found it.
    pub source: Source,
    /// The keyframe pair a verifier should compare (when keyframes were
    /// given): see `turnprint_ipc::Candidate::from_event`.
    pub keyframes: Option<KeyframePair>,
    /// Keyframe ids inside the query range (at most 8, spread evenly).
    pub query_keyframes: Vec<u64>,
    /// Keyframe ids inside the match range (at most 8, spread evenly).
    pub match_keyframes: Vec<u64>,
}

/// One keyframe on each side of a candidate, with their pose indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct KeyframePair {
    /// Keyframe id on the query (later) side.
    pub query_keyframe: u64,
    /// Its pose index.
    pub query_pose: usize,
    /// Keyframe id on the match (earlier) side.
    pub match_keyframe: u64,
    /// Its pose index.
    pub match_pose: usize,
}

impl CandidateEvent {
    /// The JSON Lines form of `cli.md` (`stream`): a `loops` entry plus
    /// `event`, `at_pose` and `id`.
    pub fn to_json(&self) -> Value {
        let mut event = candidate_fields(&self.hypothesis, self.at_pose);
        let extra = json!({
            "id": self.id,
            "rank": self.hypothesis.rank,
            "source": self.source.name(),
            "keyframes": self.keyframes,
            "query_keyframes": self.query_keyframes,
            "match_keyframes": self.match_keyframes,
        });
        if let Value::Object(extra) = extra {
            event.extend(extra);
        }
        Value::Object(event)
    }
}

/// The fields every `candidate` event of `cli.md` carries, the detector's
/// and a fleet's alike: `event`, `at_pose` and the overlap, its ranges
/// named from the query's side (`query_range`: the poses just driven).
pub fn candidate_fields(h: &Hypothesis, at_pose: usize) -> serde_json::Map<String, Value> {
    let h = h.to_json();
    [
        ("event", json!("candidate")),
        ("at_pose", json!(at_pose)),
        ("score", json!(h.score)),
        ("zncc", json!(h.zncc)),
        ("reversed", json!(h.reversed)),
        ("query_range", json!(h.a_range)),
        ("match_range", json!(h.b_range)),
        ("scale", json!(h.scale)),
        ("rotation", json!(h.rotation)),
        ("translation", json!(h.translation)),
        ("rmse", json!(h.rmse)),
        ("turning_deg", json!(h.turning_deg)),
    ]
    .into_iter()
    .map(|(key, value)| (key.to_string(), value))
    .collect()
}

/// How a candidate handed to a verifier ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The images agree: relative pose and inlier count.
    Confirmed {
        /// Relative pose (row-major 3x4) from the verifier.
        relative_pose: Vec<f64>,
        /// Inliers supporting it.
        inliers: usize,
    },
    /// The images disagree.
    Rejected {
        /// Why.
        reason: String,
    },
    /// No answer in time, or the verifier went away.
    Expired {
        /// Why.
        reason: String,
    },
}

/// Candidates handed out and not yet resolved. Every id ends in exactly
/// one outcome: resolving twice is refused, and [`Ledger::expire`] ends the
/// ones older than a deadline.
#[derive(Debug, Default)]
pub struct Ledger {
    open: HashMap<u64, (usize, std::time::Instant)>,
    /// Outcomes so far: confirmed, rejected, expired.
    pub counts: [u64; 3],
}

impl Ledger {
    /// Records a candidate handed to the verifier.
    pub fn open(&mut self, c: &CandidateEvent) {
        self.open
            .insert(c.id, (c.at_pose, std::time::Instant::now()));
    }

    /// Records an outcome; false when the id is unknown or already resolved.
    pub fn resolve(&mut self, id: u64, outcome: &Outcome) -> bool {
        if self.open.remove(&id).is_none() {
            return false;
        }
        let k = match outcome {
            Outcome::Confirmed { .. } => 0,
            Outcome::Rejected { .. } => 1,
            Outcome::Expired { .. } => 2,
        };
        self.counts[k] += 1;
        true
    }

    /// Expires every candidate opened before `older_than`; returns their ids.
    pub fn expire(&mut self, older_than: std::time::Instant, reason: &str) -> Vec<(u64, Outcome)> {
        let ids: Vec<u64> = self
            .open
            .iter()
            .filter(|(_, (_, t))| *t < older_than)
            .map(|(id, _)| *id)
            .collect();
        ids.into_iter()
            .map(|id| {
                let o = Outcome::Expired {
                    reason: reason.to_string(),
                };
                self.resolve(id, &o);
                (id, o)
            })
            .collect()
    }

    /// Candidates still waiting.
    pub fn pending(&self) -> usize {
        self.open.len()
    }
}
