//! Area under the ROC curve of a score that should rank true pairs above
//! negative pairs.

/// ROC AUC as the Mann-Whitney statistic: the probability that a random
/// positive scores above a random negative, ties counting one half.
/// `NaN` when either list is empty.
pub fn roc_auc(positives: &[f64], negatives: &[f64]) -> f64 {
    if positives.is_empty() || negatives.is_empty() {
        return f64::NAN;
    }
    let mut wins = 0.0;
    for p in positives {
        for n in negatives {
            wins += if p > n {
                1.0
            } else if p == n {
                0.5
            } else {
                0.0
            };
        }
    }
    wins / (positives.len() * negatives.len()) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separated_scores_give_one_and_zero() {
        assert_eq!(roc_auc(&[0.9, 0.8], &[0.1, 0.2, 0.3]), 1.0);
        assert_eq!(roc_auc(&[0.1], &[0.5, 0.6]), 0.0);
    }

    #[test]
    fn ties_and_interleaving_count_as_expected() {
        // Pairs: (0.5 vs 0.5) tie, (0.5 vs 0.2) win, (0.1 vs *) two losses.
        assert_eq!(roc_auc(&[0.5, 0.1], &[0.5, 0.2]), (0.5 + 1.0) / 4.0);
        // Missing hypotheses score 0 on both sides: all ties.
        assert_eq!(roc_auc(&[0.0, 0.0], &[0.0]), 0.5);
        assert!(roc_auc(&[], &[0.3]).is_nan());
    }
}
