#![deny(missing_docs)]
//! iceoryx2 transport between the detector and the visual verifier sidecar:
//! keyframe images in (zero-copy), loop-closure candidates out, verdicts back.
//!
//! The detector embeds a [`VerifierClient`]; the verifier process runs
//! [`server::run`] around any [`FrameVerifier`]. Neither side needs the other
//! to be running: every candidate ends as confirmed, rejected or expired.
//!
//! ```no_run
//! use std::time::Duration;
//! use turnprint_ipc::{CameraParams, Candidate, ClientConfig, Outcome, VerifierClient};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // The verifier runs as `turnprint-verifier --prefix robot1`.
//! let mut verifier = VerifierClient::new(ClientConfig::new("robot1"))?;
//! let camera = CameraParams::pinhole(640, 480, 500.0, 500.0, 320.0, 240.0);
//! let image = vec![0u8; 640 * 480]; // GRAY8 rows
//! verifier.publish_keyframe(42, 4.2, &camera, &image)?;
//! verifier.publish_keyframe(7, 0.7, &camera, &image)?;
//! let id = verifier.submit(Candidate::between(42, 7));
//! for outcome in verifier.wait(Duration::from_millis(5)) {
//!     match outcome {
//!         Outcome::Confirmed { match_R_query, inliers, .. } => { /* add the constraint */ }
//!         Outcome::Rejected { reason, .. } => { /* shape matched, images did not */ }
//!         Outcome::Expired { reason, .. } => { /* timeout or verifier gone */ }
//!     }
//! }
//! # let _ = id;
//! # Ok(())
//! # }
//! ```
//!
//! Service layout: [`services`]; message layouts: [`payload`]; the loop's
//! bounds and drop policy: [`server`]; expiry rules: [`client`].

pub mod client;
pub mod payload;
pub mod server;
pub mod services;

pub use client::{Candidate, ClientConfig, ExpiryReason, Outcome, VerifierClient};
pub use payload::{CameraParams, CandidateMsg, KeyframeHeader, VerdictMsg, VerifierStatus};
pub use server::{FrameVerifier, ServerConfig};

/// A failure of the iceoryx2 transport, with the service it concerns.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("ipc: {0}")]
pub struct IpcError(pub String);
