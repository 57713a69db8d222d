#![deny(missing_docs)]
//! Visual verification of loop candidates: camera models, ORB features,
//! descriptor matching and relative pose on bearing vectors.
//!
//! `camera` is shared with the renderer ([`render`], the ray-cast test
//! world); everything that needs OpenCV sits behind the `opencv` feature
//! (default), which also builds the `turnprint-verifier` sidecar binary.

pub mod camera;
#[cfg(feature = "opencv")]
pub mod features;
pub mod render;
// `impl FrameVerifier for OrbVerifier` for the verifier sidecar.
#[cfg(feature = "opencv")]
mod frame_verifier;
#[cfg(feature = "opencv")]
pub mod homography;
#[cfg(feature = "opencv")]
pub mod matching;
#[cfg(feature = "opencv")]
pub mod refine;
#[cfg(feature = "opencv")]
pub mod relative_pose;
#[cfg(feature = "opencv")]
pub mod verifier;

pub use camera::CameraModel;
#[cfg(feature = "opencv")]
pub use verifier::{OrbVerifier, Verdict, VerifierParams};
