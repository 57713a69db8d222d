//! Keyframes of a replay and the verifier that compares them: the renderer
//! that stands in for a robot's camera (the built-in test world, seen from
//! the true poses) and the verifier sidecar process with its client. Shared
//! by `stream --verify` ([`crate::sidecar`]) and `stream --fleet --verify`
//! ([`crate::fleet_verify`]).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use nalgebra::Isometry3;

use serde_json::{json, Value};
use turnprint::{Error, Result, Trajectory};
use turnprint_ipc::client::{Candidate, ClientConfig, Outcome, VerifierClient};
use turnprint_ipc::payload::CameraParams;
use turnprint_verifier::render::{camera_poses, on_road, render, World, WorldParams};

use crate::sidecar::{CameraKind, VerifyOptions};

/// The keyframes of one path: which poses are keyframes, with which
/// camera, and the image each sees in the test world.
pub struct Renderer {
    world: World,
    camera_poses: Vec<Isometry3<f64>>,
    /// The truth index of each input pose.
    to_truth: Vec<Option<usize>>,
    /// Time stamp of each input pose (its index where it has none).
    times: Vec<f64>,
    cameras: Vec<CameraKind>,
    width: u32,
    height: u32,
    every: usize,
}

impl Renderer {
    /// The keyframes of `input` seen from `truth` (paired by time stamp or
    /// order) in the world built along `world` (default: the truth).
    pub fn new(
        input: &Trajectory,
        truth: &Trajectory,
        world: Option<&Trajectory>,
        options: &VerifyOptions,
    ) -> std::result::Result<Renderer, String> {
        if options.cameras.is_empty() {
            return Err("--cameras names no camera".into());
        }
        let along = world.unwrap_or(truth).positions();
        let world = World::from_positions(&along, WorldParams::default())
            .map_err(|e| format!("test world: {e}"))?;
        Ok(Renderer {
            world,
            camera_poses: camera_poses(truth),
            to_truth: pair_with_truth(input, truth),
            times: (0..input.len())
                .map(|i| input.poses[i].t.unwrap_or(i as f64))
                .collect(),
            cameras: options.cameras.clone(),
            width: options.width,
            height: options.height,
            every: options.keyframe_every.max(1),
        })
    }

    /// Poses of the path.
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Whether the path has no pose.
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// The truth index of each input pose.
    pub fn to_truth(&self) -> &[Option<usize>] {
        &self.to_truth
    }

    /// The keyframe nearest pose `pose` (one pose in `keyframe_every`).
    pub fn snap(&self, pose: usize) -> usize {
        ((pose + self.every / 2) / self.every * self.every).min(self.len().saturating_sub(1))
    }

    /// Whether pose `pose` is a keyframe.
    pub fn is_keyframe(&self, pose: usize) -> bool {
        pose.is_multiple_of(self.every)
    }

    /// The camera of pose `pose`: the cameras take equal blocks of the path.
    pub fn camera_of(&self, pose: usize) -> CameraKind {
        let n = self.len().max(1);
        self.cameras[(pose * self.cameras.len() / n).min(self.cameras.len() - 1)]
    }

    /// Time stamp of pose `pose`.
    pub fn time(&self, pose: usize) -> f64 {
        self.times.get(pose).copied().unwrap_or(pose as f64)
    }

    /// The camera and grey image of keyframe `k` (black where the pose has
    /// no true pose).
    pub fn render(&self, k: usize) -> (CameraParams, Vec<u8>) {
        let kind = self.camera_of(k);
        let model = kind.model(self.width, self.height);
        let (code, params) = model.to_params();
        let camera = CameraParams {
            kind: code,
            width: self.width,
            height: self.height,
            _pad: 0,
            params,
        };
        let pose = self
            .to_truth
            .get(k)
            .copied()
            .flatten()
            .map(|t| on_road(&self.camera_poses[t]));
        let image = match pose {
            Some(p) => render(&self.world, &model, p, self.width, self.height),
            None => vec![0u8; (self.width * self.height) as usize],
        };
        (camera, image)
    }
}

/// The verifier sidecar process, ended on drop.
pub struct Sidecar(Child);

impl Drop for Sidecar {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts the verifier sidecar under a prefix of its own and connects to
/// it: the process, its client and the prefix.
pub fn start_verifier(options: &VerifyOptions) -> Result<(Sidecar, VerifierClient, String)> {
    let started = Instant::now();
    let prefix = format!(
        "stream-{}-{}",
        std::process::id(),
        started.elapsed().as_nanos() ^ Instant::now().elapsed().as_nanos()
    );
    let exe = options.verifier.clone().unwrap_or_else(verifier_beside_me);
    let sidecar = Command::new(&exe)
        .args(["--prefix", &prefix, "--report-secs", "0"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map(Sidecar)
        .map_err(|e| {
            Error::input(
                exe.display().to_string(),
                format!("cannot start the verifier: {e}"),
            )
        })?;
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    let client = VerifierClient::new(ClientConfig {
        timeout: options.timeout,
        liveness_timeout: Duration::from_secs(2),
        max_image_bytes: (options.width * options.height) as usize,
        ..ClientConfig::new(prefix.clone())
    })
    .map_err(|e| Error::input("iceoryx2", e.to_string()))?;
    Ok((sidecar, client, prefix))
}

/// The verifier's candidate of hypothesis `h` at `keyframes`, its
/// correspondence `poses` (query, match) between them.
pub fn candidate(
    h: &turnprint::Hypothesis,
    keyframes: [u64; 2],
    poses: (usize, usize),
) -> Candidate {
    Candidate {
        query_keyframe: keyframes[0],
        match_keyframe: keyframes[1],
        query_pose: poses.0 as u64,
        match_pose: poses.1 as u64,
        scale: h.scale,
        rotation: h.rotation,
        translation: h.translation,
        score: h.score,
    }
}

/// An ending event (`confirmed`, `rejected` or `expired`) of candidate
/// `id`: its ranges and keyframes, then the fields of `extra`.
pub fn ending(
    kind: &str,
    id: u64,
    ranges: [[usize; 2]; 2],
    keyframes: [u64; 2],
    extra: Value,
) -> Value {
    let mut v = json!({
        "event": kind,
        "id": id,
        "query_range": ranges[0],
        "match_range": ranges[1],
        "query_keyframe": keyframes[0],
        "match_keyframe": keyframes[1],
    });
    if let (Some(o), Value::Object(e)) = (v.as_object_mut(), extra) {
        o.extend(e);
    }
    v
}

/// The ending event's kind and fields of a verifier's outcome: `confirmed`
/// with the inliers and the relative pose, `rejected` with the reason and
/// the inliers, `expired` with the reason.
pub fn verdict(o: &Outcome) -> (&'static str, Value) {
    match o {
        Outcome::Confirmed {
            match_R_query: r,
            match_t_query: t,
            inliers,
            ..
        } => (
            "confirmed",
            json!({
                "inliers": inliers,
                "relative_pose": {
                    "match_R_query": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
                    "match_t_query": [t.x, t.y, t.z],
                },
            }),
        ),
        Outcome::Rejected {
            reason, inliers, ..
        } => ("rejected", json!({"reason": reason, "inliers": inliers})),
        Outcome::Expired { reason, .. } => ("expired", json!({"reason": format!("{reason:?}")})),
    }
}

/// The truth index of each input pose: by timestamp when both have them
/// (nearest within 50 ms), otherwise by order.
pub fn pair_with_truth(input: &Trajectory, truth: &Trajectory) -> Vec<Option<usize>> {
    let times: Option<Vec<f64>> = truth.poses.iter().map(|p| p.t).collect();
    match times {
        Some(tt) if input.poses.iter().all(|p| p.t.is_some()) && !tt.is_empty() => input
            .poses
            .iter()
            .map(|p| {
                let t = p.t.unwrap_or_default();
                let k = tt.partition_point(|&x| x < t);
                [k.saturating_sub(1), k.min(tt.len() - 1)]
                    .into_iter()
                    .min_by(|&a, &b| (tt[a] - t).abs().total_cmp(&(tt[b] - t).abs()))
                    .filter(|&j| (tt[j] - t).abs() < 0.05)
            })
            .collect(),
        _ => (0..input.len())
            .map(|i| (i < truth.len()).then_some(i))
            .collect(),
    }
}

/// `turnprint-verifier` in the directory of the running executable (or, for
/// tests and examples, its parent: `target/release/deps/..`).
fn verifier_beside_me() -> PathBuf {
    let me = std::env::current_exe().unwrap_or_default();
    let dir = me.parent().map(Path::to_path_buf).unwrap_or_default();
    for d in [
        dir.clone(),
        dir.parent().map(Path::to_path_buf).unwrap_or_default(),
    ] {
        let candidate = d.join("turnprint-verifier");
        if candidate.exists() {
            return candidate;
        }
    }
    dir.join("turnprint-verifier")
}
