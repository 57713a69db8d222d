//! iceoryx2 transport between the detector and the visual verifier sidecar:
//! keyframe images in (zero-copy), loop-closure candidates out, verdicts back.
//!
//! The detector embeds a [`VerifierClient`]; the verifier process runs
//! [`server::run`] around any [`FrameVerifier`]. Neither side needs the other
//! to be running: every candidate ends as confirmed, rejected or expired.

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
