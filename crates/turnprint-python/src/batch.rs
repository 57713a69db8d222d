//! Whole paths: reading and writing trajectories, matching two paths,
//! finding one path's loops, correcting its drift.

use std::path::PathBuf;
use std::str::FromStr;

use nalgebra::Vector3;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyAttributeError, PyValueError};
use pyo3::prelude::*;
use turnprint::io::Format;
use turnprint::{Config, Pose, Trajectory};

use crate::arrays::{
    orientations, positions, positions_array, rotation_array, times, vector_array,
};
use crate::{error, json};

/// Which search made a hypothesis, and so which names its ranges have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// `match_paths`: `a_range` in path A, `b_range` in path B.
    Match,
    /// `find_loops`: `query_range` (the later part) and `match_range`.
    Loop,
}

/// One ranked hypothesis of `match_paths` or `find_loops`: its attributes
/// are the fields of the command line's JSON (`turnprint match --json`,
/// `turnprint loops --json`), the similarity as numpy arrays.
#[pyclass(frozen, module = "turnprint")]
pub struct Hypothesis {
    inner: turnprint::Hypothesis,
    kind: Kind,
}

impl Hypothesis {
    /// The range named `name`, where this kind of hypothesis has it.
    fn range(&self, name: &str, kind: Kind, range: [usize; 2]) -> PyResult<(usize, usize)> {
        if self.kind != kind {
            let (has, other) = match self.kind {
                Kind::Match => ("a_range and b_range", "find_loops"),
                Kind::Loop => ("query_range and match_range", "match_paths"),
            };
            return Err(PyAttributeError::new_err(format!(
                "this hypothesis has {has}; {name} is a field of {other}'s hypotheses"
            )));
        }
        Ok((range[0], range[1]))
    }

    /// The JSON object of the command line (`loops` entries name the
    /// ranges `query_range` and `match_range`).
    fn json(&self) -> serde_json::Value {
        let mut value = serde_json::to_value(self.inner.to_json()).unwrap_or_default();
        if let (Kind::Loop, Some(fields)) = (self.kind, value.as_object_mut()) {
            for (from, to) in [("a_range", "query_range"), ("b_range", "match_range")] {
                if let Some(v) = fields.remove(from) {
                    fields.insert(to.into(), v);
                }
            }
        }
        value
    }
}

#[pymethods]
impl Hypothesis {
    /// 1-based rank after sorting by score.
    #[getter]
    fn rank(&self) -> usize {
        self.inner.rank
    }

    /// Likelihood of a true overlap, in [0, 1].
    #[getter]
    fn score(&self) -> f64 {
        self.inner.score
    }

    /// ZNCC of the curvature signatures over the matched part.
    #[getter]
    fn zncc(&self) -> f64 {
        self.inner.zncc
    }

    /// True when the two parts are travelled in opposite directions.
    #[getter]
    fn reversed(&self) -> bool {
        self.inner.reversed
    }

    /// `match_paths`: the inclusive pose-index range `(first, last)` in A.
    #[getter]
    fn a_range(&self) -> PyResult<(usize, usize)> {
        self.range("a_range", Kind::Match, self.inner.a_range)
    }

    /// `match_paths`: the inclusive pose-index range `(first, last)` in B.
    #[getter]
    fn b_range(&self) -> PyResult<(usize, usize)> {
        self.range("b_range", Kind::Match, self.inner.b_range)
    }

    /// `find_loops`: the inclusive pose-index range of the later part.
    #[getter]
    fn query_range(&self) -> PyResult<(usize, usize)> {
        self.range("query_range", Kind::Loop, self.inner.a_range)
    }

    /// `find_loops`: the inclusive pose-index range of the earlier part.
    #[getter]
    fn match_range(&self) -> PyResult<(usize, usize)> {
        self.range("match_range", Kind::Loop, self.inner.b_range)
    }

    /// Scale of the similarity `p_A = scale * rotation @ p_B + translation`
    /// (loops: match part onto query part).
    #[getter]
    fn scale(&self) -> f64 {
        self.inner.scale
    }

    /// The similarity's proper rotation, a 3x3 array.
    #[getter]
    fn rotation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rotation_array(py, &self.inner.rotation)
    }

    /// The similarity's translation, a (3,) array.
    #[getter]
    fn translation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_array(py, &self.inner.translation)
    }

    /// RMS distance (A's units) between the transformed part of B and A's.
    #[getter]
    fn rmse(&self) -> f64 {
        self.inner.rmse
    }

    /// Total turning inside the common part (degrees): the evidence.
    #[getter]
    fn turning_deg(&self) -> f64 {
        self.inner.turning.to_degrees()
    }

    /// Matched length along A (A's units).
    #[getter]
    fn length(&self) -> f64 {
        self.inner.length
    }

    /// Maps points of B (loops: of the match part) into A's frame:
    /// `scale * rotation @ p + translation`, `(N, 3)` (or `(N, 2)`) in,
    /// `(N, 3)` out.
    fn transform<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let mapped: Vec<Vector3<f64>> = positions(points, "points")?
            .iter()
            .map(|p| self.inner.transform(p))
            .collect();
        Ok(positions_array(py, &mapped))
    }

    /// The command line's JSON object of this hypothesis, as a dict
    /// (`rotation` as nested lists).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_python(py, &self.json())
    }

    fn __repr__(&self) -> String {
        let h = &self.inner;
        let (first, second) = match self.kind {
            Kind::Match => ("a_range", "b_range"),
            Kind::Loop => ("query_range", "match_range"),
        };
        format!(
            "Hypothesis(rank={}, score={:.4}, {first}=({}, {}), {second}=({}, {}), scale={:.6}, reversed={}, rmse={:.4})",
            h.rank,
            h.score,
            h.a_range[0],
            h.a_range[1],
            h.b_range[0],
            h.b_range[1],
            h.scale,
            if h.reversed { "True" } else { "False" },
            h.rmse
        )
    }
}

/// The hypotheses most asked for, `top` or the search's default.
fn top_k(top: Option<usize>, default: Config) -> PyResult<Config> {
    match top {
        Some(0) => Err(PyValueError::new_err("top must be at least 1 (or None)")),
        Some(k) => Ok(Config {
            top_k: k,
            ..default
        }),
        None => Ok(default),
    }
}

/// A trajectory of bare positions, as the readers make one (no timestamps,
/// no orientations), named `name` in messages.
fn trajectory(points: &Bound<'_, PyAny>, name: &str) -> PyResult<Trajectory> {
    Ok(Trajectory::from_positions(name, &positions(points, name)?))
}

/// Reads a trajectory file: `(positions (N, 3), times (N,) or None,
/// orientations (N, 4) as (qx, qy, qz, qw) or None, source)`. `format` is
/// one of `auto`, `tum`, `kitti`, `euroc`, `xyz`, `gpx`, `csv`.
#[pyfunction]
#[pyo3(signature = (path, format = "auto"))]
#[allow(clippy::type_complexity)]
pub fn read_trajectory_arrays<'py>(
    py: Python<'py>,
    path: PathBuf,
    format: &str,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Option<Bound<'py, PyArray1<f64>>>,
    Option<Bound<'py, PyArray2<f64>>>,
    String,
)> {
    let format = Format::from_str(format).map_err(PyValueError::new_err)?;
    let traj = py
        .detach(|| turnprint::io::read_trajectory(&path, format))
        .map_err(error)?;
    let positions = positions_array(py, &traj.positions());
    // A format has timestamps (orientations) on every line or on none.
    let times = traj.poses.iter().any(|p| p.t.is_some()).then(|| {
        let t: Vec<f64> = traj.poses.iter().map(|p| p.t.unwrap_or(f64::NAN)).collect();
        t.into_pyarray(py)
    });
    let orientations = traj.poses.iter().any(|p| p.orientation.is_some()).then(|| {
        Array2::from_shape_fn((traj.len(), 4), |(i, j)| {
            traj.poses[i]
                .orientation
                .map_or(f64::NAN, |q| [q.i, q.j, q.k, q.w][j])
        })
        .into_pyarray(py)
    });
    Ok((positions, times, orientations, traj.source))
}

/// Where path `b` overlaps path `a`, best first (at most `top`, default 5):
/// `turnprint::match_paths` with `Config::for_matching()`.
#[pyfunction]
#[pyo3(signature = (a, b, top = None))]
pub fn match_paths(
    py: Python<'_>,
    a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
    top: Option<usize>,
) -> PyResult<Vec<Hypothesis>> {
    let config = top_k(top, Config::for_matching())?;
    let (a, b) = (trajectory(a, "a")?, trajectory(b, "b")?);
    let found = py
        .detach(|| turnprint::match_paths(&a, &b, &config))
        .map_err(error)?;
    Ok(found
        .into_iter()
        .map(|inner| Hypothesis {
            inner,
            kind: Kind::Match,
        })
        .collect())
}

/// The places path `points` revisits, best first (at most `top`, default
/// 10): `turnprint::find_loops` with `Config::for_loops()`.
#[pyfunction]
#[pyo3(signature = (points, top = None))]
pub fn find_loops(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    top: Option<usize>,
) -> PyResult<Vec<Hypothesis>> {
    let config = top_k(top, Config::for_loops())?;
    let path = trajectory(points, "points")?;
    let found = py
        .detach(|| turnprint::find_loops(&path, &config))
        .map_err(error)?;
    Ok(found
        .into_iter()
        .map(|inner| Hypothesis {
            inner,
            kind: Kind::Loop,
        })
        .collect())
}

/// The path `points` without the drift its loops reveal, `(N, 3)`, one
/// position per input position: `turnprint::correct::correct` with the
/// default settings (the loops of `find_loops`, a robust pose graph) in the
/// node group `group`: `"auto"`, `"se3"` (metric odometry) or `"sim3"`
/// (monocular).
#[pyfunction]
#[pyo3(signature = (points, times = None, group = "auto"))]
pub fn correct<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    times: Option<&Bound<'py, PyAny>>,
    group: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let path = poses(points, times, None)?;
    let config = turnprint::correct::CorrectConfig {
        group: group.parse().map_err(PyValueError::new_err)?,
        ..Default::default()
    };
    let corrected = py
        .detach(|| turnprint::correct::correct(&path, &config))
        .map_err(error)?;
    let out: Vec<Vector3<f64>> = corrected.poses.iter().map(|p| p.position).collect();
    Ok(positions_array(py, &out))
}

/// A trajectory of positions with optional timestamps and orientations,
/// each pose as the readers make one.
fn poses(
    points: &Bound<'_, PyAny>,
    t: Option<&Bound<'_, PyAny>>,
    q: Option<&Bound<'_, PyAny>>,
) -> PyResult<Trajectory> {
    let xyz = positions(points, "points")?;
    let t = times(t, xyz.len(), "times")?;
    let q = orientations(q, xyz.len(), "orientations")?;
    Ok(Trajectory {
        source: "points".into(),
        poses: xyz
            .iter()
            .enumerate()
            .map(|(i, p)| Pose {
                t: t.as_ref().map(|t| t[i]),
                position: *p,
                orientation: q.as_ref().map(|q| q[i]),
            })
            .collect(),
    })
}

/// Writes positions (and timestamps, else the pose index; orientations
/// `(qx, qy, qz, qw)`, else the identity) as a TUM file, the format of
/// `turnprint merge` and `correct` and the one evo reads.
#[pyfunction]
#[pyo3(signature = (path, points, times = None, orientations = None))]
pub fn write_tum(
    py: Python<'_>,
    path: PathBuf,
    points: &Bound<'_, PyAny>,
    times: Option<&Bound<'_, PyAny>>,
    orientations: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let traj = poses(points, times, orientations)?;
    if let Some(i) = traj
        .poses
        .iter()
        .position(|p| !p.position.iter().all(|v| v.is_finite()) || !p.t.is_none_or(f64::is_finite))
    {
        // TUM text has no way to say NaN that its readers accept.
        return Err(PyValueError::new_err(format!(
            "pose {i} has a non-finite position or timestamp"
        )));
    }
    py.detach(|| turnprint::io::write_tum(&path, &traj))
        .map_err(error)
}

/// `points` as the `(N, 3)` float64 array the other functions read it as
/// (`(N, 2)` gets z = 0); a `ValueError` when it is not one.
#[pyfunction]
pub fn as_points<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    Ok(positions_array(py, &positions(points, "points")?))
}
