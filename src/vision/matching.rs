//! Descriptor matching between two keyframes: brute force Hamming with
//! Lowe's ratio test and a mutual nearest-neighbour check.
//!
//! Both filters are ratios or rank tests, so they hold for any image size or
//! camera; the absolute Hamming cap only drops matches no ORB pair of the same
//! corner produces (more than a third of the 256 bits differ).

use opencv::core::{no_array, DMatch, Ptr, Vector, NORM_HAMMING};
use opencv::features2d::BFMatcher;
use opencv::prelude::*;

use super::features::KeyframeFeatures;

/// Settings of descriptor matching.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchParams {
    /// Best distance must be below `ratio` times the second best (Lowe).
    pub ratio: f32,
    /// Largest Hamming distance (bits of 256) accepted at all.
    pub max_distance: f32,
}

impl Default for MatchParams {
    fn default() -> Self {
        MatchParams { ratio: 0.8, max_distance: 80.0 }
    }
}

/// Matches ORB descriptors with OpenCV's brute-force Hamming matcher.
pub struct DescriptorMatcher {
    params: MatchParams,
    matcher: Ptr<BFMatcher>,
}

impl DescriptorMatcher {
    /// Creates the matcher.
    pub fn new(params: MatchParams) -> Result<Self, String> {
        let matcher = BFMatcher::create(NORM_HAMMING, false).map_err(|e| format!("BFMatcher::create: {e}"))?;
        Ok(DescriptorMatcher { params, matcher })
    }

    /// Index pairs `(i in a, j in b)` that pass the ratio test from a to b and
    /// are mutual nearest neighbours.
    pub fn match_features(&self, a: &KeyframeFeatures, b: &KeyframeFeatures) -> Result<Vec<(usize, usize)>, String> {
        if a.len() < 2 || b.len() < 2 {
            return Ok(Vec::new());
        }
        let da = a.descriptor_mat()?;
        let db = b.descriptor_mat()?;
        let mut forward: Vector<Vector<DMatch>> = Vector::new();
        self.matcher
            .knn_train_match(&da, &db, &mut forward, 2, &no_array(), false)
            .map_err(|e| format!("knn match {} -> {}: {e}", a.id, b.id))?;
        let mut backward: Vector<DMatch> = Vector::new();
        self.matcher
            .train_match(&db, &da, &mut backward, &no_array())
            .map_err(|e| format!("match {} -> {}: {e}", b.id, a.id))?;
        let mut best_in_a = vec![usize::MAX; b.len()];
        for m in backward.iter() {
            best_in_a[m.query_idx as usize] = m.train_idx as usize;
        }
        let mut pairs = Vec::new();
        for knn in forward.iter() {
            if knn.len() < 2 {
                continue;
            }
            let (best, second) = (knn.get(0).map_err(|e| e.to_string())?, knn.get(1).map_err(|e| e.to_string())?);
            if best.distance > self.params.max_distance || best.distance >= self.params.ratio * second.distance {
                continue;
            }
            let (i, j) = (best.query_idx as usize, best.train_idx as usize);
            if best_in_a[j] == i {
                pairs.push((i, j));
            }
        }
        Ok(pairs)
    }
}
