//! `turnprint stream --fleet [--verify]`: one robot of a fleet, its
//! cross-robot candidates verified on the keyframes of both robots.
//!
//! Every robot renders its own keyframes (the built-in test world along
//! `--world`, the path every robot's truth lies on, seen from its own
//! `--truth`) and serves them to the others over Zenoh
//! ([`turnprint_fleet::keyframe`]). For a cross-robot candidate the robot
//! fetches the other's keyframe at the candidate's middle correspondence,
//! publishes it into its own verifier sidecar beside its own keyframe, and
//! submits the pair; the verifier is the one `stream --verify` starts. The
//! robot's own loop candidates are verified on its own keyframes, as
//! `stream --verify` does.

use std::collections::{HashMap, HashSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use serde_json::{json, Value};
use turnprint::io::Format;
use turnprint::online::OnlineConfig;
use turnprint::Trajectory;
use turnprint_fleet::StreamError;

use crate::input::read;

use turnprint_fleet::keyframe::Keyframe;
use turnprint_fleet::transport::KeyframeSource;
use turnprint_fleet::verify::{verified_at, Verification};
use turnprint_fleet::CrossCandidate;
use turnprint_ipc::client::{Outcome, VerifierClient};
use turnprint_ipc::payload::CameraParams;

use crate::keyframes::{candidate, ending, start_verifier, verdict, Renderer, Sidecar};
use crate::sidecar::{CameraKind, VerifyOptions};

/// What `stream --fleet --verify` reads besides the path.
#[derive(Debug, Clone)]
pub struct Files {
    /// The true poses this robot's keyframes are rendered from (default:
    /// the path itself).
    pub truth: Option<PathBuf>,
    /// The path the test world is built along (default: the truth).
    pub world: Option<PathBuf>,
    /// The cameras, comma-separated (`pinhole,fisheye,omni`).
    pub cameras: String,
}

/// Streams path `a` as one robot of the fleet `options` names, writing JSON
/// Lines to `out`; with `verify`, every candidate is verified on keyframes.
pub fn stream(
    a: &Path,
    format: Format,
    topic: Option<&str>,
    config: &OnlineConfig,
    options: &turnprint_fleet::Options,
    verify: Option<Files>,
    out: &mut dyn Write,
) -> Result<(), StreamError> {
    let read =
        |p: &Path, format| read(p, format, topic).map_err(|e| StreamError::Message(e.to_string()));
    let trajectory = read(a, format)?;
    let name = a.display().to_string();
    let result = match verify {
        None => turnprint_fleet::stream(&trajectory, &name, config, options, out),
        Some(files) => {
            let truth = match &files.truth {
                Some(t) => read(t, Format::Auto)?,
                None => trajectory.clone(),
            };
            let world = files
                .world
                .as_deref()
                .map(|w| read(w, Format::Auto))
                .transpose()?;
            let mut verifier =
                FleetVerifier::start(&trajectory, &truth, world.as_ref(), &files.cameras)
                    .map_err(|e| StreamError::Message(format!("{name}: {e}")))?;
            turnprint_fleet::stream_verified(
                &trajectory,
                &name,
                config,
                options,
                &mut verifier,
                out,
            )
        }
    };
    result.map(|_| ())
}

/// Verifier ids of other robots' keyframes have this bit set (this robot's
/// own are their pose indices), then the robot's number (in the order
/// heard from) above bit 40 and the pose below it.
const FOREIGN: u64 = 1 << 63;

/// A candidate handed to the verifier.
struct Open {
    id: u64,
    /// The other robot of a cross-robot candidate; `None` for a loop of
    /// this robot's own.
    robot: Option<String>,
    query_range: [usize; 2],
    match_range: [usize; 2],
    keyframes: [u64; 2],
}

/// Counts of the cross-robot verification.
#[derive(Debug, Default, serde::Serialize)]
struct Counts {
    submitted: u64,
    own_submitted: u64,
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
    /// The verifier of the robot driving `input`: its keyframes rendered
    /// from `truth` in the world built along `world` (default: the truth)
    /// with the cameras `cameras` (comma-separated names), and a verifier
    /// sidecar started and ready.
    pub fn start(
        input: &Trajectory,
        truth: &Trajectory,
        world: Option<&Trajectory>,
        cameras: &str,
    ) -> Result<FleetVerifier, String> {
        let cameras = CameraKind::parse_list(cameras)?;
        let options = VerifyOptions {
            cameras,
            ..VerifyOptions::default()
        };
        let renderer = Renderer::new(input, truth, world, &options)?;
        let (sidecar, mut client, _) = start_verifier(&options).map_err(|e| e.to_string())?;
        if !client.wait_for_verifier(Duration::from_secs(20)) {
            return Err("the verifier sidecar did not come up".into());
        }
        Ok(FleetVerifier::new(renderer, sidecar, client))
    }

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

    /// Ending event `kind` of `o`: the fields of `stream --verify`'s, and
    /// for a cross-robot candidate the other robot.
    fn event(&self, kind: &str, o: &Open, extra: Value) -> Value {
        let keyframes = [o.keyframes[0], o.keyframes[1] & ((1 << 40) - 1)];
        let ranges = [o.query_range, o.match_range];
        let mut v = ending(kind, o.id, ranges, keyframes, extra);
        if let (Some(m), Some(r)) = (v.as_object_mut(), &o.robot) {
            m.insert("robot".into(), json!(r));
        }
        v
    }

    /// Publishes this robot's keyframe `k` unless it has been; whether the
    /// verifier has it.
    fn publish_own(&mut self, k: u64) -> bool {
        if self.published.contains(&k) {
            return true;
        }
        let (camera, image) = self.renderer.render(k as usize);
        let t = self.renderer.time(k as usize);
        let ok = self.client.publish_keyframe(k, t, &camera, &image).is_ok();
        if ok {
            self.published.insert(k);
            self.counts.own_keyframes_published += 1;
        }
        ok
    }

    /// Submits `open` with the hypothesis' similarity and the poses `q`,
    /// `m` of its middle correspondence.
    fn submit_open(&mut self, open: Open, h: &turnprint::Hypothesis, (q, m): (usize, usize)) {
        let handle = self.client.submit(candidate(h, open.keyframes, (q, m)));
        self.open.insert(handle, open);
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
        let (q, m) = verified_at(&c.hypothesis);
        let own = self.renderer.snap(q) as u64;
        let foreign = self.foreign_id(&c.robot, theirs.pose);
        let h = &c.hypothesis;
        let open = Open {
            id,
            robot: Some(c.robot.clone()),
            query_range: h.a_range,
            match_range: h.b_range,
            keyframes: [own, foreign],
        };
        if !self.publish_own(own) {
            self.counts.expired += 1;
            return Some(self.event(
                "expired",
                &open,
                json!({"reason": "own keyframe not published"}),
            ));
        }
        if !self.published.contains(&foreign) {
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
                self.counts.expired += 1;
                return Some(self.event(
                    "expired",
                    &open,
                    json!({"reason": format!("{}'s keyframe not published: {e}", c.robot)}),
                ));
            }
            self.published.insert(foreign);
            self.counts.their_keyframes_published += 1;
        }
        self.submit_open(open, h, (q, m));
        self.counts.submitted += 1;
        None
    }

    fn submit_own(&mut self, id: u64, h: &turnprint::Hypothesis) -> Option<Value> {
        let (q, m) = verified_at(h);
        let keyframes = [self.renderer.snap(q) as u64, self.renderer.snap(m) as u64];
        let open = Open {
            id,
            robot: None,
            query_range: h.a_range,
            match_range: h.b_range,
            keyframes,
        };
        if !(self.publish_own(keyframes[0]) && self.publish_own(keyframes[1])) {
            self.counts.expired += 1;
            return Some(self.event(
                "expired",
                &open,
                json!({"reason": "own keyframe not published"}),
            ));
        }
        self.submit_open(open, h, (q, m));
        self.counts.own_submitted += 1;
        None
    }

    fn poll(&mut self) -> Vec<Value> {
        let outcomes = self.client.poll();
        let mut events = Vec::new();
        for o in outcomes {
            let Some(c) = self.open.remove(&o.id()) else {
                continue;
            };
            match &o {
                Outcome::Confirmed { .. } => self.counts.confirmed += 1,
                Outcome::Rejected { .. } => self.counts.rejected += 1,
                Outcome::Expired { .. } => self.counts.expired += 1,
            }
            let (kind, fields) = verdict(&o);
            events.push(self.event(kind, &c, fields));
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
