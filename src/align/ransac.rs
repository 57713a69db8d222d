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
///
/// At most `iterations` draws, and no more hypotheses than it takes to
/// have drawn an all-inlier sample with probability `confidence`, given
/// the best share `w` of inliers so far (the standard adaptive stop,
/// Fischler and Bolles; Hartley and Zisserman, 4.7.1):
///
/// ```text
///   hypotheses needed = ln(1 - confidence) / ln(1 - w^2)
/// ```
///
/// `confidence` 1 (or more) draws them all.
pub fn ransac_similarity(
    pairs: &[(Vector2<f64>, Vector2<f64>)],
    threshold: f64,
    iterations: usize,
    confidence: f64,
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
    // Only the draws that make a hypothesis count: a close pair is redrawn.
    let (mut hypotheses, mut needed) = (0, f64::INFINITY);
    for _ in 0..iterations {
        if hypotheses as f64 >= needed {
            break;
        }
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
        hypotheses += 1;
        let apply_t = t.applier();
        let count = pairs
            .iter()
            .filter(|(a, b)| (apply_t(b) - a).norm_squared() < t2)
            .count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            best = Some((count, t));
            if confidence < 1.0 {
                let w = count as f64 / n as f64;
                let miss = 1.0 - w * w;
                // Every pair agrees: ln(miss) is -inf, so none are needed.
                if miss < 1.0 {
                    needed = (1.0 - confidence).ln() / miss.ln();
                }
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Draws `rng` made since `start` (SplitMix64 steps its state by a
    /// constant per draw).
    fn draws(start: &SplitMix, end: &SplitMix) -> usize {
        let mut probe = start.clone();
        (0..10_000)
            .find(|_| {
                let at_end = probe.0 == end.0;
                probe.next_u64();
                at_end
            })
            .expect("fewer than 10 000 draws")
    }

    /// A winding road `b` and its image `a = a_T_b b`; every `outlier_every`-th
    /// pair moved off it.
    #[allow(non_snake_case)]
    fn pairs(a_T_b: &Similarity2, outlier_every: usize) -> Vec<(Vector2<f64>, Vector2<f64>)> {
        (0..60)
            .map(|k| {
                let s = k as f64;
                let b = Vector2::new(s, 8.0 * (s / 9.0).sin());
                let mut a = a_T_b.apply(&b);
                if outlier_every > 0 && k % outlier_every == 0 {
                    a += Vector2::new(40.0, -25.0 + s);
                }
                (a, b)
            })
            .collect()
    }

    fn run(pairs: &[(Vector2<f64>, Vector2<f64>)], confidence: f64) -> (Similarity2, usize) {
        let start = SplitMix(7);
        let mut rng = start.clone();
        let (fit, _) = ransac_similarity(pairs, 1.0, 64, confidence, &mut rng).unwrap();
        (fit, draws(&start, &rng))
    }

    #[test]
    fn adaptive_stop_finds_the_same_similarity_with_fewer_hypotheses() {
        #[allow(non_snake_case)]
        let a_T_b = Similarity2 {
            scale: 2.5,
            angle: 0.7,
            translation: Vector2::new(-30.0, 12.0),
        };
        // Every pair on the road: the first hypothesis explains them all.
        let (fit, few) = run(&pairs(&a_T_b, 0), 0.999);
        assert!(few <= 8, "{few} draws");
        assert!((fit.scale - a_T_b.scale).abs() < 1e-9);
        // Every second pair off it: ln(0.001) / ln(0.75) = 24 hypotheses
        // (about 43 iterations, as close pairs are redrawn), not 64.
        let noisy = pairs(&a_T_b, 2);
        let (adaptive, some) = run(&noisy, 0.999);
        let (full, all) = run(&noisy, 1.0);
        assert_eq!(all, 128, "64 iterations of two draws");
        assert!(some < all, "{some} draws");
        for fit in [adaptive, full] {
            assert!((fit.scale - a_T_b.scale).abs() < 1e-9);
            assert!((fit.angle - a_T_b.angle).abs() < 1e-9);
            assert!((fit.translation - a_T_b.translation).norm() < 1e-6);
        }
    }
}
