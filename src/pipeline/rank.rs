//! Ranking: drop the weak, sort by score, drop duplicates (both ranges
//! mostly shared; for matching, also about the same similarity), keep the
//! top k.

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

/// Two similarities this close (rotation, in radians; |ln| of the scale
/// ratio) over mostly shared ranges are one alignment found twice. Farther
/// apart they are rival placements of the same stretch, such as a
/// racetrack's two ends, which look alike turned by 180°.
const SAME_ROTATION: f64 = 0.35;
const SAME_LOG_SCALE: f64 = 0.2;

/// True when `a` and `b` map B alike: rotations within [`SAME_ROTATION`],
/// scales within [`SAME_LOG_SCALE`].
fn same_similarity(a: &Hypothesis, b: &Hypothesis) -> bool {
    a.similarity().angle_to(&b.similarity()) <= SAME_ROTATION
        && (a.scale / b.scale).ln().abs() <= SAME_LOG_SCALE
}

/// What makes two hypotheses one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Duplicates {
    /// Both ranges mostly shared: one place, whatever the similarity
    /// (loops: the place is the hint, the verifier measures the pose).
    Place,
    /// Both ranges mostly shared under about the same similarity (match and
    /// merge: the similarity is the answer, so rival placements of one
    /// stretch are alternatives, not duplicates).
    Alignment,
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
/// direction of travel, both ranges mostly shared, and per `duplicates`
/// about the same similarity) and keeps the `top_k` best, ranks from 1.
pub fn rank<T: Ranked>(
    mut all: Vec<T>,
    top_k: usize,
    min_score: f64,
    duplicates: Duplicates,
) -> Vec<T> {
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
                && (duplicates == Duplicates::Place || same_similarity(k, h))
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
        Hypothesis::scored(score, a, b, reversed)
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
        let kept = rank(all, 10, 0.1, Duplicates::Alignment);
        let scores: Vec<f64> = kept.iter().map(|h| h.score).collect();
        assert_eq!(scores, vec![0.9, 0.7, 0.6]);
        assert_eq!(
            kept.iter().map(|h| h.rank).collect::<Vec<_>>(),
            vec![1, 2, 3]
        );
        assert_eq!(rank(kept, 2, 0.0, Duplicates::Place).len(), 2);
    }

    #[test]
    fn racetrack_ends_turned_180_are_rival_alignments_not_duplicates() {
        // KITTI 06 (seed 1 of the merge evaluation): B's lap laid on A's
        // lap turned by 180° (the two U-turns look alike) scored 0.41; the
        // true placement, over mostly the same ranges, scored 0.36 and was
        // dropped as its duplicate, so not even the top 5 held it.
        let turned = Hypothesis {
            rotation: nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 3.1).into_inner(),
            ..h(0.41, [34, 683], [0, 568], true)
        };
        let truth = h(0.36, [500, 802], [266, 568], true);
        let kept = rank(
            vec![turned.clone(), truth.clone()],
            5,
            0.0,
            Duplicates::Alignment,
        );
        assert_eq!(kept.len(), 2);
        assert_eq!(kept[1].a_range, [500, 802]);
        // For loops the place is the hint: one of them.
        assert_eq!(
            rank(vec![turned, truth], 5, 0.0, Duplicates::Place).len(),
            1
        );
        // The same alignment a little off is still a duplicate.
        let close = Hypothesis {
            rotation: nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 0.1).into_inner(),
            scale: 1.05,
            ..h(0.3, [510, 800], [270, 560], true)
        };
        let kept = rank(
            vec![h(0.36, [500, 802], [266, 568], true), close],
            5,
            0.0,
            Duplicates::Alignment,
        );
        assert_eq!(kept.len(), 1);
    }
}
