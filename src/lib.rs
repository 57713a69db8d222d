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
//! The online detector reuses the batch stages; the verifier sidecar lives
//! behind the `verifier` feature so the core builds without OpenCV.

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
#[cfg(feature = "plot")]
pub mod plot;
pub mod score;
pub mod segments;
#[cfg(feature = "verifier")]
pub mod sidecar;
pub mod signature;
pub mod track;
pub mod trajectory;

pub use error::{Error, Result};
pub use hypothesis::Hypothesis;
pub use pipeline::{find_loops, match_paths, Config};
pub use trajectory::{Pose, Trajectory};
#[cfg(feature = "eval")]
pub mod eval;
#[cfg(feature = "ipc")]
pub mod ipc;
#[cfg(feature = "render")]
pub mod render;
#[cfg(any(feature = "render", feature = "verifier"))]
pub mod vision;
