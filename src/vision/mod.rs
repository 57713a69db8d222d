//! Visual verification of loop candidates: camera models, ORB features,
//! descriptor matching and relative pose on bearing vectors.
//!
//! `camera` is shared with the renderer (feature `render`); everything that
//! needs OpenCV sits behind the `verifier` feature.

pub mod camera;
#[cfg(feature = "verifier")]
pub mod features;
// `impl FrameVerifier for OrbVerifier` for the verifier sidecar.
#[cfg(feature = "verifier")]
mod frame_verifier;
#[cfg(feature = "verifier")]
pub mod homography;
#[cfg(feature = "verifier")]
pub mod matching;
#[cfg(feature = "verifier")]
pub mod refine;
#[cfg(feature = "verifier")]
pub mod relative_pose;
#[cfg(feature = "verifier")]
pub mod verifier;

pub use camera::CameraModel;
#[cfg(feature = "verifier")]
pub use verifier::{OrbVerifier, Verdict, VerifierParams};
