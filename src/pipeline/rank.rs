//! Ranking: drop the weak, sort by score, drop duplicates (both ranges
//! mostly shared), keep the top k.

use crate::Hypothesis;

/// Fraction of the shorter range covered by the intersection.
pub fn range_overlap(a: [usize; 2], b: [usize; 2]) -> f64 {
    let lo = a[0].max(b[0]);
    let hi = a[1].min(b[1]);
    if hi < lo {
        return 0.0;
    }
    let inter = (hi - lo + 1) as f64;
    let shorter = ((a[1] - a[0]).min(b[1] - b[0]) + 1) as f64;
    inter / shorter
}

/// Something ranked by the hypothesis it carries.
pub trait Ranked {
    /// The hypothesis.
    fn hypothesis(&self) -> &Hypothesis;
    /// The hypothesis, to number its rank.
    fn hypothesis_mut(&mut self) -> &mut Hypothesis;
}

impl Ranked for Hypothesis {
    fn hypothesis(&self) -> &Hypothesis {
        self
    }
    fn hypothesis_mut(&mut self) -> &mut Hypothesis {
        self
    }
}

/// Drops those scoring below `min_score`, sorts, de-duplicates (same
/// direction of travel, both ranges mostly shared) and keeps the `top_k`
/// best, ranks from 1.
pub fn rank<T: Ranked>(mut all: Vec<T>, top_k: usize, min_score: f64) -> Vec<T> {
    all.retain(|h| h.hypothesis().score >= min_score);
    all.sort_by(|x, y| y.hypothesis().score.total_cmp(&x.hypothesis().score));
    let mut kept: Vec<T> = Vec::new();
    for item in all {
        if kept.len() >= top_k {
            break;
        }
        let h = item.hypothesis();
        let duplicate = kept.iter().map(Ranked::hypothesis).any(|k| {
            k.reversed == h.reversed
                && range_overlap(k.a_range, h.a_range) > 0.5
                && range_overlap(k.b_range, h.b_range) > 0.5
        });
        if !duplicate {
            kept.push(item);
        }
    }
    for (i, item) in kept.iter_mut().enumerate() {
        item.hypothesis_mut().rank = i + 1;
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h(score: f64, a: [usize; 2], b: [usize; 2], reversed: bool) -> Hypothesis {
        Hypothesis {
            rank: 0,
            score,
            zncc: 1.0,
            reversed,
            a_range: a,
            b_range: b,
            scale: 1.0,
            rotation: nalgebra::Matrix3::identity(),
            translation: nalgebra::Vector3::zeros(),
            rmse: 0.0,
            turning: 0.0,
            length: 1.0,
            length_ratio: 1.0,
            correspondences: Vec::new(),
        }
    }

    #[test]
    fn rank_drops_weak_and_duplicate_hypotheses_and_numbers_the_rest() {
        let all = vec![
            h(0.5, [0, 100], [500, 600], false),
            h(0.9, [10, 110], [510, 610], false), // keeps; drops the first
            h(0.7, [10, 110], [510, 610], true),  // other direction: kept
            h(0.05, [900, 950], [200, 250], false), // below the cut
            h(0.6, [300, 400], [700, 800], false),
        ];
        let kept = rank(all, 10, 0.1);
        let scores: Vec<f64> = kept.iter().map(|h| h.score).collect();
        assert_eq!(scores, vec![0.9, 0.7, 0.6]);
        assert_eq!(
            kept.iter().map(|h| h.rank).collect::<Vec<_>>(),
            vec![1, 2, 3]
        );
        assert_eq!(rank(kept, 2, 0.0).len(), 2);
    }
}
