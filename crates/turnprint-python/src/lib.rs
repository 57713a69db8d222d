//! turnprint from Python: the extension module `turnprint._turnprint`,
//! which the package `python/turnprint` re-exports.
//!
//! Paths come in as anything numpy reads as an `(N, 3)` (or `(N, 2)`, z = 0)
//! float64 array and go out as numpy arrays. Every input is checked here
//! before it reaches the library, so that a bad array ends as a Python
//! exception (`ValueError` for an array of the wrong shape, `TurnprintError`
//! with the library's message for a path it cannot use), never as a panic.
//! The long calls (matching, loop search, correction, a detector's push and
//! finish) run with the Python thread state detached, so that other Python
//! threads go on meanwhile.

mod arrays;
mod batch;
mod detector;
mod json;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    turnprint,
    TurnprintError,
    PyException,
    "A call of turnprint failed on its input (a file it cannot read, a path \
     too short or with a non-finite pose, one that does not move, a setting \
     out of range); the message is the library's."
);

/// The library's error as a Python [`TurnprintError`], with its message.
pub(crate) fn error(e: turnprint::Error) -> PyErr {
    TurnprintError::new_err(e.to_string())
}

/// The module: functions of `batch`, the classes of `batch` and `detector`.
#[pymodule]
fn _turnprint(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("TurnprintError", m.py().get_type::<TurnprintError>())?;
    m.add_class::<batch::Hypothesis>()?;
    m.add_class::<detector::Candidate>()?;
    m.add_class::<detector::Detector>()?;
    m.add_function(wrap_pyfunction!(batch::read_trajectory_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(batch::match_paths, m)?)?;
    m.add_function(wrap_pyfunction!(batch::find_loops, m)?)?;
    m.add_function(wrap_pyfunction!(batch::correct, m)?)?;
    m.add_function(wrap_pyfunction!(batch::write_tum, m)?)?;
    m.add_function(wrap_pyfunction!(batch::as_points, m)?)?;
    Ok(())
}
