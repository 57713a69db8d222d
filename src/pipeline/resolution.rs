//! Paths sampled at very different rates: a 1 Hz GPS against 10 Hz
//! odometry of the same drive. Each path is smoothed over a few of its own
//! pose spacings, so the sparse one rounds two corners a short straight
//! apart into one bend and its signature no longer lines up with the dense
//! one's in `K`. The denser path is matched a second time thinned to about
//! the sparser one's rate, where both see the road at one resolution.

use super::prepare::PreparedPath;
use crate::Trajectory;

/// Thin the denser path when its density ratio to the other is at least
/// this (10 Hz odometry against 1 Hz GPS reads about 6.5).
pub const MIN_DENSITY_RATIO: f64 = 3.0;

/// Most a path is thinned by: thinner would leave too few poses to match.
const MAX_THINNING: usize = 20;

/// Quantile of the per-pose turns that stands for "at a corner".
const CORNER_QUANTILE: f64 = 0.95;

/// The heading change between consecutive moving poses on the smoothed
/// track at the corners (its 95th percentile), in radians.
pub fn corner_turn_per_pose(p: &PreparedPath) -> f64 {
    let track = &p.track;
    let mut turns = Vec::with_capacity(p.poses);
    let mut last: Option<(f64, f64)> = None;
    for pose in 0..p.poses {
        let g = track.grid_of_pose(pose);
        let heading = crate::track::Track::interp(&track.heading, g);
        if let Some((g0, h0)) = last {
            if g <= g0 {
                continue;
            }
            turns.push((heading - h0).abs());
        }
        last = Some((g, heading));
    }
    if turns.is_empty() {
        return 0.0;
    }
    let k = ((turns.len() - 1) as f64 * CORNER_QUANTILE).round() as usize;
    let (_, q, _) = turns.select_nth_unstable_by(k, f64::total_cmp);
    *q
}

/// How many times more densely `a` is sampled than `b`. The corners of one
/// road have one radius whatever the path's scale, so the ratio of the
/// turning per pose at the corners is the ratio of the pose spacings.
pub fn density_ratio(a: &PreparedPath, b: &PreparedPath) -> f64 {
    let (ta, tb) = (corner_turn_per_pose(a), corner_turn_per_pose(b));
    if ta > 0.0 && tb > 0.0 {
        tb / ta
    } else {
        1.0
    }
}

/// The density ratio reads low by about this factor: the sparse path's own
/// smoothing rounds its corners. Measured on KITTI 00, 05 and 08 ground
/// truth against itself thinned by 5, 10 and 20: it reads 4.1-4.3,
/// 6.5-7.5 and 9-11 (and 2.7-2.8 thinned by 3).
const READS_LOW: f64 = 1.5;

/// The thinning `k` (keep every `k`-th pose) that brings the denser of two
/// paths to about the other's rate, for their density ratio (`None`: the
/// rates are close enough to match as they are).
pub fn thinning(ratio: f64) -> Option<usize> {
    let r = if ratio >= 1.0 { ratio } else { 1.0 / ratio };
    (r.is_finite() && r >= MIN_DENSITY_RATIO)
        .then(|| ((READS_LOW * r).round() as usize).min(MAX_THINNING))
}

/// The thinnings tried around an estimate `k`: the estimate reads the
/// ratio from a few corners, so on a short path it can be a fifth off, and
/// a sparse path matches well only near its own rate.
pub fn thinnings_around(k: usize) -> Vec<usize> {
    let mut ks: Vec<usize> = [
        k as f64 / THINNING_SPREAD,
        k as f64,
        k as f64 * THINNING_SPREAD,
    ]
    .iter()
    .map(|x| (x.round() as usize).clamp(2, MAX_THINNING))
    .collect();
    ks.dedup();
    ks
}

/// Ratio between the thinnings tried ([`thinnings_around`]).
const THINNING_SPREAD: f64 = 1.25;

/// Every `k`-th pose of `t`, the last one included.
pub fn thinned(t: &Trajectory, k: usize) -> Trajectory {
    let n = t.poses.len();
    let mut poses: Vec<_> = t.poses.iter().step_by(k.max(1)).cloned().collect();
    if n > 0 && !(n - 1).is_multiple_of(k.max(1)) {
        poses.push(t.poses[n - 1].clone());
    }
    Trajectory {
        source: t.source.clone(),
        poses,
    }
}

/// The original pose index of pose `i` of [`thinned`]`(t, k)` (`n` poses).
pub fn unthinned(i: usize, k: usize, n: usize) -> usize {
    (i * k).min(n.saturating_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{read_trajectory, Format};
    use crate::pipeline::Config;

    #[test]
    fn thinning_keeps_both_ends_and_maps_back() {
        let t = Trajectory::from_positions(
            "t",
            &(0..25)
                .map(|i| nalgebra::Vector3::new(i as f64, 0.0, 0.0))
                .collect::<Vec<_>>(),
        );
        let thin = thinned(&t, 10);
        let xs: Vec<f64> = thin.poses.iter().map(|p| p.position.x).collect();
        assert_eq!(xs, [0.0, 10.0, 20.0, 24.0]);
        let back: Vec<usize> = (0..thin.len()).map(|i| unthinned(i, 10, t.len())).collect();
        assert_eq!(back, [0, 10, 20, 24]);
    }

    /// KITTI 00 ground truth against itself thinned by 10 (10 Hz against
    /// 1 Hz): thinned again by about 10; against itself: not at all.
    #[test]
    fn the_denser_path_is_thinned_to_the_sparser_rate() {
        let Some(path) = crate::test_data::shared_data("kitti_gt/00.txt") else {
            return;
        };
        let t = read_trajectory(&path, Format::Kitti).expect("00");
        let config = Config::default();
        let dense = PreparedPath::new(&t, &config).expect("prepares");
        let sparse = PreparedPath::new(&thinned(&t, 10), &config).expect("prepares");
        let k = thinning(density_ratio(&dense, &sparse)).expect("rates differ");
        assert!((8..=13).contains(&k), "k = {k}");
        // Either way round.
        assert_eq!(thinning(density_ratio(&sparse, &dense)), Some(k));
        assert_eq!(thinning(density_ratio(&dense, &dense)), None);
    }
}
