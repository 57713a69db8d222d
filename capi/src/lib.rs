#![deny(missing_docs)]
//! C ABI of turnprint (`include/turnprint.h`), so a visual-odometry or
//! mapping process written in C or C++ uses the library in
//! its own address space.
//!
//! Every entry point checks its pointers, catches panics (a panic never
//! unwinds into C) and reports failures through `tp_last_error`. The types
//! mirror the header field for field (`#[repr(C)]`). One file per part of
//! the header: `detector.rs` (online, one pose at a time), `verifier.rs`
//! (the link to the visual verifier sidecar), `batch.rs` (whole paths:
//! merging and loops); this one holds what they share.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::ffi::{c_char, c_int, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use nalgebra::Matrix3;

mod batch;
mod detector;
mod verifier;

pub use batch::{tp_find_loops, tp_match_paths, TpHypothesis};
pub use detector::{
    tp_detector_finish, tp_detector_free, tp_detector_new, tp_detector_poll, tp_detector_push,
    tp_options_default, TpCandidate, TpDetector, TpOptions, TpPose, TpSummary,
};
pub use verifier::{
    tp_verifier_connect, tp_verifier_free, tp_verifier_poll, tp_verifier_publish_keyframe,
    tp_verifier_submit, tp_verifier_wait, TpCamera, TpVerdict, TpVerifier,
};

/// Success (`TP_ACCEPTED`).
pub(crate) const TP_ACCEPTED: c_int = 0;
/// Any failure; `tp_last_error` says which.
pub(crate) const TP_ERROR: c_int = -1;

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Sets this thread's `tp_last_error`.
pub(crate) fn set_error(message: &str) {
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

/// Runs `body`, turning a panic into `on_panic` and an error message.
pub(crate) fn guarded<T>(name: &str, on_panic: T, body: impl FnOnce() -> T) -> T {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(value) => value,
        Err(panic) => {
            let why = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            set_error(&format!("{name}: internal error: {why}"));
            on_panic
        }
    }
}

/// Frees a handle `tp_*_new`/`tp_*_connect` made with `Box::into_raw`
/// (NULL: nothing to do); a panic while dropping it is caught.
///
/// # Safety
/// `handle` is NULL or came from `Box::into_raw` and was not freed.
pub(crate) unsafe fn free_handle<T>(name: &str, handle: *mut T) {
    guarded(name, (), || {
        if !handle.is_null() {
            // SAFETY: the caller's contract above.
            drop(unsafe { Box::from_raw(handle) });
        }
    })
}

/// Moves up to `capacity` items of `waiting` into the caller's array `out`
/// (converted) and returns how many; `TP_ERROR` when `out` is NULL with a
/// nonzero capacity. What does not fit waits for the next call.
///
/// # Safety
/// `out` is NULL or points to `capacity` writable `U`s.
pub(crate) unsafe fn hand_over<T, U>(
    name: &str,
    waiting: &mut VecDeque<T>,
    out: *mut U,
    capacity: usize,
    convert: impl Fn(&T) -> U,
) -> i64 {
    if out.is_null() && capacity > 0 {
        set_error(&format!("{name}: out is NULL"));
        return TP_ERROR as i64;
    }
    let n = capacity.min(waiting.len());
    for (i, item) in waiting.drain(..n).enumerate() {
        // SAFETY: `out` holds `capacity` > `i` items.
        unsafe { out.add(i).write(convert(&item)) };
    }
    n as i64
}

/// The calling thread's last error message ("" when none).
#[no_mangle]
pub extern "C" fn tp_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// A rotation as the header's row-major array.
pub(crate) fn row_major(m: &Matrix3<f64>) -> [f64; 9] {
    std::array::from_fn(|i| m[(i / 3, i % 3)])
}
