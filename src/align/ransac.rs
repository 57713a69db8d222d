//! RANSAC over 2-point similarity samples.
//!
//! Two point pairs fix a 2D similarity exactly. The inlier threshold is a
//! fraction of the matched length in the target's units, so it is the same
//! for a map in millimetres and one in kilometres.

use nalgebra::Vector2;

use crate::geometry::Similarity2;

/// A small deterministic generator (SplitMix64): runs are repeatable.
#[derive(Debug, Clone)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform index in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Best similarity `a_T_b` for pairs `(p_a, p_b)`: 2-point hypotheses, the
/// one with most pairs closer than `threshold` (A units) wins, then a
/// least-squares refit on its inliers. Returns the transform and the inlier
/// flags, or `None` when no sample gives at least three inliers.
pub fn ransac_similarity(
    pairs: &[(Vector2<f64>, Vector2<f64>)],
    threshold: f64,
    iterations: usize,
    rng: &mut SplitMix,
) -> Option<(Similarity2, Vec<bool>)> {
    let n = pairs.len();
    if n < 3 {
        return None;
    }
    // Samples far apart along the path condition rotation and scale well.
    let min_gap = (n / 4).max(1);
    let t2 = threshold * threshold;
    let mut best: Option<(usize, Similarity2)> = None;
    for _ in 0..iterations {
        let i = rng.below(n);
        let j = rng.below(n);
        if i.abs_diff(j) < min_gap {
            continue;
        }
        let (a0, b0) = pairs[i];
        let (a1, b1) = pairs[j];
        let Some(t) = Similarity2::from_two(&a0, &a1, &b0, &b1) else {
            continue;
        };
        let apply_t = t.applier();
        let count = pairs
            .iter()
            .filter(|(a, b)| (apply_t(b) - a).norm_squared() < t2)
            .count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            best = Some((count, t));
        }
    }
    let (count, t) = best?;
    if count < 3 {
        return None;
    }
    let apply_t = t.applier();
    let inliers: Vec<bool> = pairs
        .iter()
        .map(|(a, b)| (apply_t(b) - a).norm_squared() < t2)
        .collect();
    let kept: Vec<_> = pairs
        .iter()
        .zip(&inliers)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect();
    let refit = Similarity2::fit(&kept, None).unwrap_or(t);
    Some((refit, inliers))
}
