//! The track: a smooth planar curve through the poses, with arc length,
//! heading and signed curvature on a uniform grid.
//!
//! Stages: [`chord`] (drop repeated and stationary poses, chord-length
//! parameter), [`smooth`] (kernel smoothing whose bandwidth is chosen from
//! the data by generalised cross-validation, widened past wobble), then
//! differential geometry on the smoothed grid ([`grid_step`]).

pub mod chord;
pub mod smooth;
pub mod stream;

use nalgebra::Vector2;

pub use chord::{ChordParam, ChordStream};
pub use smooth::Smoother;
pub use stream::{DiffStream, GridPoint, GridStream, TrackPoint};

/// Grid samples per smoothing bandwidth, at least: finer adds samples but no
/// shape, which the kernel has removed.
const SAMPLES_PER_BANDWIDTH: f64 = 8.0;

/// The step of the track's grid in `u`: half the typical pose spacing, or
/// an eighth of the bandwidth when that is wider (a path smoothed past its
/// wobble, `Smoother::choose`: TUM fr2/desk at 11 pose spacings kept 22
/// samples per bandwidth, 179 B of online history per pose).
pub fn grid_step(typical_step: f64, bandwidth: f64) -> f64 {
    (typical_step / 2.0).max(bandwidth / SAMPLES_PER_BANDWIDTH)
}

/// Smoothed curve sampled uniformly in the chord parameter `u`.
#[derive(Debug, Clone)]
pub struct Track {
    /// Smoothed positions.
    pub xy: Vec<Vector2<f64>>,
    /// Arc length of the smoothed curve at each sample.
    pub s: Vec<f64>,
    /// Unwrapped heading (radians).
    pub heading: Vec<f64>,
    /// Signed curvature `d heading / ds` (1 / path units).
    pub curvature: Vec<f64>,
    /// Fractional pose index of each sample.
    pub pose: Vec<f64>,
    /// Grid step in `u`.
    pub step: f64,
    /// Chord parameter of each original pose.
    pub pose_u: Vec<f64>,
    /// The smoothing bandwidth chosen (units of `u`).
    pub bandwidth: f64,
}

impl Track {
    /// Builds the track of 2D points (one per pose). `None` when the path
    /// does not move (fewer than three distinct positions).
    pub fn build(points: &[Vector2<f64>]) -> Option<Track> {
        let chord = ChordParam::new(points)?;
        let smoother = Smoother::choose(&chord);
        Some(Self::from_smoother(&chord, &smoother))
    }

    /// Samples the smoother on a grid of [`grid_step`] and differentiates it.
    pub fn from_smoother(chord: &ChordParam, smoother: &Smoother) -> Track {
        let step = grid_step(chord.typical_step, smoother.bandwidth);
        let total = chord.total();
        let m = ((total / step).ceil() as usize).max(2) + 1;
        let step = total / (m - 1) as f64;
        // The same streams the online detector runs, fed the whole path.
        let mut grid = GridStream::new(*smoother, step);
        let mut diff = DiffStream::new();
        let mut track = Track {
            xy: Vec::with_capacity(m),
            s: Vec::with_capacity(m),
            heading: Vec::with_capacity(m),
            curvature: Vec::with_capacity(m),
            pose: Vec::with_capacity(m),
            step,
            pose_u: chord.pose_u.clone(),
            bandwidth: smoother.bandwidth,
        };
        let mut sink = |p: TrackPoint| track.push(p);
        let mut feed = |g: GridPoint| diff.push(g, &mut sink);
        for k in 0..chord.u.len() {
            grid.push(chord.u[k], chord.points[k], chord.index[k], &mut feed);
        }
        grid.flush(m, &mut feed);
        diff.flush(&mut sink);
        track
    }

    /// Appends one final track sample.
    pub fn push(&mut self, p: TrackPoint) {
        self.xy.push(p.xy);
        self.s.push(p.s);
        self.heading.push(p.heading);
        self.curvature.push(p.curvature);
        self.pose.push(p.pose);
    }

    /// Number of grid samples.
    pub fn len(&self) -> usize {
        self.xy.len()
    }

    /// True when the track has no samples.
    pub fn is_empty(&self) -> bool {
        self.xy.is_empty()
    }

    /// Total arc length (from the first sample: a window of the online
    /// history keeps the history's arc, which does not start at 0).
    pub fn length(&self) -> f64 {
        match (self.s.first(), self.s.last()) {
            (Some(first), Some(last)) => last - first,
            _ => 0.0,
        }
    }

    /// Fractional grid index of the sample nearest to a pose.
    pub fn grid_of_pose(&self, pose: usize) -> f64 {
        self.pose_u[pose.min(self.pose_u.len() - 1)] / self.step
    }

    /// Linear interpolation of a per-sample quantity at a fractional index.
    pub fn interp(values: &[f64], at: f64) -> f64 {
        let n = values.len();
        if n == 0 {
            return 0.0;
        }
        let at = at.clamp(0.0, (n - 1) as f64);
        // Non-negative: truncation is the floor, without the libm call
        // `floor` is on baseline x86-64 (a hot path of growth).
        let i = (at as usize).min(n.saturating_sub(2));
        let f = at - i as f64;
        if i + 1 < n {
            values[i] * (1.0 - f) + values[i + 1] * f
        } else {
            values[i]
        }
    }

    /// Smoothed position at a fractional grid index.
    pub fn point_at(&self, at: f64) -> Vector2<f64> {
        lerp_point(&self.xy, at)
    }
}

/// Linear interpolation in a non-empty point list at a fractional index
/// (clamped to the list).
pub fn lerp_point(xy: &[Vector2<f64>], at: f64) -> Vector2<f64> {
    let n = xy.len();
    let at = at.clamp(0.0, (n - 1) as f64);
    let i = (at as usize).min(n.saturating_sub(2)); // (the floor: as above)
    let f = at - i as f64;
    xy[i] * (1.0 - f) + xy[(i + 1).min(n - 1)] * f
}

/// Arc length, unwrapped heading and curvature of a densely sampled curve
/// by central differences: `kappa = d(theta)/ds` (the [`DiffStream`] fed
/// the whole curve).
pub fn differentiate(xy: &[Vector2<f64>]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut diff = DiffStream::new();
    let (mut s, mut heading, mut curvature) = (Vec::new(), Vec::new(), Vec::new());
    let mut sink = |p: TrackPoint| {
        s.push(p.s);
        heading.push(p.heading);
        curvature.push(p.curvature);
    };
    for (i, p) in xy.iter().enumerate() {
        let g = GridPoint {
            u: i as f64,
            xy: *p,
            pose: i as f64,
        };
        diff.push(g, &mut sink);
    }
    diff.flush(&mut sink);
    (s, heading, curvature)
}

/// Removes 2π jumps so consecutive angles differ by less than π.
pub fn unwrap(angles: &mut [f64]) {
    use std::f64::consts::{PI, TAU};
    for i in 1..angles.len() {
        let mut d = angles[i] - angles[i - 1];
        d -= TAU * ((d + PI) / TAU).floor();
        angles[i] = angles[i - 1] + d;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path that starts slowly (steps a tenth of a bandwidth) and then
    /// drives at steps of twenty bandwidths: the smoothing chosen on the
    /// slow start left every grid sample of a later step on one pose, and
    /// rounding noise between those equal samples counted as turning
    /// (KITTI 00 entered at a tenth of its speed: 120° per pose). A 90°
    /// arc must turn 90°.
    #[test]
    fn steps_far_wider_than_the_smoothing_add_no_turning() {
        let mut points: Vec<Vector2<f64>> = (0..200)
            .map(|i| Vector2::new(0.1 * i as f64, 0.0))
            .collect();
        let (r, step) = (100.0, 2.0);
        let n = (std::f64::consts::FRAC_PI_2 * r / step) as usize;
        for k in 0..=n {
            let a = k as f64 * step / r;
            points.push(Vector2::new(20.0 + r * a.sin(), r * (1.0 - a.cos())));
        }
        let chord = ChordParam::new(&points).expect("a moving path");
        let track = Track::from_smoother(&chord, &Smoother { bandwidth: 0.1 });
        let turning: f64 = track.curvature.iter().map(|k| k.abs() * track.step).sum();
        assert!(
            (turning.to_degrees() - 90.0).abs() < 10.0,
            "{}° of turning",
            turning.to_degrees()
        );
    }

    /// A window cut from the online history keeps the history's arc
    /// lengths; its length is its own, not the history's up to its end.
    #[test]
    fn the_length_of_a_window_does_not_count_the_path_before_it() {
        let road: Vec<Vector2<f64>> = (0..100).map(|i| Vector2::new(i as f64, 0.0)).collect();
        let mut track = Track::build(&road).expect("a moving path");
        let whole = track.length();
        for s in &mut track.s {
            *s += 1.0e4;
        }
        assert!((track.length() - whole).abs() < 1e-9 * whole);
        assert!((whole - 99.0).abs() < 3.0, "{whole}");
    }
}
