//! turnprint finds where robot paths overlap by the shape of their turns, with
//! no knowledge of scale, frame or direction of travel.
//!
//! The modules mirror the data flow of `DESIGN.md`:
//!
//! ```text
//! io -> geometry::plane -> track -> signature -> segments
//!    -> matching (ZNCC) -> align (RANSAC, grow, refit) -> hypotheses
//!    -> pipeline (match / loops / merge)   online (one pose at a time)
//!    -> correct (pose graph: odometry + loops -> path without drift)
//! ```
//!
//! The online detector reuses the batch stages. This crate is the core an
//! embedding user links; the heavy parts are crates of their own:
//! `turnprint-cli` (the `turnprint` command, figures), `turnprint-ipc`
//! (iceoryx2 link to a verifier), `turnprint-verifier` (OpenCV verifier
//! sidecar, rendered test world) and `turnprint-eval` (the evaluation).
//! Drift correction (`correct`) is the feature `correct`, since its solver
//! brings a few hundred crates.

pub mod align;
#[cfg(feature = "correct")]
pub mod correct;
pub mod error;
pub mod geometry;
pub mod hypothesis;
pub mod io;
pub mod matching;
pub mod online;
pub mod parallel;
pub mod pipeline;
pub mod score;
pub mod segments;
pub mod signature;
pub mod track;
pub mod trajectory;

pub use error::{Error, Result};
pub use hypothesis::Hypothesis;
pub use pipeline::{find_loops, match_paths, Config};
pub use trajectory::{Pose, Trajectory};
