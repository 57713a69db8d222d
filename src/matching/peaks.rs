//! Local maxima of a ZNCC array at or above a threshold: the peaks the
//! batch and online scans both take as candidate alignments.
//!
//! A third of the windows of a KITTI history reach the usual threshold
//! (0.5) and few of them are peaks, so a test with a branch per window
//! mispredicts often: on one segment against 100 000 poses that cost more
//! than computing the scores. The test runs branch-free over 64 windows at
//! a time into a bit mask instead, and only the set bits branch.

use std::ops::Range;

/// Calls `emit(i, v)`, in increasing `i` over `range`, for each local
/// maximum `v = sign * scores[i] >= min`: strictly above its left
/// neighbour and at least its right one. The first and last elements of
/// `scores` have one neighbour and need beat only that one.
#[inline(always)]
pub fn local_maxima(
    scores: &[f64],
    sign: f64,
    range: Range<usize>,
    min: f64,
    mut emit: impl FnMut(usize, f64),
) {
    let n = scores.len();
    let (start, end) = (range.start, range.end.min(n));
    if start >= end {
        return;
    }
    let value = |i: usize| sign * scores[i];
    // An end of the array, tested with its one neighbour.
    let edge = |i: usize, emit: &mut dyn FnMut(usize, f64)| {
        let v = value(i);
        let left = i == 0 || value(i - 1) < v;
        let right = i + 1 == n || value(i + 1) <= v;
        if v >= min && left && right {
            emit(i, v);
        }
    };
    if start == 0 {
        edge(0, &mut emit);
    }
    let (lo, hi) = (start.max(1), end.min(n - 1));
    let mut i = lo;
    while i < hi {
        let block = (hi - i).min(64);
        let mut mask = 0u64;
        for (b, w) in scores[i - 1..i + block + 1].windows(3).enumerate() {
            let (l, v, r) = (sign * w[0], sign * w[1], sign * w[2]);
            mask |= (((v >= min) & (l < v) & (r <= v)) as u64) << b;
        }
        while mask != 0 {
            let b = mask.trailing_zeros() as usize;
            emit(i + b, value(i + b));
            mask &= mask - 1;
        }
        i += block;
    }
    if end == n && n > 1 {
        edge(n - 1, &mut emit);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The plain definition, one branch per element.
    fn reference(s: &[f64], sign: f64, range: Range<usize>, min: f64) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        for i in range.start..range.end.min(s.len()) {
            let v = sign * s[i];
            if v < min {
                continue;
            }
            let left = i == 0 || sign * s[i - 1] < v;
            let right = i + 1 == s.len() || sign * s[i + 1] <= v;
            if left && right {
                out.push((i, v));
            }
        }
        out
    }

    fn found(s: &[f64], sign: f64, range: Range<usize>, min: f64) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        local_maxima(s, sign, range, min, |i, v| out.push((i, v)));
        out
    }

    proptest! {
        /// Same peaks as the plain definition, plateaus (quantised values)
        /// and array ends included, over any sub-range.
        #[test]
        fn finds_what_the_plain_test_finds(
            s in prop::collection::vec((-8i32..8).prop_map(|v| v as f64 / 8.0), 0..300),
            a in 0usize..320,
            b in 0usize..320,
            negate in any::<bool>(),
        ) {
            let sign = if negate { -1.0 } else { 1.0 };
            let range = a.min(b)..a.max(b);
            prop_assert_eq!(found(&s, sign, range.clone(), 0.25), reference(&s, sign, range, 0.25));
        }
    }

    #[test]
    fn single_and_flat_arrays() {
        assert_eq!(found(&[0.7], 1.0, 0..1, 0.5), vec![(0, 0.7)]);
        assert_eq!(found(&[0.7], -1.0, 0..1, 0.5), vec![]);
        // A plateau peaks at its first element only.
        assert_eq!(found(&[0.6; 5], 1.0, 0..5, 0.5), vec![(0, 0.6)]);
        assert_eq!(found(&[0.1, 0.6, 0.6, 0.2], 1.0, 0..4, 0.5), vec![(1, 0.6)]);
    }
}
