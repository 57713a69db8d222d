//! `turnprint stream --verify`: the detector and the visual verifier sidecar
//! end to end.
//!
//! The path is replayed one pose at a time through the online detector. The
//! verifier (`turnprint-verifier`) is started as a separate process and
//! reached over iceoryx2. Keyframes are rendered in the built-in test world
//! (facades along the *true* trajectory, `--truth`) with the camera type of
//! their part of the path, published into shared memory, and every candidate
//! is handed to the verifier with the keyframes on both sides. Each candidate
//! ends as exactly one `confirmed`, `rejected` or `expired` event; the
//! detector never waits for the verifier.
//!
//! The renderer stands in for the robot's camera only: the detector sees the
//! (drifting, unscaled) estimate, the verifier sees images.

use std::collections::{HashMap, HashSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serde_json::{json, Value};

use turnprint::io::{read_trajectory, Format};
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput};
use turnprint::{Error, Result, Trajectory};
use turnprint_ipc::client::{Outcome, VerifierClient};
use turnprint_verifier::camera::CameraModel;

use crate::keyframes::{candidate, ending, start_verifier, verdict, Renderer};

/// Settings of a verified replay.
#[derive(Debug, Clone)]
pub struct VerifyOptions {
    /// The true poses (KITTI-style camera frame, metres); `None`: the input.
    pub truth: Option<PathBuf>,
    /// Camera types assigned along the path, in blocks of equal length.
    pub cameras: Vec<CameraKind>,
    /// Keyframe image size.
    pub width: u32,
    /// Keyframe image height.
    pub height: u32,
    /// One pose in this many is a keyframe.
    pub keyframe_every: usize,
    /// A candidate without a verdict after this long expires.
    pub timeout: Duration,
    /// The verifier binary (default: `turnprint-verifier` beside this one).
    pub verifier: Option<PathBuf>,
    /// Write a figure of the path and the longest confirmed loop here.
    pub plot: Option<PathBuf>,
    /// Keep a drift-corrected path with the confirmed loops and write it here as TUM at the end.
    pub correct: Option<PathBuf>,
    /// The topic to read when the path is a ROS 2 bag (`--topic`).
    pub topic: Option<String>,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        VerifyOptions {
            truth: None,
            cameras: vec![CameraKind::Pinhole, CameraKind::Fisheye, CameraKind::Omni],
            width: 640,
            height: 480,
            keyframe_every: 5,
            timeout: Duration::from_secs(10),
            verifier: None,
            plot: None,
            correct: None,
            topic: None,
        }
    }
}

/// The camera models of the test world.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CameraKind {
    /// Perspective, 90° horizontal field of view.
    Pinhole,
    /// Fish-eye, 190° diagonal.
    Fisheye,
    /// Omnidirectional (unified model, ξ = 0.9), 200° diagonal.
    Omni,
}

impl CameraKind {
    /// Parses `pinhole`, `fisheye` or `omni`.
    pub fn parse(s: &str) -> std::result::Result<CameraKind, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "pinhole" | "perspective" => Ok(CameraKind::Pinhole),
            "fisheye" | "fish-eye" => Ok(CameraKind::Fisheye),
            "omni" | "omnidirectional" => Ok(CameraKind::Omni),
            other => Err(format!("unknown camera '{other}' (pinhole, fisheye, omni)")),
        }
    }

    /// Parses a comma-separated list (`pinhole,fisheye,omni`).
    pub fn parse_list(s: &str) -> std::result::Result<Vec<CameraKind>, String> {
        s.split(',').map(CameraKind::parse).collect()
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            CameraKind::Pinhole => "pinhole",
            CameraKind::Fisheye => "fisheye",
            CameraKind::Omni => "omni",
        }
    }

    /// The model of this camera for images of `w` x `h` pixels.
    pub(crate) fn model(self, w: u32, h: u32) -> CameraModel {
        match self {
            CameraKind::Pinhole => CameraModel::standard_pinhole(w, h, 90f64.to_radians()),
            CameraKind::Fisheye => CameraModel::standard_fisheye(w, h, 190f64.to_radians()),
            CameraKind::Omni => CameraModel::standard_omni(w, h, 0.9, 200f64.to_radians()),
        }
    }
}

/// Counts of a verified replay.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct VerifySummary {
    /// Candidates emitted by the detector.
    pub candidates: u64,
    /// Confirmed by the images.
    pub confirmed: u64,
    /// Rejected by the images.
    pub rejected: u64,
    /// No verdict (timeout, verifier gone or restarted).
    pub expired: u64,
    /// Per camera pairing: [candidates, confirmed, true candidates, true
    /// confirmed, false confirmed], truth by the 10 m criterion.
    pub pairings: std::collections::BTreeMap<String, [u64; 5]>,
    /// Keyframes rendered and published.
    pub keyframes: u64,
    /// Wall time of the replay (seconds).
    pub seconds: f64,
}

/// What the replay remembers of a submitted candidate.
struct Open {
    event: u64,
    query_range: [usize; 2],
    match_range: [usize; 2],
    keyframes: [u64; 2],
    pairing: String,
    truly: Option<bool>,
    hypothesis: turnprint::Hypothesis,
}

/// Replays `path` through the detector with the verifier sidecar, writing
/// JSON Lines to `out`.
pub fn stream_verified(
    path: &Path,
    format: Format,
    config: &OnlineConfig,
    options: &VerifyOptions,
    out: &mut dyn Write,
) -> Result<VerifySummary> {
    let started = Instant::now();
    let input = crate::input::read(path, format, options.topic.as_deref())?;
    let truth = match &options.truth {
        Some(t) => read_trajectory(t, Format::Auto)?,
        None => input.clone(),
    };
    let name = path.display().to_string();
    if input.len() < turnprint::pipeline::prepare::MIN_POSES {
        return Err(Error::input(&name, "too few poses to stream"));
    }
    let renderer =
        Renderer::new(&input, &truth, None, options).map_err(|e| Error::input(&name, e))?;
    let to_truth = renderer.to_truth().to_vec();
    let io_err = |e: std::io::Error| Error::Io {
        path: "<stdout>".into(),
        source: e,
    };
    let (_sidecar, mut client, prefix) = start_verifier(options)?;
    let ready = client.wait_for_verifier(Duration::from_secs(20));
    writeln!(
        out,
        "{}",
        json!({"event": "verifier", "ready": ready, "prefix": prefix, "cameras": options.cameras.iter().map(|c| c.name()).collect::<Vec<_>>()})
    )
    .map_err(io_err)?;

    let detector = Detector::new(config.clone(), Overflow::Block);
    let detector = match options.correct {
        Some(_) => detector.with_correction(
            turnprint::correct::CorrectConfig::default(),
            turnprint::online::correction::LoopInput::Confirmed,
        ),
        None => detector,
    };
    let mut detector = detector;
    let mut summary = VerifySummary::default();
    let mut published: HashSet<u64> = HashSet::new();
    let mut open: HashMap<u64, Open> = HashMap::new();
    let mut best: Option<turnprint::Hypothesis> = None;

    let mut handle = |e: CandidateEvent,
                      client: &mut VerifierClient,
                      out: &mut dyn Write,
                      summary: &mut VerifySummary,
                      open: &mut HashMap<u64, Open>|
     -> Result<()> {
        writeln!(out, "{}", e.to_json()).map_err(io_err)?;
        summary.candidates += 1;
        let h = &e.hypothesis;
        // The middle correspondence, snapped to keyframes.
        let (q, m) = h
            .correspondences
            .get(h.correspondences.len() / 2)
            .copied()
            .unwrap_or((h.a_range[0], h.b_range[0]));
        let (qk, mk) = (renderer.snap(q), renderer.snap(m));
        for k in [qk, mk] {
            if published.insert(k as u64) {
                let (camera, image) = renderer.render(k);
                if client
                    .publish_keyframe(k as u64, renderer.time(k), &camera, &image)
                    .is_ok()
                {
                    summary.keyframes += 1;
                }
            }
        }
        let pairing = pairing_name(renderer.camera_of(qk), renderer.camera_of(mk));
        let truly = truly_revisits(h.a_range, h.b_range, &to_truth, &truth);
        let id = client.submit(candidate(h, [qk as u64, mk as u64], (q, m)));
        let row = summary.pairings.entry(pairing.clone()).or_default();
        row[0] += 1;
        if truly == Some(true) {
            row[2] += 1;
        }
        open.insert(
            id,
            Open {
                event: e.id,
                query_range: h.a_range,
                match_range: h.b_range,
                keyframes: [qk as u64, mk as u64],
                pairing,
                truly,
                hypothesis: h.clone(),
            },
        );
        Ok(())
    };

    for (i, pose) in input.poses.iter().enumerate() {
        detector.push(&PoseInput {
            t: pose.t,
            position: pose.position,
            orientation: pose.orientation,
            keyframe: renderer.is_keyframe(i).then_some(i as u64),
        });
        for e in detector.poll() {
            handle(e, &mut client, out, &mut summary, &mut open)?;
        }
        for o in client.poll() {
            let _confirmed = report(&o, &mut open, &mut summary, &mut best, out).map_err(io_err)?;
            if let Some(h) = _confirmed {
                detector.close_loop(&h);
            }
        }
        for c in detector.poll_corrections() {
            writeln!(out, "{}", c.to_json(false)).map_err(io_err)?;
        }
    }
    let (rest, _, correction) = detector.finish_keeping_correction();
    for e in rest {
        handle(e, &mut client, out, &mut summary, &mut open)?;
    }
    // Every candidate ends: wait for the verdicts (expiry is the client's).
    let deadline = Instant::now() + options.timeout + Duration::from_secs(3);
    while !open.is_empty() && Instant::now() < deadline {
        for o in client.wait(Duration::from_millis(100)) {
            let _confirmed = report(&o, &mut open, &mut summary, &mut best, out).map_err(io_err)?;
            if let (Some(h), Some(c)) = (_confirmed, &correction) {
                c.close_loop(&h);
            }
        }
    }
    let leftovers: Vec<u64> = open.keys().copied().collect();
    for id in leftovers {
        if let Some(c) = open.remove(&id) {
            summary.expired += 1;
            writeln!(
                out,
                "{}",
                ended("expired", &c, json!({"reason": "replay ended"}))
            )
            .map_err(io_err)?;
        }
    }
    if let (Some(file), Some(c)) = (&options.correct, correction) {
        let t0 = Instant::now();
        c.finish().write(&name, file, t0, out)?;
    }
    summary.seconds = started.elapsed().as_secs_f64();
    if let Some(fig) = &options.plot {
        plot_loop(fig, &input, &to_truth, &truth, best.as_ref())?;
    }
    let mut s = serde_json::to_value(&summary).unwrap_or_default();
    if let Some(o) = s.as_object_mut() {
        o.insert("event".into(), json!("summary"));
        o.insert("path".into(), json!(name));
        o.insert("client".into(), json!(format!("{:?}", client.stats())));
    }
    writeln!(out, "{s}").map_err(io_err)?;
    Ok(summary)
}

/// One outcome as a JSON line; counts it. The hypothesis when it is a
/// confirmation.
fn report(
    o: &Outcome,
    open: &mut HashMap<u64, Open>,
    s: &mut VerifySummary,
    best: &mut Option<turnprint::Hypothesis>,
    out: &mut dyn Write,
) -> std::io::Result<Option<turnprint::Hypothesis>> {
    let Some(c) = open.remove(&o.id()) else {
        return Ok(None);
    };
    let confirmed = matches!(o, Outcome::Confirmed { .. }).then(|| c.hypothesis.clone());
    if matches!(o, Outcome::Confirmed { .. })
        && best.as_ref().is_none_or(|b| {
            b.a_range[1] - b.a_range[0] < c.hypothesis.a_range[1] - c.hypothesis.a_range[0]
        })
    {
        *best = Some(c.hypothesis.clone());
    }
    match o {
        Outcome::Confirmed { .. } => {
            s.confirmed += 1;
            let row = s.pairings.entry(c.pairing.clone()).or_default();
            row[1] += 1;
            match c.truly {
                Some(true) => row[3] += 1,
                Some(false) => row[4] += 1,
                None => {}
            }
        }
        Outcome::Rejected { .. } => s.rejected += 1,
        Outcome::Expired { .. } => s.expired += 1,
    }
    let (kind, fields) = verdict(o);
    let line = ended(kind, &c, fields);
    writeln!(out, "{line}")?;
    Ok(confirmed)
}

/// An ending event with the candidate's ranges, keyframes and cameras.
fn ended(kind: &str, c: &Open, extra: Value) -> Value {
    let ranges = [c.query_range, c.match_range];
    let mut v = ending(kind, c.event, ranges, c.keyframes, extra);
    if let Some(o) = v.as_object_mut() {
        o.insert("cameras".into(), json!(c.pairing));
        if let Some(t) = c.truly {
            o.insert("true_revisit".into(), json!(t));
        }
    }
    v
}

fn pairing_name(a: CameraKind, b: CameraKind) -> String {
    let (x, y) = if (a as u8) <= (b as u8) {
        (a, b)
    } else {
        (b, a)
    };
    format!("{}-{}", x.name(), y.name())
}

/// Whether a loop's query part truly revisits its match part: median
/// distance from query poses to the nearest match pose within 10 m, in the
/// truth's metres. `None` when the truth is the input itself is unknown.
fn truly_revisits(
    q: [usize; 2],
    m: [usize; 2],
    to_truth: &[Option<usize>],
    truth: &Trajectory,
) -> Option<bool> {
    let pos = |i: usize| {
        to_truth
            .get(i)
            .copied()
            .flatten()
            .map(|t| truth.poses[t].position)
    };
    let matches: Vec<Vector3<f64>> = (m[0]..=m[1]).filter_map(pos).collect();
    let mut d: Vec<f64> = (q[0]..=q[1])
        .step_by(((q[1] - q[0]) / 50).max(1))
        .filter_map(pos)
        .map(|p| {
            matches
                .iter()
                .map(|x| (x - p).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2] <= 10.0)
}

/// The true path with the longest confirmed loop highlighted: its query
/// part, its match part and their correspondences.
fn plot_loop(
    fig: &Path,
    input: &Trajectory,
    to_truth: &[Option<usize>],
    truth: &Trajectory,
    best: Option<&turnprint::Hypothesis>,
) -> Result<()> {
    let points: Vec<Vector3<f64>> = (0..input.len())
        .map(|i| to_truth[i].map_or(input.poses[i].position, |t| truth.poses[t].position))
        .collect();
    let h = match best {
        Some(h) => turnprint::Hypothesis {
            scale: 1.0,
            rotation: nalgebra::Matrix3::identity(),
            translation: Vector3::zeros(),
            ..h.clone()
        },
        None => turnprint::Hypothesis {
            rank: 0,
            score: 0.0,
            zncc: 0.0,
            reversed: false,
            a_range: [0, 0],
            b_range: [0, 0],
            scale: 1.0,
            rotation: nalgebra::Matrix3::identity(),
            translation: Vector3::zeros(),
            rmse: 0.0,
            turning: 0.0,
            length: 0.0,
            length_ratio: 1.0,
            correspondences: Vec::new(),
        },
    };
    crate::plot::plot_merge(fig, &points, &points, &h)
}
