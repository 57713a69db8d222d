//! The link to the visual verifier sidecar (`tp_verifier_*`): keyframes
//! published and candidates submitted over iceoryx2 through
//! [`VerifierClient`], verdicts polled. Every submitted candidate ends in
//! exactly one verdict; the client, not the caller, tracks timeouts and a
//! verifier that dies or restarts.

use std::collections::VecDeque;
use std::ffi::{c_char, c_int, CStr};
use std::time::Duration;

use nalgebra::{Matrix3, Vector3};
use turnprint::online::events::KeyframePair;
use turnprint::online::{CandidateEvent, Source};
use turnprint::Hypothesis;
use turnprint_ipc::{CameraParams, ClientConfig, Outcome, VerifierClient};

use crate::{
    free_handle, guarded, hand_over, row_major, set_error, TpCandidate, TP_ACCEPTED, TP_ERROR,
};

/// A camera (`tp_camera`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TpCamera {
    /// `TP_CAMERA_*`.
    pub kind: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Model parameters (see the header).
    pub params: [f64; 12],
}

/// A verdict (`tp_verdict`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_snake_case)]
pub struct TpVerdict {
    /// Id from `tp_verifier_submit`.
    pub id: u64,
    /// `TP_CONFIRMED`, `TP_REJECTED` or `TP_EXPIRED`.
    pub outcome: c_int,
    /// Inliers.
    pub inliers: u32,
    /// Query keyframe of the candidate.
    pub query_keyframe: i64,
    /// Match keyframe of the candidate.
    pub match_keyframe: i64,
    /// Rotation query camera -> match camera, row-major.
    pub match_R_query: [f64; 9],
    /// Query camera centre seen from the match camera, unit length.
    pub match_t_query: [f64; 3],
    /// Why (rejected, expired), NUL-terminated.
    pub reason: [c_char; 64],
}

/// The link behind a `tp_verifier *`.
pub struct TpVerifier {
    client: VerifierClient,
    waiting: VecDeque<Outcome>,
}

/// Connects to the verifier's services under `prefix`.
///
/// # Safety
/// `prefix` is NULL or a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn tp_verifier_connect(
    prefix: *const c_char,
    timeout_s: f64,
) -> *mut TpVerifier {
    guarded("tp_verifier_connect", std::ptr::null_mut(), || {
        if prefix.is_null() {
            set_error("tp_verifier_connect: prefix is NULL");
            return std::ptr::null_mut();
        }
        // SAFETY: a NUL-terminated string, as the caller promises.
        let Ok(prefix) = unsafe { CStr::from_ptr(prefix) }.to_str() else {
            set_error("tp_verifier_connect: prefix is not UTF-8");
            return std::ptr::null_mut();
        };
        let Ok(timeout) = Duration::try_from_secs_f64(timeout_s) else {
            set_error("tp_verifier_connect: timeout_s must be a number of seconds >= 0");
            return std::ptr::null_mut();
        };
        // A library in someone else's process: iceoryx2's warnings (no
        // config file, and so on) are not the caller's business.
        iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
        let config = ClientConfig {
            timeout,
            ..ClientConfig::new(prefix)
        };
        match VerifierClient::new(config) {
            Ok(client) => Box::into_raw(Box::new(TpVerifier {
                client,
                waiting: VecDeque::new(),
            })),
            Err(e) => {
                set_error(&format!("tp_verifier_connect: {}", e.0));
                std::ptr::null_mut()
            }
        }
    })
}

/// Waits up to `seconds` for the verifier's heartbeat.
///
/// # Safety
/// `verifier` is NULL or came from `tp_verifier_connect` and was not freed.
#[no_mangle]
pub unsafe extern "C" fn tp_verifier_wait(verifier: *mut TpVerifier, seconds: f64) -> c_int {
    guarded("tp_verifier_wait", TP_ERROR, || {
        // SAFETY: NULL or valid, as the caller promises.
        let Some(v) = (unsafe { verifier.as_mut() }) else {
            set_error("tp_verifier_wait: verifier is NULL");
            return TP_ERROR;
        };
        let wait = Duration::try_from_secs_f64(seconds).unwrap_or_default();
        v.client.wait_for_verifier(wait) as c_int
    })
}

/// Publishes a grey keyframe of `camera.height` rows of `stride` bytes.
///
/// # Safety
/// `verifier` as for `tp_verifier_wait`; `camera` NULL or readable; `gray`
/// NULL or `stride * camera->height` readable bytes.
#[no_mangle]
pub unsafe extern "C" fn tp_verifier_publish_keyframe(
    verifier: *mut TpVerifier,
    keyframe: i64,
    t: f64,
    camera: *const TpCamera,
    gray: *const u8,
    stride: usize,
) -> c_int {
    guarded("tp_verifier_publish_keyframe", TP_ERROR, || {
        // SAFETY: NULL or valid, as the caller promises.
        let (Some(v), Some(camera)) = (unsafe { verifier.as_mut() }, unsafe { camera.as_ref() })
        else {
            set_error("tp_verifier_publish_keyframe: verifier or camera is NULL");
            return TP_ERROR;
        };
        let Ok(keyframe) = u64::try_from(keyframe) else {
            set_error("tp_verifier_publish_keyframe: keyframe ids are >= 0");
            return TP_ERROR;
        };
        if gray.is_null() || stride < camera.width as usize || camera.height == 0 {
            set_error("tp_verifier_publish_keyframe: no pixels, or stride below the width");
            return TP_ERROR;
        }
        // SAFETY: `stride * height` readable bytes, as the caller promises.
        let image = unsafe { std::slice::from_raw_parts(gray, stride * camera.height as usize) };
        let params = CameraParams {
            kind: camera.kind,
            width: camera.width,
            height: camera.height,
            _pad: 0,
            params: camera.params,
        };
        match v.client.publish_keyframe(keyframe, t, &params, image) {
            Ok(()) => TP_ACCEPTED,
            Err(e) => {
                set_error(&format!("tp_verifier_publish_keyframe: {}", e.0));
                TP_ERROR
            }
        }
    })
}

/// Submits a detector candidate; returns its verdict id (0: an error; the
/// client's ids are never 0).
///
/// # Safety
/// `verifier` as for `tp_verifier_wait`; `candidate` NULL or readable.
#[no_mangle]
pub unsafe extern "C" fn tp_verifier_submit(
    verifier: *mut TpVerifier,
    candidate: *const TpCandidate,
) -> u64 {
    guarded("tp_verifier_submit", 0, || {
        // SAFETY: NULL or valid, as the caller promises.
        let (Some(v), Some(c)) = (unsafe { verifier.as_mut() }, unsafe { candidate.as_ref() })
        else {
            set_error("tp_verifier_submit: verifier or candidate is NULL");
            return 0;
        };
        let Some(hint) = turnprint_ipc::Candidate::from_event(&event_of(c)) else {
            set_error("tp_verifier_submit: the candidate names no keyframes (push keyframe ids)");
            return 0;
        };
        v.client.submit(hint)
    })
}

/// Copies up to `capacity` verdicts into `out`.
///
/// # Safety
/// `verifier` as for `tp_verifier_wait`; `out` points to `capacity`
/// writable `tp_verdict`s (or is NULL with `capacity` 0).
#[no_mangle]
pub unsafe extern "C" fn tp_verifier_poll(
    verifier: *mut TpVerifier,
    out: *mut TpVerdict,
    capacity: usize,
) -> i64 {
    guarded("tp_verifier_poll", TP_ERROR as i64, || {
        // SAFETY: NULL or valid, as the caller promises.
        let Some(v) = (unsafe { verifier.as_mut() }) else {
            set_error("tp_verifier_poll: verifier is NULL");
            return TP_ERROR as i64;
        };
        v.waiting.extend(v.client.poll());
        // SAFETY: `out` holds `capacity` verdicts, as the caller promises.
        unsafe { hand_over("tp_verifier_poll", &mut v.waiting, out, capacity, verdict) }
    })
}

/// Frees the link.
///
/// # Safety
/// `verifier` is NULL or came from `tp_verifier_connect` and was not freed.
#[no_mangle]
pub unsafe extern "C" fn tp_verifier_free(verifier: *mut TpVerifier) {
    // SAFETY: NULL or made by `Box::into_raw` in `tp_verifier_connect` (the caller's
    // contract).
    unsafe { free_handle("tp_verifier_free", verifier) }
}

/// The detector event a `tp_candidate` came from, as far as the verifier
/// needs it, so the hint is made by [`turnprint_ipc::Candidate::from_event`] itself.
fn event_of(c: &TpCandidate) -> CandidateEvent {
    let r = &c.rotation;
    let hypothesis = Hypothesis {
        rank: 0,
        score: c.score,
        zncc: c.zncc,
        reversed: c.reversed != 0,
        a_range: [c.query_first as usize, c.query_last as usize],
        b_range: [c.match_first as usize, c.match_last as usize],
        scale: c.scale,
        rotation: Matrix3::new(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]),
        translation: Vector3::from(c.translation),
        rmse: 0.0,
        turning: 0.0,
        length: 0.0,
        length_ratio: 1.0,
        correspondences: Vec::new(),
    };
    let keyframes = (c.has_keyframes != 0 && c.query_keyframe >= 0 && c.match_keyframe >= 0)
        .then_some(KeyframePair {
            query_keyframe: c.query_keyframe as u64,
            query_pose: c.query_keyframe_pose as usize,
            match_keyframe: c.match_keyframe as u64,
            match_pose: c.match_keyframe_pose as usize,
        });
    CandidateEvent {
        id: c.id,
        at_pose: c.at_pose as usize,
        hypothesis,
        source: Source::Shape,
        keyframes,
        query_keyframes: Vec::new(),
        match_keyframes: Vec::new(),
    }
}

/// An outcome in the header's layout.
fn verdict(o: &Outcome) -> TpVerdict {
    let c = o.candidate();
    let mut v = TpVerdict {
        id: o.id(),
        outcome: 0,
        inliers: 0,
        query_keyframe: c.query_keyframe as i64,
        match_keyframe: c.match_keyframe as i64,
        match_R_query: [0.0; 9],
        match_t_query: [0.0; 3],
        reason: [0; 64],
    };
    let reason = match o {
        Outcome::Confirmed {
            match_R_query,
            match_t_query,
            inliers,
            ..
        } => {
            v.inliers = *inliers;
            v.match_R_query = row_major(match_R_query);
            v.match_t_query = [match_t_query.x, match_t_query.y, match_t_query.z];
            String::new()
        }
        Outcome::Rejected {
            reason, inliers, ..
        } => {
            v.outcome = 1;
            v.inliers = *inliers;
            reason.clone()
        }
        Outcome::Expired { reason, .. } => {
            v.outcome = 2;
            reason.to_string()
        }
    };
    for (dst, &b) in v.reason.iter_mut().zip(reason.as_bytes().iter().take(63)) {
        *dst = b as c_char;
    }
    v
}
