//! The IPC server's `FrameVerifier` implemented by [`OrbVerifier`]: a thin
//! adapter from the shared-memory message types to the verifier's own API.
//!
//! Declared in `vision/mod.rs` only once `crate::ipc::server` exists (the two
//! halves of the sidecar are built on separate branches); the field names
//! follow the payload description of the IPC side.

use super::camera::CameraModel;
use super::features::GrayImage;
use super::verifier::OrbVerifier;
use crate::ipc::server::{CandidateMsg, FrameVerifier, KeyframeHeader, VerdictMsg};

impl FrameVerifier for OrbVerifier {
    fn add_keyframe(&mut self, header: &KeyframeHeader, image: &[u8]) -> Result<(), String> {
        let camera = CameraModel::from_params(header.camera.kind, &header.camera.params)
            .map_err(|e| format!("keyframe {}: {e}", header.keyframe_id))?;
        let view = GrayImage { data: image, width: header.camera.width, height: header.camera.height, stride: header.stride };
        OrbVerifier::add_keyframe(self, header.keyframe_id, camera, view)
    }

    fn verify(&mut self, candidate: &CandidateMsg) -> VerdictMsg {
        let verdict = OrbVerifier::verify(self, candidate.query_keyframe_id, candidate.match_keyframe_id);
        let parts = verdict.parts();
        VerdictMsg::new(candidate.candidate_id, parts.confirmed, parts.rotation, parts.translation, parts.inliers, &parts.reason)
    }

    fn memory_bytes(&self) -> usize {
        OrbVerifier::memory_bytes(self)
    }
}
