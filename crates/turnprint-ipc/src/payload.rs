//! The messages that cross process boundaries between the detector and the
//! verifier sidecar: fixed-layout `#[repr(C)]` structs that iceoryx2 places in
//! shared memory as they are, so every field has a fixed size and no pointers.
//!
//! Every message starts with [`IPC_VERSION`]; a receiver drops (and counts)
//! messages of another version instead of misreading them. The iceoryx2 type
//! names carry the version too, so opening a service with an incompatible
//! layout fails at connection time, not at run time.

use iceoryx2::prelude::ZeroCopySend;
use nalgebra::{Matrix3, Vector3};

/// Layout version of every message in this module.
pub const IPC_VERSION: u32 = 1;

/// Camera model codes of [`CameraParams::kind`].
pub mod camera_kind {
    /// Pinhole with radial-tangential distortion: fx, fy, cx, cy, k1, k2, p1, p2.
    pub const PINHOLE: u32 = 0;
    /// OpenCV fisheye (Kannala-Brandt): fx, fy, cx, cy, k1, k2, k3, k4.
    pub const FISHEYE: u32 = 1;
    /// Mei unified omnidirectional: xi, fx, fy, cx, cy, k1, k2, p1, p2.
    pub const OMNI: u32 = 2;
}

/// Pixel format codes of [`KeyframeHeader::pixel_format`].
pub mod pixel_format {
    /// One byte per pixel, grey.
    pub const GRAY8: u32 = 0;
}

/// A camera model and its intrinsics; the meaning of `params` depends on `kind`
/// (see [`camera_kind`]); unused entries are zero.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("turnprint::CameraParams.v1")]
pub struct CameraParams {
    /// One of [`camera_kind`].
    pub kind: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Keeps `params` 8-byte aligned on every platform.
    pub _pad: u32,
    /// Model parameters in the order documented in [`camera_kind`].
    pub params: [f64; 12],
}

impl CameraParams {
    /// A distortion-free pinhole camera.
    pub fn pinhole(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        let mut params = [0.0; 12];
        params[..4].copy_from_slice(&[fx, fy, cx, cy]);
        Self {
            kind: camera_kind::PINHOLE,
            width,
            height,
            _pad: 0,
            params,
        }
    }
}

/// The user header of a keyframe sample; the pixels are the sample's `[u8]`
/// payload, `stride * height` bytes long.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("turnprint::KeyframeHeader.v1")]
pub struct KeyframeHeader {
    /// [`IPC_VERSION`] of the sender.
    pub version: u32,
    /// One of [`pixel_format`].
    pub pixel_format: u32,
    /// The caller's keyframe id, named again by candidates.
    pub keyframe_id: u64,
    /// Per-publisher sequence number, +1 per keyframe: gaps are keyframes the
    /// verifier never saw (dropped by the bounded queue).
    pub seq: u64,
    /// The verifier instance the publisher had heard when it sent this
    /// keyframe (0: none). Only then is the verifier sure it was connected.
    pub verifier_instance: u64,
    /// First `seq` the publisher sent while hearing `verifier_instance`: the
    /// verifier counts gaps from there.
    pub instance_first_seq: u64,
    /// Capture time in seconds (the caller's clock).
    pub timestamp: f64,
    /// Camera model and intrinsics of this image.
    pub camera: CameraParams,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Bytes from one row to the next.
    pub stride: u32,
    /// Keeps the struct size a multiple of 8.
    pub _pad: u32,
}

/// A loop-closure candidate sent to the verifier: two keyframes and the
/// shape-based similarity that proposed them.
///
/// The similarity maps query-side positions into the match side:
/// `p_match = scale * rotation * p_query + translation`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("turnprint::CandidateMsg.v1")]
pub struct CandidateMsg {
    /// [`IPC_VERSION`] of the sender.
    pub version: u32,
    /// Keeps the following fields 8-byte aligned.
    pub _pad: u32,
    /// Unique per client (high 32 bits: client tag, low 32 bits: counter).
    pub candidate_id: u64,
    /// Keyframe on the query side (the newer place).
    pub query_keyframe: u64,
    /// Keyframe on the match side (the earlier place or the other map).
    pub match_keyframe: u64,
    /// Pose index of the query keyframe in the caller's trajectory.
    pub query_pose: u64,
    /// Pose index of the match keyframe in the caller's trajectory.
    pub match_pose: u64,
    /// Similarity hint: scale.
    pub scale: f64,
    /// Similarity hint: rotation, row-major.
    pub rotation: [[f64; 3]; 3],
    /// Similarity hint: translation.
    pub translation: [f64; 3],
    /// Shape score of the hypothesis (higher is better).
    pub score: f64,
}

/// Verdict status codes of [`VerdictMsg::status`].
pub mod status {
    /// The images agree on a consistent relative pose.
    pub const CONFIRMED: u32 = 1;
    /// The images do not support the candidate (see the reason).
    pub const REJECTED: u32 = 2;
}

/// Reason codes of [`VerdictMsg::reason_code`].
pub mod reason {
    /// Confirmed: no reason needed.
    pub const NONE: u32 = 0;
    /// A keyframe named by the candidate was never received or was evicted.
    pub const UNKNOWN_KEYFRAME: u32 = 1;
    /// Too few feature matches between the two images.
    pub const TOO_FEW_MATCHES: u32 = 2;
    /// A relative pose was found but with too few inliers.
    pub const TOO_FEW_INLIERS: u32 = 3;
    /// The geometry is degenerate or inconsistent.
    pub const INCONSISTENT_GEOMETRY: u32 = 4;
    /// The candidate message could not be used (version, values).
    pub const BAD_CANDIDATE: u32 = 5;
    /// The verifier failed internally.
    pub const INTERNAL_ERROR: u32 = 6;
    /// The verifier is shutting down and will not decide this candidate.
    pub const SHUTTING_DOWN: u32 = 7;
}

/// Bytes of [`VerdictMsg::reason_text`].
pub const REASON_LEN: usize = 64;

/// The verifier's answer to one candidate.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("turnprint::VerdictMsg.v1")]
pub struct VerdictMsg {
    /// [`IPC_VERSION`] of the sender.
    pub version: u32,
    /// One of [`status`].
    pub status: u32,
    /// The candidate this verdict decides.
    pub candidate_id: u64,
    /// The verifier process instance that decided (changes on restart).
    pub instance: u64,
    /// Relative rotation `match_R_query` (maps query-camera bearings into the
    /// match camera), row-major.
    pub rotation: [[f64; 3]; 3],
    /// `match_t_query`: the query camera's centre seen from the match camera,
    /// unit length (images carry no scale); zero for a pure rotation.
    pub translation: [f64; 3],
    /// Geometric inliers supporting the pose.
    pub inliers: u32,
    /// One of [`reason`].
    pub reason_code: u32,
    /// Human-readable reason, NUL-padded UTF-8.
    pub reason_text: [u8; REASON_LEN],
}

impl Default for VerdictMsg {
    fn default() -> Self {
        Self {
            version: IPC_VERSION,
            status: status::REJECTED,
            candidate_id: 0,
            instance: 0,
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.0; 3],
            inliers: 0,
            reason_code: reason::NONE,
            reason_text: [0; REASON_LEN],
        }
    }
}

impl VerdictMsg {
    /// A confirmed verdict with relative pose `match_R_query`, translation
    /// direction `match_t_query` (normalised here) and its inlier count.
    #[allow(non_snake_case)]
    pub fn confirmed(
        candidate_id: u64,
        match_R_query: &Matrix3<f64>,
        match_t_query: &Vector3<f64>,
        inliers: u32,
    ) -> Self {
        let norm = match_t_query.norm();
        let t = if norm > 0.0 {
            match_t_query / norm
        } else {
            *match_t_query
        };
        Self {
            status: status::CONFIRMED,
            candidate_id,
            rotation: matrix_to_rows(match_R_query),
            translation: [t.x, t.y, t.z],
            inliers,
            ..Self::default()
        }
    }

    /// A rejected verdict with one of the [`reason`] codes and a short text
    /// (cut to [`REASON_LEN`] bytes at a character boundary).
    pub fn rejected(candidate_id: u64, reason_code: u32, text: &str, inliers: u32) -> Self {
        let mut v = Self {
            status: status::REJECTED,
            candidate_id,
            inliers,
            reason_code,
            ..Self::default()
        };
        v.set_reason_text(text);
        v
    }

    /// Stores `text` in `reason_text`, cut at a character boundary to fit.
    pub fn set_reason_text(&mut self, text: &str) {
        let mut end = text.len().min(REASON_LEN);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        self.reason_text = [0; REASON_LEN];
        self.reason_text[..end].copy_from_slice(&text.as_bytes()[..end]);
    }

    /// The reason text up to the first NUL (lossy if not UTF-8).
    pub fn reason_text(&self) -> String {
        let end = self
            .reason_text
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(REASON_LEN);
        String::from_utf8_lossy(&self.reason_text[..end]).into_owned()
    }

    /// The relative rotation as a matrix.
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        rows_to_matrix(&self.rotation)
    }
}

/// The verifier's periodic liveness and statistics message.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("turnprint::VerifierStatus.v1")]
pub struct VerifierStatus {
    /// [`IPC_VERSION`] of the sender.
    pub version: u32,
    /// Keeps the following fields 8-byte aligned.
    pub _pad: u32,
    /// Random id of this verifier process; a new value means a restart.
    pub instance: u64,
    /// Heartbeat counter of this instance.
    pub seq: u64,
    /// Keyframes taken from the queue.
    pub keyframes_received: u64,
    /// Keyframes whose features are now held.
    pub keyframes_added: u64,
    /// Keyframes overwritten in the bounded queue before the verifier read
    /// them (gaps in the publishers' sequence numbers).
    pub keyframes_dropped_queue: u64,
    /// Keyframes refused because the memory cap was reached.
    pub keyframes_dropped_memory: u64,
    /// Keyframes the vision code could not use (bad image, no features).
    pub keyframes_failed: u64,
    /// Old keyframes evicted to stay under the memory cap.
    pub keyframes_evicted: u64,
    /// Candidates received.
    pub candidates_received: u64,
    /// Verdicts sent.
    pub verdicts_sent: u64,
    /// Messages dropped for a wrong version.
    pub bad_messages: u64,
    /// Bytes the vision code holds now.
    pub memory_bytes: u64,
    /// The memory cap in bytes.
    pub max_memory_bytes: u64,
}

/// A nalgebra matrix as row-major arrays.
pub fn matrix_to_rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

/// Row-major arrays as a nalgebra matrix.
pub fn rows_to_matrix(r: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| r[i][j])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reason_text_is_cut_at_a_char_boundary() {
        let long = "é".repeat(40); // 80 bytes
        let v = VerdictMsg::rejected(7, reason::TOO_FEW_INLIERS, &long, 3);
        let text = v.reason_text();
        assert_eq!(text, "é".repeat(32));
        assert_eq!(v.candidate_id, 7);
        assert_eq!(v.status, status::REJECTED);
    }

    #[test]
    fn confirmed_normalises_translation() {
        let v = VerdictMsg::confirmed(1, &Matrix3::identity(), &Vector3::new(0.0, 3.0, 4.0), 50);
        assert!((v.translation[1] - 0.6).abs() < 1e-12 && (v.translation[2] - 0.8).abs() < 1e-12);
        assert_eq!(v.rotation_matrix(), Matrix3::identity());
    }
}
