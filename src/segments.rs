//! Segmentation into G2 clothoid pieces, scale-free.
//!
//! In the `K` domain a path is a sequence of turns. The local radius of
//! curvature per unit turn, `r = ln(ds/dK)`, is low at a corner's apex and
//! high on the straights and inflections between corners. Boundaries are the
//! prominent extrema of `r`: straights/inflections (maxima) and apexes
//! (minima). Between an apex and a straight the curvature rises or falls
//! monotonically, which is what a clothoid (curvature linear in arc length)
//! models, so each piece is fitted as one, continuous at the boundaries.
//!
//! Everything is measured in `K` samples and in ratios of `ds/dK`: scaling
//! the path shifts `r` by a constant and moves no boundary; rotation and
//! translation change nothing; reversing the path reverses the sequence.

use crate::signature::Signature;

/// Settings of the segmentation.
#[derive(Debug, Clone, Copy)]
pub struct SegmentConfig {
    /// Half-width of the window (radians of `K`) in which a boundary must be
    /// the extremum: about half a typical corner.
    pub window: f64,
    /// Minimal ratio between `ds/dK` at an extremum and at the opposite
    /// extremes on both sides of it.
    pub prominence_ratio: f64,
}

impl Default for SegmentConfig {
    fn default() -> Self {
        SegmentConfig {
            window: 40f64.to_radians(),
            prominence_ratio: 2.0,
        }
    }
}

/// One clothoid piece between two boundaries, in `K` samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// First signature sample.
    pub start: usize,
    /// Last signature sample (the next segment's start).
    pub end: usize,
    /// Curvature at the start and end (path units), linear in arc length between.
    pub kappa: [f64; 2],
    /// Arc length at the start and end.
    pub s: [f64; 2],
}

/// Boundaries (signature sample indices, increasing, first and last included).
pub fn boundaries(sig: &Signature, config: &SegmentConfig) -> Vec<usize> {
    let n = sig.len();
    if n < 3 {
        return if n == 0 { vec![] } else { vec![0, n - 1] };
    }
    let r = log_radius(sig);
    let w = ((config.window / sig.dk).round() as usize).max(2);
    let p = config.prominence_ratio.ln();
    let mut out = vec![0];
    for j in 1..n - 1 {
        if is_extremum(&r, j, w, p) {
            out.push(j);
        }
    }
    if *out.last().expect("non-empty") != n - 1 {
        out.push(n - 1);
    }
    out
}

/// The clothoid pieces between boundaries, each fitted with curvature linear
/// in arc length and continuous across boundaries (G2).
pub fn segments(sig: &Signature, bounds: &[usize]) -> Vec<Segment> {
    // Curvature at each boundary: the signed compressed value squared back
    // (the signature stores sign(κ)|κ|^½). Using the boundary values for both
    // neighbours makes the piecewise-linear curvature continuous.
    let kappa_at = |j: usize| sig.value[j] * sig.value[j].abs();
    bounds
        .windows(2)
        .map(|b| Segment {
            start: b[0],
            end: b[1],
            kappa: [kappa_at(b[0]), kappa_at(b[1])],
            s: [sig.s[b[0]], sig.s[b[1]]],
        })
        .collect()
}

/// `ln(ds/dK)` per sample by central differences (floored so that a stop in
/// `s` cannot give `-inf`).
pub fn log_radius(sig: &Signature) -> Vec<f64> {
    let n = sig.len();
    let span = sig.s.last().copied().unwrap_or(0.0) - sig.s.first().copied().unwrap_or(0.0);
    let floor = (span * 1e-12).max(f64::MIN_POSITIVE);
    (0..n)
        .map(|j| {
            let (lo, hi) = (j.saturating_sub(1), (j + 1).min(n - 1));
            let ds = (sig.s[hi] - sig.s[lo]) / (hi - lo).max(1) as f64;
            ds.max(floor).ln()
        })
        .collect()
}

/// True when `r[j]` is the first strict extremum within `±w` samples and
/// stands out by `p` from the opposite extremes on both sides.
fn is_extremum(r: &[f64], j: usize, w: usize, p: f64) -> bool {
    let lo = j.saturating_sub(w);
    let hi = (j + w).min(r.len() - 1);
    let v = r[j];
    let left = &r[lo..j];
    let right = &r[j + 1..=hi];
    let is_max = left.iter().all(|&x| x < v) && right.iter().all(|&x| x <= v);
    let is_min = left.iter().all(|&x| x > v) && right.iter().all(|&x| x >= v);
    if is_max {
        let lmin = left.iter().copied().fold(f64::INFINITY, f64::min);
        let rmin = right.iter().copied().fold(f64::INFINITY, f64::min);
        v - lmin >= p && v - rmin >= p
    } else if is_min {
        let lmax = left.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let rmax = right.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        lmax - v >= p && rmax - v >= p
    } else {
        false
    }
}
