//! Ranking: drop weak ones, sort by score, drop duplicates (both ranges mostly shared), keep
//! the top k.

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

/// Drops those scoring below `min_score`, sorts, de-duplicates and keeps
/// the `top_k` best, ranks from 1.
pub fn rank(mut all: Vec<Hypothesis>, top_k: usize, min_score: f64) -> Vec<Hypothesis> {
    all.retain(|h| h.score >= min_score);
    all.sort_by(|x, y| y.score.total_cmp(&x.score));
    let mut kept: Vec<Hypothesis> = Vec::new();
    for h in all {
        if kept.len() >= top_k {
            break;
        }
        let duplicate = kept.iter().any(|k| {
            k.reversed == h.reversed
                && range_overlap(k.a_range, h.a_range) > 0.5
                && range_overlap(k.b_range, h.b_range) > 0.5
        });
        if !duplicate {
            kept.push(h);
        }
    }
    for (i, h) in kept.iter_mut().enumerate() {
        h.rank = i + 1;
    }
    kept
}
