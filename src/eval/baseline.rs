//! The naive loop detector a SLAM engineer compares against: for each pose,
//! the nearest pose at least `min_gap` poses earlier in the input's own
//! frame; close enough means a loop. Scale-free: the distance threshold is
//! a multiple of the input's median step length.

use nalgebra::Vector3;

use super::checks::{median, LoopClaim};
use super::revisits::nearest_earlier;

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
    /// A jump of the matched earlier pose by more than this many poses
    /// starts a new loop (another earlier place).
    pub max_match_jump: usize,
    /// How many loops to return.
    pub top_k: usize,
}

impl Default for Naive {
    fn default() -> Self {
        Naive {
            min_gap: 300,
            threshold_steps: 8.0,
            max_gap: 5,
            max_match_jump: 50,
            top_k: 10,
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
        // (query first, query last, match min, match max, last match, distances)
        let mut groups: Vec<(usize, usize, usize, usize, usize, Vec<f64>)> = Vec::new();
        for (i, n) in nearest_earlier(positions, self.min_gap)
            .into_iter()
            .enumerate()
        {
            let Some((j, d)) = n.filter(|(_, d)| *d <= threshold) else {
                continue;
            };
            match groups.last_mut() {
                Some(g)
                    if i - g.1 <= self.max_gap + 1 && j.abs_diff(g.4) <= self.max_match_jump =>
                {
                    g.1 = i;
                    g.2 = g.2.min(j);
                    g.3 = g.3.max(j);
                    g.4 = j;
                    g.5.push(d);
                }
                _ => groups.push((i, i, j, j, j, vec![d])),
            }
        }
        let mut claims: Vec<(f64, LoopClaim)> = groups
            .into_iter()
            .map(|g| {
                let mean = g.5.iter().sum::<f64>() / g.5.len() as f64;
                let claim = LoopClaim {
                    query: [g.0, g.1],
                    matched: [g.2, g.3],
                    score: 1.0 / (1.0 + mean / threshold),
                };
                (mean, claim)
            })
            .collect();
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
        let mut p = Vec::new();
        for i in 0..100 {
            p.push(Vector3::new(i as f64, 0.0, 0.0));
        }
        for i in 0..100 {
            p.push(Vector3::new(100.0, i as f64, 0.0));
        }
        for i in 0..100 {
            p.push(Vector3::new(100.0 - i as f64, 100.0, 0.0));
        }
        for i in 0..100 {
            p.push(Vector3::new(0.0, 100.0 - i as f64, 0.0));
        }
        for i in 0..80 {
            p.push(Vector3::new(i as f64, 2.0, 0.0));
        }
        p.into_iter().map(|v| v * s).collect()
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
}
