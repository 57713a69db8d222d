//! The naive loop detector a SLAM engineer compares against: for each pose,
//! the nearest pose at least `min_gap` poses earlier in the input's own
//! frame; close enough means a loop. Scale-free: the distance threshold is
//! a multiple of the input's median step length.

use nalgebra::Vector3;

use super::checks::{median, LoopClaim};
use super::revisits::{arc_lengths, nearest_earlier, nearest_earlier_apart};

/// Settings of the naive detector.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Naive {
    /// Poses between a pose and the earliest candidate match (300, as for
    /// the ground-truth revisits).
    pub min_gap: usize,
    /// Threshold in median step lengths. KITTI moves about 1 m per frame
    /// when moving, so 8 steps is the 8 m of the ground-truth revisits.
    pub threshold_steps: f64,
    /// Non-hit poses allowed inside one loop.
    pub max_gap: usize,
    /// Matched earlier poses more than this many poses apart belong to
    /// different earlier passes: one loop each.
    pub max_match_jump: usize,
    /// How many loops to return.
    pub top_k: usize,
    /// When above 0, the earliest candidate match lies this fraction of the
    /// input's own length back instead of `min_gap` poses (paths whose poses
    /// per length vary, as a drone's hovering does).
    pub min_gap_share: f64,
}

impl Default for Naive {
    fn default() -> Self {
        Naive {
            min_gap: 300,
            threshold_steps: 8.0,
            max_gap: 5,
            max_match_jump: 50,
            top_k: 10,
            min_gap_share: 0.0,
        }
    }
}

impl Naive {
    /// Loops of the input path, best (smallest mean distance) first.
    pub fn loops(&self, positions: &[Vector3<f64>]) -> Vec<LoopClaim> {
        let steps: Vec<f64> = positions
            .windows(2)
            .map(|w| (w[1] - w[0]).norm())
            .filter(|d| *d > 0.0)
            .collect();
        let threshold = self.threshold_steps * median(&steps);
        if !threshold.is_finite() {
            return Vec::new();
        }
        // Runs of consecutive hits (gaps <= max_gap) as (i, j, d) lists.
        let mut runs: Vec<Vec<(usize, usize, f64)>> = Vec::new();
        let nearest = match self.min_gap_share > 0.0 {
            true => {
                let length = arc_lengths(positions).last().copied().unwrap_or(0.0);
                nearest_earlier_apart(positions, self.min_gap_share * length)
            }
            false => nearest_earlier(positions, self.min_gap),
        };
        for (i, n) in nearest.into_iter().enumerate() {
            let Some((j, d)) = n.filter(|(_, d)| *d <= threshold) else {
                continue;
            };
            match runs.last_mut() {
                Some(run) if i - run[run.len() - 1].0 <= self.max_gap + 1 => run.push((i, j, d)),
                _ => runs.push(vec![(i, j, d)]),
            }
        }
        // Within a run, the matches may alternate between earlier passes
        // over the same road: one loop per cluster of matched poses.
        let mut claims: Vec<(f64, LoopClaim)> = Vec::new();
        for mut run in runs {
            run.sort_by_key(|h| h.1);
            let mut start = 0;
            for k in 1..=run.len() {
                if k < run.len() && run[k].1 - run[k - 1].1 <= self.max_match_jump {
                    continue;
                }
                let cluster = &run[start..k];
                start = k;
                let mean = cluster.iter().map(|h| h.2).sum::<f64>() / cluster.len() as f64;
                let (q0, q1) = cluster
                    .iter()
                    .fold((usize::MAX, 0), |(lo, hi), h| (lo.min(h.0), hi.max(h.0)));
                let claim = LoopClaim {
                    query: [q0, q1],
                    matched: [cluster[0].1, cluster[cluster.len() - 1].1],
                    score: 1.0 / (1.0 + mean / threshold),
                };
                claims.push((mean, claim));
            }
        }
        claims.sort_by(|a, b| a.0.total_cmp(&b.0));
        claims.into_iter().take(self.top_k).map(|c| c.1).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Out along x, around a 100 m square, back along the start 2 m to the
    /// side, with 1 m steps; then scaled by `s`.
    fn loop_path(s: f64) -> Vec<Vector3<f64>> {
        crate::test_paths::square_loop(80, 2.0)
            .into_iter()
            .map(|v| v * s)
            .collect()
    }

    #[test]
    fn finds_the_revisit_at_any_scale() {
        for s in [0.01, 1.0, 100.0] {
            let loops = Naive::default().loops(&loop_path(s));
            assert_eq!(loops.len(), 1, "scale {s}: {loops:?}");
            let l = loops[0];
            assert!(l.query[0] >= 390 && l.query[1] == 479, "{l:?}");
            assert!(l.matched[0] <= 2 && l.matched[1] >= 75, "{l:?}");
        }
    }

    #[test]
    fn a_far_second_pass_is_missed() {
        // The return leg 20 m to the side: beyond 8 median steps.
        let p: Vec<_> = loop_path(1.0)
            .into_iter()
            .enumerate()
            .map(|(i, v)| {
                if i >= 380 {
                    v + Vector3::new(0.0, 18.0, 0.0)
                } else {
                    v
                }
            })
            .collect();
        assert!(Naive::default().loops(&p).is_empty());
    }

    #[test]
    fn interleaved_earlier_passes_give_one_loop_each() {
        // Passes along x at y = 0 (poses 0..200), y = 1 (400..600) and
        // y = 0.5 (1000..1200); the first two are offset by 0.2 on alternate
        // poses so the third pass's nearest earlier pose flips between them.
        let mut p: Vec<Vector3<f64>> = Vec::new();
        for k in 0..1200usize {
            let x = (k % 200) as f64;
            let odd = (k % 2) as f64;
            p.push(match k {
                0..200 => Vector3::new(x + 0.2 * (1.0 - odd), 0.0, 0.0),
                400..600 => Vector3::new(x + 0.2 * odd, 1.0, 0.0),
                1000..1200 => Vector3::new(x, 0.5, 0.0),
                _ => Vector3::new(-500.0 - k as f64, 500.0, 0.0),
            });
        }
        let loops = Naive::default().loops(&p);
        // The second pass revisits the first; the third revisits both.
        assert_eq!(loops.len(), 3, "{loops:?}");
        let third: Vec<_> = loops.iter().filter(|l| l.query[0] >= 1000).collect();
        assert_eq!(third.len(), 2, "{loops:?}");
        let mut matched: Vec<[usize; 2]> = third.iter().map(|l| l.matched).collect();
        matched.sort();
        assert!(
            matched[0][0] <= 2 && matched[0][1] >= 197 && matched[0][1] < 200,
            "{loops:?}"
        );
        assert!(
            matched[1][0] <= 402 && matched[1][1] >= 597 && matched[1][1] < 600,
            "{loops:?}"
        );
        assert!(third
            .iter()
            .all(|l| l.query[0] <= 1002 && l.query[1] >= 1197));
    }
}
