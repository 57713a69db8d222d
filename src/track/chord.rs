//! Chord-length parameter of a path: repeated and stationary poses collapse
//! onto one parameter value, so a robot standing still adds no length and no
//! spurious turns.

use nalgebra::Vector2;

/// Poses that move, their chord-length parameter, and the map back to every
/// original pose.
#[derive(Debug, Clone)]
pub struct ChordParam {
    /// Positions of the kept (moving) poses.
    pub points: Vec<Vector2<f64>>,
    /// Chord-length parameter of each kept pose.
    pub u: Vec<f64>,
    /// Original pose index of each kept pose.
    pub index: Vec<usize>,
    /// Chord parameter of every original pose (stationary poses share one).
    pub pose_u: Vec<f64>,
    /// Typical spacing between kept poses (median).
    pub typical_step: f64,
}

/// A pose closer than this fraction of the typical moving step to the last
/// kept pose is treated as standing still (jitter of a stopped robot).
const STATIONARY_FRACTION: f64 = 0.25;

impl ChordParam {
    /// `None` when fewer than three distinct positions remain.
    pub fn new(points: &[Vector2<f64>]) -> Option<ChordParam> {
        if points.len() < 3 || points.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
            return None;
        }
        // Typical moving step: an upper quantile of the step lengths, so that
        // long stops (many near-zero steps) do not drag it down.
        let mut steps: Vec<f64> = points.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
        steps.sort_by(f64::total_cmp);
        let upper = steps[(steps.len() * 3) / 4];
        if !(upper > 0.0) {
            return None;
        }
        let min_step = STATIONARY_FRACTION * upper;

        let mut kept = vec![points[0]];
        let mut u = vec![0.0];
        let mut index = vec![0];
        let mut pose_u = Vec::with_capacity(points.len());
        pose_u.push(0.0);
        for (i, p) in points.iter().enumerate().skip(1) {
            let last = *kept.last().expect("kept starts non-empty");
            let d = (p - last).norm();
            if d >= min_step {
                u.push(u.last().expect("u starts non-empty") + d);
                kept.push(*p);
                index.push(i);
            }
            pose_u.push(*u.last().expect("u starts non-empty"));
        }
        if kept.len() < 3 {
            return None;
        }
        let mut kept_steps: Vec<f64> = u.windows(2).map(|w| w[1] - w[0]).collect();
        kept_steps.sort_by(f64::total_cmp);
        let typical_step = kept_steps[kept_steps.len() / 2];
        Some(ChordParam {
            points: kept,
            u,
            index,
            pose_u,
            typical_step,
        })
    }

    /// Total chord length.
    pub fn total(&self) -> f64 {
        self.u.last().copied().unwrap_or(0.0)
    }

    /// Fractional original pose index at chord parameter `u`.
    pub fn pose_at(&self, u: f64) -> f64 {
        let k = self.u.partition_point(|&x| x <= u);
        if k == 0 {
            return self.index[0] as f64;
        }
        if k >= self.u.len() {
            return *self.index.last().expect("non-empty") as f64;
        }
        let (u0, u1) = (self.u[k - 1], self.u[k]);
        let f = if u1 > u0 { (u - u0) / (u1 - u0) } else { 0.0 };
        self.index[k - 1] as f64 + f * (self.index[k] as f64 - self.index[k - 1] as f64)
    }
}
