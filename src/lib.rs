#![deny(missing_docs)]
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
//!
//! Two robots' paths in their own frames and units, one driven the other
//! way, then the loops of one path, in batch and pose by pose:
//!
//! ```
//! use nalgebra::Vector3;
//! use turnprint::online::synthetic::CityDrive;
//! use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
//! use turnprint::{find_loops, match_paths, Config, Trajectory};
//!
//! // A drive through a street grid that comes back to its own streets.
//! let drive: Vec<Vector3<f64>> = CityDrive::new(7).take(3000).collect();
//! let a = Trajectory::from_positions("a", &drive);
//! // Its second half, three times smaller, turned a quarter, reversed.
//! let mut part: Vec<Vector3<f64>> =
//!     drive[1500..].iter().map(|p| Vector3::new(-p.y, p.x, p.z) / 3.0).collect();
//! part.reverse();
//! let b = Trajectory::from_positions("b", &part);
//!
//! let best = &match_paths(&a, &b, &Config::default())?[0];
//! assert!(best.reversed);
//! assert!((best.scale - 3.0).abs() < 0.05, "scale {}", best.scale);
//!
//! let loops = find_loops(&a, &Config::for_loops())?;
//! assert!(!loops.is_empty());
//!
//! let mut detector = Detector::new(OnlineConfig::default(), Overflow::Block);
//! for p in &drive {
//!     detector.push(&PoseInput::at(*p));
//! }
//! let (candidates, summary) = detector.finish();
//! assert_eq!(summary.accepted, drive.len() as u64);
//! assert!(!candidates.is_empty());
//! # Ok::<(), turnprint::Error>(())
//! ```

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
#[cfg(test)]
mod test_data;
pub mod track;
pub mod trajectory;

pub use error::{Error, Result};
pub use hypothesis::Hypothesis;
pub use pipeline::{find_loops, match_paths, Config};
pub use trajectory::{Pose, Trajectory};
