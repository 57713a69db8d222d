//! The online detector from C (`tp_detector_*`): one push per pose on the
//! caller's thread, candidates handed over as the caller polls, the counts
//! at the end.

use std::collections::VecDeque;
use std::ffi::c_int;

use nalgebra::Vector3;
use turnprint::online::{
    CandidateEvent, Detector, Exclusion, OnlineConfig, Overflow, PoseInput, Pushed, Rejection,
    Source, Summary,
};

use crate::{free_handle, guarded, hand_over, row_major, set_error, TP_ACCEPTED, TP_ERROR};

/// The rejection codes of `tp_detector_push`.
const TP_REJECTED_NON_FINITE: c_int = 1;
const TP_REJECTED_OUT_OF_ORDER: c_int = 2;
const TP_REJECTED_DUPLICATE: c_int = 3;

/// Settings (`tp_options`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TpOptions {
    /// Candidates emitted per finalised segment.
    pub top_k: u32,
    /// Lowest score emitted.
    pub min_score: f64,
    /// Nonzero: the drifting-map probe is on.
    pub drift_probe: c_int,
    /// Nonzero: `push` waits for the worker ([`Overflow::Block`]).
    pub wait_for_matching: c_int,
    /// Lowest score emitted for a drift-probe candidate.
    pub drift_min_score: f64,
    /// Nonzero: the proximity probe is on.
    pub proximity: c_int,
    /// The query's own neighbourhood, in radians of turning.
    pub exclusion_turning: f64,
    /// Shape candidates verified per finalised segment.
    pub max_verify: u32,
    /// Messages the worker's queue holds.
    pub queue_capacity: u32,
    /// Steps longer than this many typical steps are jumps.
    pub jump_factor: f64,
    /// Matching threads.
    pub workers: u32,
}

/// One pose (`tp_pose`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TpPose {
    /// Timestamp (seconds), read when `has_time` is nonzero.
    pub t: f64,
    /// See `t`.
    pub has_time: c_int,
    /// Position.
    pub position: [f64; 3],
    /// Keyframe id, negative for none.
    pub keyframe: i64,
}

/// A candidate (`tp_candidate`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct TpCandidate {
    /// Unique id.
    pub id: u64,
    /// Index of the pose whose arrival produced it.
    pub at_pose: u64,
    /// First pose of the query (later) part.
    pub query_first: u64,
    /// Last pose of the query part.
    pub query_last: u64,
    /// First pose of the match (earlier) part.
    pub match_first: u64,
    /// Last pose of the match part.
    pub match_last: u64,
    /// Score in [0, 1].
    pub score: f64,
    /// ZNCC of the signatures.
    pub zncc: f64,
    /// 1 when the parts are driven in opposite directions.
    pub reversed: c_int,
    /// `TP_SOURCE_*`.
    pub source: c_int,
    /// Similarity match -> query: scale.
    pub scale: f64,
    /// Rotation, row-major.
    pub rotation: [f64; 9],
    /// Translation.
    pub translation: [f64; 3],
    /// 1 when `query_keyframe` and `match_keyframe` are set.
    pub has_keyframes: c_int,
    /// Keyframe to compare on the query side.
    pub query_keyframe: i64,
    /// Keyframe to compare on the match side.
    pub match_keyframe: i64,
    /// Pose index of `query_keyframe`.
    pub query_keyframe_pose: u64,
    /// Pose index of `match_keyframe`.
    pub match_keyframe_pose: u64,
}

/// Counts of a run (`tp_summary`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct TpSummary {
    /// Poses pushed.
    pub poses: u64,
    /// Poses accepted.
    pub accepted: u64,
    /// Dropped: NaN or infinite.
    pub non_finite: u64,
    /// Dropped: timestamp before the last two accepted.
    pub out_of_order: u64,
    /// Dropped: repeated timestamp.
    pub duplicate: u64,
    /// Dropped: isolated far poses (glitches).
    pub outliers: u64,
    /// Lasting jumps re-anchored.
    pub jumps: u64,
    /// Segments finalised.
    pub segments: u64,
    /// Candidates emitted.
    pub candidates: u64,
    /// Segments not matched because matching fell behind.
    pub skipped: u64,
    /// Bytes held by the history.
    pub history_bytes: u64,
    /// 1 when the matching thread was lost to an internal error.
    pub workers_lost: u64,
    /// Batches of matchings shared out over more than one thread.
    pub parallel_batches: u64,
    /// Taken although stamped before the last: that one's stamp alone was
    /// ahead.
    pub stamps_ahead: u64,
}

/// The detector behind a `tp_detector *`: candidates polled from the
/// worker wait here until the caller has room for them.
pub struct TpDetector {
    detector: Option<Detector>,
    waiting: VecDeque<CandidateEvent>,
}

/// The options the library uses by default.
fn default_options() -> TpOptions {
    let c = OnlineConfig::default();
    TpOptions {
        top_k: c.top_k as u32,
        min_score: c.min_score,
        drift_probe: c.drift_probe as c_int,
        wait_for_matching: 0,
        drift_min_score: c.drift_min_score,
        proximity: c.proximity as c_int,
        exclusion_turning: match c.exclusion {
            Exclusion::Turning(k) => k,
            Exclusion::Segments(_) => unreachable!("the default excludes by turning"),
        },
        max_verify: c.max_verify as u32,
        queue_capacity: c.queue_capacity as u32,
        jump_factor: c.jump_factor,
        workers: c.workers as u32,
    }
}

/// Why `o` is not a valid setting, if it is not.
fn invalid(o: &TpOptions) -> Option<&'static str> {
    let unit = |x: f64| (0.0..=1.0).contains(&x);
    if o.top_k == 0 {
        Some("top_k must be at least 1")
    } else if !unit(o.min_score) {
        Some("min_score must be a number in [0, 1]")
    } else if !unit(o.drift_min_score) {
        Some("drift_min_score must be a number in [0, 1]")
    } else if !(o.exclusion_turning.is_finite() && o.exclusion_turning > 0.0) {
        Some("exclusion_turning must be a finite, positive number of radians (0 would let a query match itself)")
    } else if o.max_verify == 0 {
        Some("max_verify must be at least 1")
    } else if o.queue_capacity == 0 {
        Some("queue_capacity must be at least 1")
    } else if !(o.jump_factor.is_finite() && o.jump_factor > 1.0) {
        Some("jump_factor must be a finite number above 1")
    } else if !(1..=OnlineConfig::MAX_WORKERS).contains(&(o.workers as usize)) {
        // The message names the bound (checked below at compile time).
        const _: () = assert!(OnlineConfig::MAX_WORKERS == 64);
        Some("workers must be between 1 and 64")
    } else {
        None
    }
}

/// Fills `out` with the default settings.
///
/// # Safety
/// `out` is NULL or points to a writable `tp_options`.
#[no_mangle]
pub unsafe extern "C" fn tp_options_default(out: *mut TpOptions) -> c_int {
    guarded("tp_options_default", TP_ERROR, || {
        // SAFETY: the caller passes NULL or a valid pointer.
        match unsafe { out.as_mut() } {
            Some(out) => {
                *out = default_options();
                TP_ACCEPTED
            }
            None => {
                set_error("tp_options_default: out is NULL");
                TP_ERROR
            }
        }
    })
}

/// A new detector, or NULL when the options are invalid.
///
/// # Safety
/// `options` is NULL or points to a readable `tp_options`.
#[no_mangle]
pub unsafe extern "C" fn tp_detector_new(options: *const TpOptions) -> *mut TpDetector {
    guarded("tp_detector_new", std::ptr::null_mut(), || {
        // SAFETY: the caller passes NULL or a valid pointer.
        let o = unsafe { options.as_ref() }
            .copied()
            .unwrap_or_else(default_options);
        if let Some(why) = invalid(&o) {
            set_error(&format!("tp_detector_new: {why}"));
            return std::ptr::null_mut();
        }
        let config = OnlineConfig {
            top_k: o.top_k as usize,
            min_score: o.min_score,
            drift_probe: o.drift_probe != 0,
            drift_min_score: o.drift_min_score,
            proximity: o.proximity != 0,
            exclusion: Exclusion::Turning(o.exclusion_turning),
            max_verify: o.max_verify as usize,
            queue_capacity: o.queue_capacity as usize,
            jump_factor: o.jump_factor,
            workers: o.workers as usize,
            ..OnlineConfig::default()
        };
        let overflow = match o.wait_for_matching {
            0 => Overflow::MergeLatest,
            _ => Overflow::Block,
        };
        Box::into_raw(Box::new(TpDetector {
            detector: Some(Detector::new(config, overflow)),
            waiting: VecDeque::new(),
        }))
    })
}

/// Feeds one pose.
///
/// # Safety
/// `detector` is NULL or came from `tp_detector_new` and was not freed;
/// `pose` is NULL or points to a readable `tp_pose`.
#[no_mangle]
pub unsafe extern "C" fn tp_detector_push(detector: *mut TpDetector, pose: *const TpPose) -> c_int {
    guarded("tp_detector_push", TP_ERROR, || {
        // SAFETY: the caller passes NULL or valid pointers.
        let (Some(d), Some(p)) = (unsafe { detector.as_mut() }, unsafe { pose.as_ref() }) else {
            set_error("tp_detector_push: detector or pose is NULL");
            return TP_ERROR;
        };
        let Some(detector) = d.detector.as_mut() else {
            set_error("tp_detector_push: the detector is finished");
            return TP_ERROR;
        };
        let input = PoseInput {
            t: (p.has_time != 0).then_some(p.t),
            position: Vector3::from(p.position),
            orientation: None,
            keyframe: u64::try_from(p.keyframe).ok(),
        };
        match detector.push(&input) {
            Pushed::Accepted(_) => TP_ACCEPTED,
            Pushed::Rejected(_, Rejection::NonFinite) => TP_REJECTED_NON_FINITE,
            Pushed::Rejected(_, Rejection::OutOfOrder) => TP_REJECTED_OUT_OF_ORDER,
            Pushed::Rejected(_, Rejection::Duplicate) => TP_REJECTED_DUPLICATE,
        }
    })
}

/// Copies up to `capacity` waiting candidates into `out`.
///
/// # Safety
/// `detector` as for `tp_detector_push`; `out` points to `capacity`
/// writable `tp_candidate`s (or is NULL with `capacity` 0).
#[no_mangle]
pub unsafe extern "C" fn tp_detector_poll(
    detector: *mut TpDetector,
    out: *mut TpCandidate,
    capacity: usize,
) -> i64 {
    guarded("tp_detector_poll", TP_ERROR as i64, || {
        // SAFETY: the caller passes NULL or a valid pointer.
        let Some(d) = (unsafe { detector.as_mut() }) else {
            set_error("tp_detector_poll: detector is NULL");
            return TP_ERROR as i64;
        };
        if let Some(detector) = &d.detector {
            d.waiting.extend(detector.poll());
        }
        // SAFETY: `out` holds `capacity` candidates, as the caller promises.
        unsafe { hand_over("tp_detector_poll", &mut d.waiting, out, capacity, candidate) }
    })
}

/// Ends the stream and writes the counts to `summary` (may be NULL).
///
/// # Safety
/// `detector` as for `tp_detector_push`; `summary` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn tp_detector_finish(
    detector: *mut TpDetector,
    summary: *mut TpSummary,
) -> c_int {
    guarded("tp_detector_finish", TP_ERROR, || {
        // SAFETY: the caller passes NULL or a valid pointer.
        let Some(d) = (unsafe { detector.as_mut() }) else {
            set_error("tp_detector_finish: detector is NULL");
            return TP_ERROR;
        };
        let Some(detector) = d.detector.take() else {
            set_error("tp_detector_finish: the detector is already finished");
            return TP_ERROR;
        };
        let (rest, counts) = detector.finish();
        d.waiting.extend(rest);
        // SAFETY: the caller passes NULL or a valid pointer.
        if let Some(out) = unsafe { summary.as_mut() } {
            *out = summary_of(&counts);
        }
        if counts.workers_lost > 0 {
            set_error(
                "tp_detector_finish: the matching stopped on an internal error; the candidates polled are right, but those of the samples after it are missing",
            );
            return TP_ERROR;
        }
        TP_ACCEPTED
    })
}

/// Frees a detector (stopping its worker if it was not finished).
///
/// # Safety
/// `detector` is NULL or came from `tp_detector_new` and was not freed.
#[no_mangle]
pub unsafe extern "C" fn tp_detector_free(detector: *mut TpDetector) {
    // SAFETY: NULL or made by `Box::into_raw` in `tp_detector_new` (the caller's
    // contract).
    unsafe { free_handle("tp_detector_free", detector) }
}

/// A candidate event in the header's layout.
fn candidate(e: &CandidateEvent) -> TpCandidate {
    let h = &e.hypothesis;
    let (has_keyframes, query_keyframe, match_keyframe, query_keyframe_pose, match_keyframe_pose) =
        match e.keyframes {
            Some(k) => (
                1,
                k.query_keyframe as i64,
                k.match_keyframe as i64,
                k.query_pose as u64,
                k.match_pose as u64,
            ),
            None => (0, -1, -1, 0, 0),
        };
    TpCandidate {
        id: e.id,
        at_pose: e.at_pose as u64,
        query_first: h.a_range[0] as u64,
        query_last: h.a_range[1] as u64,
        match_first: h.b_range[0] as u64,
        match_last: h.b_range[1] as u64,
        score: h.score,
        zncc: h.zncc,
        reversed: h.reversed as c_int,
        source: match e.source {
            Source::Shape => 0,
            Source::Proximity => 1,
            Source::DriftProbe => 2,
            Source::Network => 3,
        },
        scale: h.scale,
        rotation: row_major(&h.rotation),
        translation: [h.translation.x, h.translation.y, h.translation.z],
        has_keyframes,
        query_keyframe,
        match_keyframe,
        query_keyframe_pose,
        match_keyframe_pose,
    }
}

/// The counts in the header's layout.
fn summary_of(s: &Summary) -> TpSummary {
    TpSummary {
        poses: s.poses,
        accepted: s.accepted,
        non_finite: s.guards.non_finite,
        out_of_order: s.guards.out_of_order,
        duplicate: s.guards.duplicate,
        outliers: s.guards.outliers,
        jumps: s.guards.jumps,
        segments: s.worker.segments,
        candidates: s.worker.candidates,
        skipped: s.worker.skipped,
        history_bytes: s.worker.history_bytes,
        workers_lost: s.workers_lost,
        parallel_batches: s.worker.parallel_batches,
        stamps_ahead: s.guards.stamps_ahead,
    }
}
