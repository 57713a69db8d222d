//! The online detector: push poses one at a time (or an array at once),
//! poll candidates, finish with the last ones and the run's counts.

use std::sync::Mutex;

use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyRuntimeWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use turnprint::online::{
    CandidateEvent, Detector as Online, Exclusion, OnlineConfig, Overflow, PoseInput, Pushed,
};

use crate::arrays::{positions, positions_array, rotation_array, times, vector_array};
use crate::{json, TurnprintError};

/// One loop-closure candidate of the detector: its attributes are the
/// fields of `turnprint stream --json`'s candidate events. The query part
/// is the later one; the similarity maps the match part onto it.
#[pyclass(frozen, module = "turnprint")]
pub struct Candidate {
    event: CandidateEvent,
}

#[pymethods]
impl Candidate {
    /// The candidate's id (increasing).
    #[getter]
    fn id(&self) -> u64 {
        self.event.id
    }

    /// Index of the pose whose arrival produced it.
    #[getter]
    fn at_pose(&self) -> usize {
        self.event.at_pose
    }

    /// Rank among the candidates of its segment (1-based).
    #[getter]
    fn rank(&self) -> usize {
        self.event.hypothesis.rank
    }

    /// Score in [0, 1].
    #[getter]
    fn score(&self) -> f64 {
        self.event.hypothesis.score
    }

    /// ZNCC of the curvature signatures.
    #[getter]
    fn zncc(&self) -> f64 {
        self.event.hypothesis.zncc
    }

    /// True when the two parts are travelled in opposite directions.
    #[getter]
    fn reversed(&self) -> bool {
        self.event.hypothesis.reversed
    }

    /// Inclusive pose-index range `(first, last)` of the later part.
    #[getter]
    fn query_range(&self) -> (usize, usize) {
        let [a, b] = self.event.hypothesis.a_range;
        (a, b)
    }

    /// Inclusive pose-index range `(first, last)` of the earlier part.
    #[getter]
    fn match_range(&self) -> (usize, usize) {
        let [a, b] = self.event.hypothesis.b_range;
        (a, b)
    }

    /// Scale of `p_query = scale * rotation @ p_match + translation`.
    #[getter]
    fn scale(&self) -> f64 {
        self.event.hypothesis.scale
    }

    /// The similarity's rotation, a 3x3 array.
    #[getter]
    fn rotation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rotation_array(py, &self.event.hypothesis.rotation)
    }

    /// The similarity's translation, a (3,) array.
    #[getter]
    fn translation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_array(py, &self.event.hypothesis.translation)
    }

    /// RMS distance between the transformed match part and the query part.
    #[getter]
    fn rmse(&self) -> f64 {
        self.event.hypothesis.rmse
    }

    /// Total turning inside the common part (degrees).
    #[getter]
    fn turning_deg(&self) -> f64 {
        self.event.hypothesis.turning.to_degrees()
    }

    /// Which search found it: `shape`, `proximity`, `drift-probe` or
    /// `network`.
    #[getter]
    fn source(&self) -> &'static str {
        self.event.source.name()
    }

    /// The keyframe pair a verifier should compare, as a dict
    /// (`query_keyframe`, `query_pose`, `match_keyframe`, `match_pose`), or
    /// None when no keyframes were pushed on both parts.
    #[getter]
    fn keyframes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_python(py, &self.event.to_json()["keyframes"])
    }

    /// Keyframe ids inside the query range (at most 8, spread evenly).
    #[getter]
    fn query_keyframes(&self) -> Vec<u64> {
        self.event.query_keyframes.clone()
    }

    /// Keyframe ids inside the match range (at most 8, spread evenly).
    #[getter]
    fn match_keyframes(&self) -> Vec<u64> {
        self.event.match_keyframes.clone()
    }

    /// Maps points of the match part into the query part's frame, `(N, 3)`.
    fn transform<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let mapped: Vec<_> = positions(points, "points")?
            .iter()
            .map(|p| self.event.hypothesis.transform(p))
            .collect();
        Ok(positions_array(py, &mapped))
    }

    /// The JSON object `turnprint stream --json` prints for this candidate,
    /// as a dict (`"event": "candidate"` included).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_python(py, &self.event.to_json())
    }

    fn __repr__(&self) -> String {
        let h = &self.event.hypothesis;
        format!(
            "Candidate(id={}, at_pose={}, source='{}', score={:.4}, query_range=({}, {}), match_range=({}, {}), scale={:.6}, reversed={})",
            self.event.id,
            self.event.at_pose,
            self.event.source.name(),
            h.score,
            h.a_range[0],
            h.a_range[1],
            h.b_range[0],
            h.b_range[1],
            h.scale,
            if h.reversed { "True" } else { "False" }
        )
    }
}

/// The online loop-closure detector (`turnprint::online::Detector`).
///
/// Its guards drop and count the poses it cannot use (a NaN position, a
/// timestamp going back or repeated): `push` then returns False, and
/// `finish`'s summary says how many of each.
#[pyclass(module = "turnprint")]
pub struct Detector {
    /// The detector until `finish` (a Mutex because Python objects must be
    /// shareable between threads; the methods take `&mut self`, so it is
    /// never contended).
    inner: Mutex<Option<Online>>,
}

impl Detector {
    /// The running detector, or a `TurnprintError` once it has finished.
    fn running(&mut self) -> PyResult<&mut Online> {
        self.inner
            .get_mut()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .as_mut()
            .ok_or_else(|| TurnprintError::new_err("this Detector has finished"))
    }
}

/// Why a setting is out of range (the C ABI's rules and messages).
fn invalid(c: &OnlineConfig) -> Option<&'static str> {
    let unit = |x: f64| (0.0..=1.0).contains(&x);
    match c {
        _ if c.top_k == 0 => Some("top_k must be at least 1"),
        _ if !unit(c.min_score) => Some("min_score must be a number in [0, 1]"),
        _ if !unit(c.drift_min_score) => Some("drift_min_score must be a number in [0, 1]"),
        OnlineConfig {
            exclusion: Exclusion::Turning(k),
            ..
        } if !(k.is_finite() && *k > 0.0) => Some(
            "exclusion_turning must be a finite, positive number of radians (0 would let a query match itself)",
        ),
        _ if c.max_verify == 0 => Some("max_verify must be at least 1"),
        _ if c.queue_capacity == 0 => Some("queue_capacity must be at least 1"),
        _ if !(c.jump_factor.is_finite() && c.jump_factor > 1.0) => {
            Some("jump_factor must be a finite number above 1")
        }
        _ if !(1..=OnlineConfig::MAX_WORKERS).contains(&c.workers) => {
            const _: () = assert!(OnlineConfig::MAX_WORKERS == 64);
            Some("workers must be between 1 and 64")
        }
        _ => None,
    }
}

#[pymethods]
impl Detector {
    /// A detector with its matching thread; every setting left out keeps
    /// the library's default (`OnlineConfig::default()`). With
    /// `wait_for_matching`, `push` waits for the matching to keep up (a
    /// replay: the same candidates on every run); without, it never waits
    /// and merges the work behind (live odometry).
    #[new]
    #[pyo3(signature = (
        *,
        top_k = None,
        min_score = None,
        drift_probe = None,
        drift_min_score = None,
        proximity = None,
        exclusion_turning = None,
        max_verify = None,
        queue_capacity = None,
        jump_factor = None,
        workers = None,
        wait_for_matching = false,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        top_k: Option<usize>,
        min_score: Option<f64>,
        drift_probe: Option<bool>,
        drift_min_score: Option<f64>,
        proximity: Option<bool>,
        exclusion_turning: Option<f64>,
        max_verify: Option<usize>,
        queue_capacity: Option<usize>,
        jump_factor: Option<f64>,
        workers: Option<usize>,
        wait_for_matching: bool,
    ) -> PyResult<Self> {
        let d = OnlineConfig::default();
        let config = OnlineConfig {
            top_k: top_k.unwrap_or(d.top_k),
            min_score: min_score.unwrap_or(d.min_score),
            drift_probe: drift_probe.unwrap_or(d.drift_probe),
            drift_min_score: drift_min_score.unwrap_or(d.drift_min_score),
            proximity: proximity.unwrap_or(d.proximity),
            exclusion: exclusion_turning.map_or(d.exclusion, Exclusion::Turning),
            max_verify: max_verify.unwrap_or(d.max_verify),
            queue_capacity: queue_capacity.unwrap_or(d.queue_capacity),
            jump_factor: jump_factor.unwrap_or(d.jump_factor),
            workers: workers.unwrap_or(d.workers),
            ..OnlineConfig::default()
        };
        if let Some(why) = invalid(&config) {
            return Err(PyValueError::new_err(why));
        }
        let overflow = match wait_for_matching {
            true => Overflow::Block,
            false => Overflow::MergeLatest,
        };
        Ok(Detector {
            inner: Mutex::new(Some(Online::new(config, overflow))),
        })
    }

    /// Feeds one pose (timestamp `t` in seconds, if any, must increase;
    /// `keyframe`: this pose's keyframe id, if it is one). Returns True
    /// when it was taken, False when a guard dropped it.
    #[pyo3(signature = (x, y, z = 0.0, t = None, keyframe = None))]
    fn push(
        &mut self,
        py: Python<'_>,
        x: f64,
        y: f64,
        z: f64,
        t: Option<f64>,
        keyframe: Option<u64>,
    ) -> PyResult<bool> {
        let detector = self.running()?;
        let pose = PoseInput {
            t,
            position: nalgebra::Vector3::new(x, y, z),
            orientation: None,
            keyframe,
        };
        // With wait_for_matching a push may wait for the matching thread.
        let pushed = py.detach(|| detector.push(&pose));
        Ok(matches!(pushed, Pushed::Accepted(_)))
    }

    /// Feeds every position of `points` ((N, 3) or (N, 2)), with the
    /// timestamps `times` if given; returns how many were taken. Poll
    /// after it: the candidates wait in the detector meanwhile.
    #[pyo3(signature = (points, times = None))]
    fn push_many(
        &mut self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        times: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        let xyz = positions(points, "points")?;
        let t = self::times(times, xyz.len(), "times")?;
        let detector = self.running()?;
        let accepted = py.detach(|| {
            xyz.iter()
                .enumerate()
                .map(|(i, p)| PoseInput {
                    t: t.as_ref().map(|t| t[i]),
                    ..PoseInput::at(*p)
                })
                .filter(|pose| matches!(detector.push(pose), Pushed::Accepted(_)))
                .count()
        });
        Ok(accepted)
    }

    /// The candidates that arrived since the last call.
    fn poll(&mut self) -> PyResult<Vec<Candidate>> {
        Ok(self
            .running()?
            .poll()
            .into_iter()
            .map(|event| Candidate { event })
            .collect())
    }

    /// Poses pushed so far (taken or dropped).
    #[getter]
    fn poses(&mut self) -> PyResult<usize> {
        Ok(self.running()?.poses())
    }

    /// True once `finish` has been called.
    #[getter]
    fn finished(&mut self) -> bool {
        self.inner
            .get_mut()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .is_none()
    }

    /// Ends the stream: finalises the last segments, waits for the
    /// matching, and returns the remaining candidates and the run's
    /// summary (the dict of `turnprint stream`'s summary line: `poses`,
    /// `accepted`, `candidates`, `guards`, `worker`, timings...). The
    /// detector takes no pose after it.
    fn finish<'py>(&mut self, py: Python<'py>) -> PyResult<(Vec<Candidate>, Bound<'py, PyDict>)> {
        let detector = self
            .inner
            .get_mut()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .take()
            .ok_or_else(|| TurnprintError::new_err("this Detector has finished"))?;
        let (rest, summary) = py.detach(|| detector.finish());
        let mut value = serde_json::to_value(summary).unwrap_or_default();
        if let Some(fields) = value.as_object_mut() {
            fields.insert("candidates".into(), summary.worker.candidates.into());
        }
        let dict = json::to_python(py, &value)?.cast_into::<PyDict>()?;
        if summary.workers_lost > 0 {
            // A bug, not the input: the candidates of the poses after the
            // loss are missing, which the caller must hear of.
            PyErr::warn(
                py,
                &py.get_type::<PyRuntimeWarning>(),
                c"turnprint's matching thread stopped on an internal error; the candidates of the poses after it are missing (summary['workers_lost'])",
                1,
            )?;
        }
        let rest = rest.into_iter().map(|event| Candidate { event }).collect();
        Ok((rest, dict))
    }

    fn __repr__(&mut self) -> String {
        match self.inner.get_mut().unwrap_or_else(|p| p.into_inner()) {
            Some(d) => format!("Detector(poses={})", d.poses()),
            None => "Detector(finished)".into(),
        }
    }
}
