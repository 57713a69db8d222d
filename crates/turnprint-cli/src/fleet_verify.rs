//! `turnprint stream --fleet --verify`: a robot's cross-robot candidates
//! verified on the keyframes of both robots.
//!
//! Every robot renders its own keyframes (the built-in test world along
//! `--world`, the path every robot's truth lies on, seen from its own
//! `--truth`) and serves them to the others over Zenoh
//! ([`turnprint_fleet::keyframe`]). For a cross-robot candidate the robot
//! fetches the other's keyframe at the candidate's middle correspondence,
//! publishes it into its own verifier sidecar beside its own keyframe, and
//! submits the pair; the verifier is the one `stream --verify` starts.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use serde_json::{json, Value};

use turnprint_fleet::keyframe::Keyframe;
use turnprint_fleet::transport::KeyframeSource;
use turnprint_fleet::verify::{ended, verified_at, Verification};
use turnprint_fleet::CrossCandidate;
use turnprint_ipc::client::{Candidate, Outcome, VerifierClient};
use turnprint_ipc::payload::CameraParams;

use crate::keyframes::{Renderer, Sidecar};

/// Verifier ids of other robots' keyframes have this bit set (this robot's
/// own are their pose indices), then the robot's number (in the order
/// heard from) above bit 40 and the pose below it.
const FOREIGN: u64 = 1 << 63;

/// A candidate handed to the verifier.
struct Open {
    id: u64,
    candidate: CrossCandidate,
    keyframes: [u64; 2],
}

/// Counts of the cross-robot verification.
#[derive(Debug, Default, serde::Serialize)]
struct Counts {
    submitted: u64,
    confirmed: u64,
    rejected: u64,
    expired: u64,
    own_keyframes_published: u64,
    their_keyframes_published: u64,
}

/// The verifier of one robot of a fleet.
pub struct FleetVerifier {
    renderer: Arc<Renderer>,
    client: VerifierClient,
    _sidecar: Sidecar,
    published: HashSet<u64>,
    robots: HashMap<String, u64>,
    open: HashMap<u64, Open>,
    counts: Counts,
}

impl FleetVerifier {
    /// A verifier over `renderer`'s keyframes with a started sidecar.
    pub fn new(renderer: Renderer, sidecar: Sidecar, client: VerifierClient) -> FleetVerifier {
        FleetVerifier {
            renderer: Arc::new(renderer),
            client,
            _sidecar: sidecar,
            published: HashSet::new(),
            robots: HashMap::new(),
            open: HashMap::new(),
            counts: Counts::default(),
        }
    }

    /// The verifier's id of `robot`'s keyframe at `pose`.
    fn foreign_id(&mut self, robot: &str, pose: u64) -> u64 {
        let n = self.robots.len() as u64;
        let number = *self.robots.entry(robot.to_string()).or_insert(n);
        FOREIGN | (number & 0x7f_ffff) << 40 | (pose & ((1 << 40) - 1))
    }

    fn event(&self, kind: &str, o: &Open, extra: Value) -> Value {
        let mut v = ended(kind, o.id, &o.candidate, extra);
        if let Some(m) = v.as_object_mut() {
            m.insert("query_keyframe".into(), json!(o.keyframes[0]));
            m.insert(
                "match_keyframe".into(),
                json!(o.keyframes[1] & ((1 << 40) - 1)),
            );
        }
        v
    }
}

impl Verification for FleetVerifier {
    fn source(&self) -> KeyframeSource {
        let r = self.renderer.clone();
        Arc::new(move |pose: u64| {
            if r.is_empty() {
                return None;
            }
            let k = r.snap(usize::try_from(pose).unwrap_or(usize::MAX));
            let (camera, image) = r.render(k);
            Some(
                Keyframe {
                    pose: k as u64,
                    t: r.time(k),
                    camera_kind: camera.kind,
                    width: camera.width,
                    height: camera.height,
                    params: camera.params,
                    image,
                }
                .encode(),
            )
        })
    }

    fn submit(&mut self, id: u64, c: &CrossCandidate, theirs: Keyframe) -> Option<Value> {
        let (q, m) = verified_at(c);
        let own = self.renderer.snap(q) as u64;
        let foreign = self.foreign_id(&c.robot, theirs.pose);
        let open = Open {
            id,
            candidate: c.clone(),
            keyframes: [own, foreign],
        };
        if self.published.insert(own) {
            let (camera, image) = self.renderer.render(own as usize);
            let t = self.renderer.time(own as usize);
            if self
                .client
                .publish_keyframe(own, t, &camera, &image)
                .is_err()
            {
                self.published.remove(&own);
                self.counts.expired += 1;
                return Some(self.event(
                    "expired",
                    &open,
                    json!({"reason": "own keyframe not published"}),
                ));
            }
            self.counts.own_keyframes_published += 1;
        }
        if self.published.insert(foreign) {
            let camera = CameraParams {
                kind: theirs.camera_kind,
                width: theirs.width,
                height: theirs.height,
                _pad: 0,
                params: theirs.params,
            };
            if let Err(e) = self
                .client
                .publish_keyframe(foreign, theirs.t, &camera, &theirs.image)
            {
                self.published.remove(&foreign);
                self.counts.expired += 1;
                return Some(self.event(
                    "expired",
                    &open,
                    json!({"reason": format!("{}'s keyframe not published: {e}", c.robot)}),
                ));
            }
            self.counts.their_keyframes_published += 1;
        }
        let h = &c.hypothesis;
        let handle = self.client.submit(Candidate {
            query_keyframe: own,
            match_keyframe: foreign,
            query_pose: q as u64,
            match_pose: m as u64,
            scale: h.scale,
            rotation: h.rotation,
            translation: h.translation,
            score: h.score,
        });
        self.counts.submitted += 1;
        self.open.insert(handle, open);
        None
    }

    fn poll(&mut self) -> Vec<Value> {
        let outcomes = self.client.poll();
        let mut events = Vec::new();
        for o in outcomes {
            let Some(c) = self.open.remove(&o.id()) else {
                continue;
            };
            events.push(match &o {
                Outcome::Confirmed {
                    match_R_query,
                    match_t_query,
                    inliers,
                    ..
                } => {
                    self.counts.confirmed += 1;
                    let r = match_R_query;
                    self.event(
                        "confirmed",
                        &c,
                        json!({
                            "inliers": inliers,
                            "relative_pose": {
                                "match_R_query": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
                                "match_t_query": [match_t_query.x, match_t_query.y, match_t_query.z],
                            },
                        }),
                    )
                }
                Outcome::Rejected {
                    reason, inliers, ..
                } => {
                    self.counts.rejected += 1;
                    self.event("rejected", &c, json!({"reason": reason, "inliers": inliers}))
                }
                Outcome::Expired { reason, .. } => {
                    self.counts.expired += 1;
                    self.event("expired", &c, json!({"reason": format!("{reason:?}")}))
                }
            });
        }
        events
    }

    fn open(&self) -> usize {
        self.open.len()
    }

    fn expire_all(&mut self, reason: &str) -> Vec<Value> {
        let open: Vec<Open> = self.open.drain().map(|(_, o)| o).collect();
        self.counts.expired += open.len() as u64;
        open.iter()
            .map(|o| self.event("expired", o, json!({"reason": reason})))
            .collect()
    }

    fn summary(&self) -> Value {
        serde_json::to_value(&self.counts).unwrap_or_default()
    }
}
