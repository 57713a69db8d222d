//! The IPC server's [`FrameVerifier`] implemented by [`OrbVerifier`]: a thin
//! adapter from the shared-memory message types to the verifier's own API.
//!
//! The pose conventions agree: `OrbVerifier::verify(query, match)` returns
//! `match_T_query` (rotation `match_R_query`, unit `match_t_query`), which is
//! what [`VerdictMsg`] carries.

use super::camera::CameraModel;
use super::features::GrayImage;
use super::verifier::OrbVerifier;
use turnprint_ipc::payload::{reason, CandidateMsg, KeyframeHeader, VerdictMsg};
use turnprint_ipc::server::FrameVerifier;

impl FrameVerifier for OrbVerifier {
    fn add_keyframe(&mut self, header: &KeyframeHeader, image: &[u8]) -> Result<(), String> {
        let camera = CameraModel::from_params(header.camera.kind, &header.camera.params)
            .map_err(|e| format!("keyframe {}: {e}", header.keyframe_id))?;
        let view = GrayImage {
            data: image,
            width: header.width,
            height: header.height,
            stride: header.stride,
        };
        OrbVerifier::add_keyframe(self, header.keyframe_id, camera, view)
    }

    fn verify(&mut self, candidate: &CandidateMsg) -> VerdictMsg {
        let id = candidate.candidate_id;
        for kf in [candidate.query_keyframe, candidate.match_keyframe] {
            if self.features(kf).is_none() {
                let text = format!("keyframe {kf} unknown (never received or evicted)");
                return VerdictMsg::rejected(id, reason::UNKNOWN_KEYFRAME, &text, 0);
            }
        }
        let verdict = OrbVerifier::verify(self, candidate.query_keyframe, candidate.match_keyframe);
        let inliers = verdict.inliers.min(u32::MAX as usize) as u32;
        match &verdict.pose {
            Some(pose) => VerdictMsg::confirmed(id, pose.b_R_a.matrix(), &pose.b_t_a, inliers),
            None => {
                // Fewer than 8 matches cannot even fit a model.
                let code = if verdict.matches < 8 {
                    reason::TOO_FEW_MATCHES
                } else if inliers < self.params().pose.min_inliers as u32 {
                    reason::TOO_FEW_INLIERS
                } else {
                    reason::INCONSISTENT_GEOMETRY
                };
                VerdictMsg::rejected(id, code, &verdict.reason, inliers)
            }
        }
    }

    fn take_evicted(&mut self) -> u64 {
        OrbVerifier::take_evicted(self)
    }

    fn memory_bytes(&self) -> usize {
        OrbVerifier::memory_bytes(self)
    }
}
