//! numpy arrays in and out: positions, timestamps, orientations, the
//! similarity's rotation and translation.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `obj` as a float64 numpy array of any shape (`numpy.asarray`), or a
/// `ValueError` naming `name` when numpy cannot read it as numbers.
fn float_array<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let py = obj.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = py
        .import("numpy")?
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| {
            PyValueError::new_err(format!("{name} cannot be read as an array of numbers: {e}"))
        })?;
    Ok(array.cast_into::<PyArrayDyn<f64>>()?)
}

/// The positions in `obj`: an `(N, 3)` array-like, or `(N, 2)` with z = 0.
/// Non-finite values pass through: the library names the pose that has one.
pub fn positions(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vector3<f64>>> {
    let array = float_array(obj, name)?;
    let readonly = array.readonly();
    let view = readonly.as_array();
    let shape = view.shape();
    if shape.len() != 2 || !(2..=3).contains(&shape[1]) {
        return Err(PyValueError::new_err(format!(
            "{name} must be an (N, 3) array of positions (or (N, 2), z = 0), not one of shape {}",
            shape_text(shape)
        )));
    }
    Ok(view
        .rows()
        .into_iter()
        .map(|r| Vector3::new(r[0], r[1], r.get(2).copied().unwrap_or(0.0)))
        .collect())
}

/// The timestamps in `obj` (seconds, one per pose of `n`), or `None`.
pub fn times(obj: Option<&Bound<'_, PyAny>>, n: usize, name: &str) -> PyResult<Option<Vec<f64>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let array = float_array(obj, name)?;
    let readonly = array.readonly();
    let view = readonly.as_array();
    if view.shape() != [n] {
        return Err(PyValueError::new_err(format!(
            "{name} must be an (N,) array of {n} timestamps (one per position), not one of shape {}",
            shape_text(view.shape())
        )));
    }
    Ok(Some(view.iter().copied().collect()))
}

/// The orientations in `obj`, `(N, 4)` unit quaternions in TUM's order
/// `(qx, qy, qz, qw)`, or `None`.
pub fn orientations(
    obj: Option<&Bound<'_, PyAny>>,
    n: usize,
    name: &str,
) -> PyResult<Option<Vec<UnitQuaternion<f64>>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let array = float_array(obj, name)?;
    let readonly = array.readonly();
    let view = readonly.as_array();
    if view.shape() != [n, 4] {
        return Err(PyValueError::new_err(format!(
            "{name} must be an (N, 4) array of {n} quaternions (qx, qy, qz, qw), not one of shape {}",
            shape_text(view.shape())
        )));
    }
    view.rows()
        .into_iter()
        .enumerate()
        .map(|(i, q)| {
            let q = Quaternion::new(q[3], q[0], q[1], q[2]);
            // A zero (or NaN) quaternion is no orientation: normalising it
            // would make NaNs the TUM file could not be read back with.
            match q.norm() {
                norm if norm.is_finite() && norm > 1e-6 => Ok(UnitQuaternion::new_normalize(q)),
                _ => Err(PyValueError::new_err(format!(
                    "{name}[{i}] is not an orientation (a zero or non-finite quaternion)"
                ))),
            }
        })
        .collect::<PyResult<Vec<_>>>()
        .map(Some)
}

/// A shape as numpy prints it: `(5,)`, `(4, 7)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Positions as an `(N, 3)` array.
pub fn positions_array<'py>(py: Python<'py>, points: &[Vector3<f64>]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Array2::from_shape_vec((points.len(), 3), flat)
        .expect("3 values per point")
        .into_pyarray(py)
}

/// A rotation as a 3x3 array (row-major, as the JSON's nested rows).
pub fn rotation_array<'py>(py: Python<'py>, r: &Matrix3<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((3, 3), |(i, j)| r[(i, j)]).into_pyarray(py)
}

/// A vector as a `(3,)` array.
pub fn vector_array<'py>(py: Python<'py>, v: &Vector3<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v.as_slice())
}
