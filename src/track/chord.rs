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

/// The chord parameter one point at a time: a point is kept when it moved
/// at least `min_step` from the last kept point; every point (kept or not)
/// gets the parameter of the last kept point. [`ChordParam::new`] runs the
/// same loop over a whole path.
#[derive(Debug, Clone)]
pub struct ChordStream {
    /// Smallest move that counts (path units; chosen from data, see
    /// [`ChordParam::min_step_of`]).
    pub min_step: f64,
    last: Option<Vector2<f64>>,
    u: f64,
}

impl ChordStream {
    /// A stream that keeps moves of at least `min_step`.
    pub fn new(min_step: f64) -> Self {
        ChordStream {
            min_step,
            last: None,
            u: 0.0,
        }
    }

    /// Feeds one point: its chord parameter and whether it was kept.
    pub fn push(&mut self, p: Vector2<f64>) -> (f64, bool) {
        match self.last {
            None => {
                self.last = Some(p);
                (0.0, true)
            }
            Some(last) => {
                let d = (p - last).norm();
                if d >= self.min_step {
                    self.u += d;
                    self.last = Some(p);
                    (self.u, true)
                } else {
                    (self.u, false)
                }
            }
        }
    }

    /// Chord parameter of the last kept point.
    pub fn u(&self) -> f64 {
        self.u
    }

    /// The last kept point.
    pub fn last(&self) -> Option<Vector2<f64>> {
        self.last
    }
}

impl ChordParam {
    /// `None` when fewer than three distinct positions remain.
    pub fn new(points: &[Vector2<f64>]) -> Option<ChordParam> {
        if points.len() < 3 || points.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
            return None;
        }
        let min_step = Self::min_step_of(points)?;
        let mut stream = ChordStream::new(min_step);
        let mut kept = Vec::new();
        let mut u = Vec::new();
        let mut index = Vec::new();
        let mut pose_u = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let (ui, is_kept) = stream.push(*p);
            if is_kept {
                kept.push(*p);
                u.push(ui);
                index.push(i);
            }
            pose_u.push(ui);
        }
        if kept.len() < 3 {
            return None;
        }
        let typical_step = Self::typical_step_of(&u);
        Some(ChordParam {
            points: kept,
            u,
            index,
            pose_u,
            typical_step,
        })
    }

    /// The stationary threshold of a path: `STATIONARY_FRACTION` of an
    /// upper quantile of its step lengths, so that long stops (many
    /// near-zero steps) do not drag it down. `None` when nothing moves.
    pub fn min_step_of(points: &[Vector2<f64>]) -> Option<f64> {
        if points.len() < 2 {
            return None;
        }
        let mut steps: Vec<f64> = points.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
        steps.sort_by(f64::total_cmp);
        let upper = steps[(steps.len() * 3) / 4];
        if upper.is_nan() || upper <= 0.0 {
            return None;
        }
        Some(STATIONARY_FRACTION * upper)
    }

    /// Typical spacing of kept poses: the median step of increasing `u`.
    pub fn typical_step_of(u: &[f64]) -> f64 {
        let mut kept_steps: Vec<f64> = u.windows(2).map(|w| w[1] - w[0]).collect();
        if kept_steps.is_empty() {
            return 0.0;
        }
        kept_steps.sort_by(f64::total_cmp);
        kept_steps[kept_steps.len() / 2]
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
