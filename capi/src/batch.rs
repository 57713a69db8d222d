//! Whole paths from C (`tp_match_paths`, `tp_find_loops`): map merging and
//! loop hypotheses of recorded paths, the library's `match_paths` and
//! `find_loops` with their default settings.

use std::ffi::c_int;

use nalgebra::Vector3;
use turnprint::{find_loops, match_paths, Config, Hypothesis, Trajectory};

use crate::{guarded, hand_over, row_major, set_error, TP_ERROR};

/// A hypothesis (`tp_hypothesis`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct TpHypothesis {
    /// First pose of the range in A.
    pub a_first: u64,
    /// Last pose of the range in A.
    pub a_last: u64,
    /// First pose of the range in B.
    pub b_first: u64,
    /// Last pose of the range in B.
    pub b_last: u64,
    /// Score in [0, 1].
    pub score: f64,
    /// ZNCC of the signatures.
    pub zncc: f64,
    /// 1 when B runs the other way.
    pub reversed: c_int,
    /// Similarity B -> A: scale.
    pub scale: f64,
    /// Rotation, row-major.
    pub rotation: [f64; 9],
    /// Translation.
    pub translation: [f64; 3],
    /// RMS residual of the overlap (A's units).
    pub rmse: f64,
    /// Turning inside the overlap (degrees).
    pub turning_deg: f64,
    /// Matched length (A's units).
    pub length: f64,
}

/// Where path B overlaps path A, best first.
///
/// # Safety
/// `a` and `b` are NULL or hold `3 * a_poses` and `3 * b_poses` readable
/// doubles; `out` is NULL or holds `capacity` writable hypotheses.
#[no_mangle]
pub unsafe extern "C" fn tp_match_paths(
    a: *const f64,
    a_poses: usize,
    b: *const f64,
    b_poses: usize,
    out: *mut TpHypothesis,
    capacity: usize,
) -> i64 {
    guarded("tp_match_paths", TP_ERROR as i64, || {
        // SAFETY: as the caller promises.
        let (Some(a), Some(b)) = (unsafe { path("A", a, a_poses) }, unsafe {
            path("B", b, b_poses)
        }) else {
            return TP_ERROR as i64;
        };
        let config = Config {
            top_k: capacity.max(1),
            ..Config::for_matching()
        };
        // SAFETY: as the caller promises.
        unsafe {
            write(
                "tp_match_paths",
                match_paths(&a, &b, &config),
                out,
                capacity,
            )
        }
    })
}

/// Places path A revisits (A's range the later part, B's the earlier),
/// best first.
///
/// # Safety
/// `a` is NULL or holds `3 * poses` readable doubles; `out` is NULL or
/// holds `capacity` writable hypotheses.
#[no_mangle]
pub unsafe extern "C" fn tp_find_loops(
    a: *const f64,
    poses: usize,
    out: *mut TpHypothesis,
    capacity: usize,
) -> i64 {
    guarded("tp_find_loops", TP_ERROR as i64, || {
        // SAFETY: as the caller promises.
        let Some(a) = (unsafe { path("A", a, poses) }) else {
            return TP_ERROR as i64;
        };
        let config = Config {
            top_k: capacity.max(1),
            ..Config::for_loops()
        };
        // SAFETY: as the caller promises.
        unsafe { write("tp_find_loops", find_loops(&a, &config), out, capacity) }
    })
}

/// The path of `poses` positions at `xyz` (x, y, z each), or `None` with
/// the error set.
///
/// # Safety
/// `xyz` is NULL or holds `3 * poses` readable doubles.
unsafe fn path(name: &str, xyz: *const f64, poses: usize) -> Option<Trajectory> {
    if xyz.is_null() {
        set_error(&format!("path {name} is NULL"));
        return None;
    }
    // SAFETY: `3 * poses` readable doubles, as the caller promises.
    let xyz = unsafe { std::slice::from_raw_parts(xyz, 3 * poses) };
    let positions: Vec<Vector3<f64>> = xyz
        .chunks_exact(3)
        .map(|p| Vector3::new(p[0], p[1], p[2]))
        .collect();
    Some(Trajectory::from_positions(name, &positions))
}

/// Writes the hypotheses (at most `capacity`) and returns how many.
///
/// # Safety
/// `out` is NULL or holds `capacity` writable hypotheses.
unsafe fn write(
    name: &str,
    found: turnprint::Result<Vec<Hypothesis>>,
    out: *mut TpHypothesis,
    capacity: usize,
) -> i64 {
    match found {
        // SAFETY: as the caller promises.
        Ok(found) => unsafe { hand_over(name, &mut found.into(), out, capacity, hypothesis) },
        Err(e) => {
            set_error(&format!("{name}: {e}"));
            TP_ERROR as i64
        }
    }
}

/// A hypothesis in the header's layout.
fn hypothesis(h: &Hypothesis) -> TpHypothesis {
    TpHypothesis {
        a_first: h.a_range[0] as u64,
        a_last: h.a_range[1] as u64,
        b_first: h.b_range[0] as u64,
        b_last: h.b_range[1] as u64,
        score: h.score,
        zncc: h.zncc,
        reversed: h.reversed as c_int,
        scale: h.scale,
        rotation: row_major(&h.rotation),
        translation: [h.translation.x, h.translation.y, h.translation.z],
        rmse: h.rmse,
        turning_deg: h.turning.to_degrees(),
        length: h.length,
    }
}
