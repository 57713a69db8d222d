//! Chord-length parameter of a path: repeated and stationary poses collapse
//! onto one parameter value, so a robot standing still adds no length and no
//! spurious turns; a pose that jitters back against the direction of travel
//! is left out the same way, so the path keeps going forward.

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

/// Moving steps are of two kinds when their [`step_spread`] exceeds this:
/// every KITTI, EuRoC, TUM and CARMEN path of the shared data reads 1.0-2.3
/// whole; the Intel lab robot's first 400 poses (a short drive, then
/// turning on the spot) read 18.
const STEP_SPREAD: f64 = 3.0;

/// How mixed the (sorted, positive) step lengths are: the step below which
/// half the distance is covered over the median step (1 for equal steps;
/// scale-free). Infinite when there are none.
fn step_spread(sorted_moving: &[f64]) -> f64 {
    if sorted_moving.is_empty() {
        return f64::INFINITY;
    }
    let median = sorted_moving[sorted_moving.len() / 2];
    length_quantile(sorted_moving, 0.5) / median
}

/// The step length below which fraction `q` of the distance is covered
/// (`sorted` ascending).
fn length_quantile(sorted: &[f64], q: f64) -> f64 {
    let target = q * sorted.iter().sum::<f64>();
    let mut covered = 0.0;
    for d in sorted {
        covered += d;
        if covered >= target {
            return *d;
        }
    }
    sorted.last().copied().unwrap_or(0.0)
}

/// A pose closer than this fraction of the typical moving step to the last
/// kept pose is treated as standing still (jitter of a stopped robot).
const STATIONARY_FRACTION: f64 = 0.25;

/// A pose that steps back against the direction of travel (more than 90°
/// from both the last kept step and the chord of the last two) by less
/// than that chord is jitter, not a reversal: it is left out like a
/// stationary pose. Real monocular VO does this: ORB-SLAM2 on KITTI 06
/// steps back by an eighth of a step every other frame over whole
/// stretches, and 13-16 % of the poses of 05 and 06 step back. Kept, each
/// such pose is a cusp, 180° of spurious turning that no smoothing removes
/// where the back step exceeds the stationary threshold (a 9-pose stretch
/// of 06 showed 696° and matched a U-turn: regressions
/// `tests::a_sawtooth_of_back_steps_goes_forward` and
/// `tests/merge_real.rs::back_steps_of_mono_06_do_not_make_turns`).
/// A true reversal moves back further than the two steps before it and is
/// kept from there on; a sharp turn of a sparse path (a 1 Hz GPS at an
/// intersection) turns less than 90° from its last step.
const BACK_STEPS: usize = 2;

/// The chord parameter one point at a time: a point is kept when it moved
/// at least `min_step` from the last kept point and is no back step (see
/// `BACK_STEPS`); every point (kept or not) gets the parameter of the last
/// kept point. [`ChordParam::new`] runs the same loop over a whole path.
#[derive(Debug, Clone)]
pub struct ChordStream {
    /// Smallest move that counts (path units; chosen from data, see
    /// [`ChordParam::min_step_of`]).
    pub min_step: f64,
    /// The last kept points, newest last: the first `count` of them.
    kept: [Vector2<f64>; BACK_STEPS + 1],
    count: usize,
    u: f64,
}

impl ChordStream {
    /// A stream that keeps moves of at least `min_step`.
    pub fn new(min_step: f64) -> Self {
        ChordStream {
            min_step,
            kept: [Vector2::zeros(); BACK_STEPS + 1],
            count: 0,
            u: 0.0,
        }
    }

    /// Feeds one point: its chord parameter and whether it was kept.
    pub fn push(&mut self, p: Vector2<f64>) -> (f64, bool) {
        let Some(last) = self.last() else {
            self.kept[0] = p;
            self.count = 1;
            return (0.0, true);
        };
        let step = p - last;
        let d = step.norm();
        if d < self.min_step {
            return (self.u, false);
        }
        if self.count > BACK_STEPS {
            let chord = last - self.kept[0];
            let back = step.dot(&chord) < 0.0 && step.dot(&(last - self.kept[1])) < 0.0;
            if back && d < chord.norm() {
                return (self.u, false);
            }
            self.kept.rotate_left(1);
            self.count -= 1;
        }
        self.u += d;
        self.kept[self.count] = p;
        self.count += 1;
        (self.u, true)
    }

    /// Chord parameter of the last kept point.
    pub fn u(&self) -> f64 {
        self.u
    }

    /// The last kept point.
    pub fn last(&self) -> Option<Vector2<f64>> {
        self.count.checked_sub(1).map(|i| self.kept[i])
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
    ///
    /// When the moving steps are of two kinds (`step_spread` above
    /// `STEP_SPREAD`: a robot idling with jitter, or creeping while it
    /// turns on the spot, for much of the path) the quantile is taken by
    /// distance covered, not by count: jitter covers little distance. (The
    /// online warm-up chooses from a prefix: the Intel lab robot's first
    /// 400 poses, a short drive and then a turn on the spot, gave a 1.4 mm
    /// step against its 29 mm driving step, counted; 25 mm by distance.)
    /// Counted, where most poses are jitter (a robot idling for minutes
    /// before a drive), the threshold fell to the jitter's own steps, every
    /// jitter pose was kept, and its turning filled the signature.
    pub fn min_step_of(points: &[Vector2<f64>]) -> Option<f64> {
        if points.len() < 2 {
            return None;
        }
        let mut steps: Vec<f64> = points.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
        steps.sort_by(f64::total_cmp);
        let first_moving = steps.partition_point(|d| *d <= 0.0);
        let upper = if step_spread(&steps[first_moving..]) > STEP_SPREAD {
            length_quantile(&steps, 0.75)
        } else {
            steps[(steps.len() * 3) / 4]
        };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// 9 000 poses of a robot idling with jitter (steps of about a
    /// hundredth of its driving step), then 1 000 driving: counted, the
    /// jitter set the stationary threshold below its own steps and every
    /// jitter pose was kept (and turned). By distance, it is a quarter of
    /// a driving step again.
    #[test]
    fn idling_jitter_does_not_set_the_stationary_threshold() {
        // A fixed pseudo-random jitter of +-1 cm around the origin.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut jitter = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 0.02 - 0.01
        };
        let mut points: Vec<Vector2<f64>> = (0..9000)
            .map(|_| Vector2::new(jitter(), jitter()))
            .collect();
        points.extend((1..=1000).map(|i| Vector2::new(i as f64, 0.0)));
        let min_step = ChordParam::min_step_of(&points).expect("it moves");
        assert!((min_step - 0.25).abs() < 0.01, "threshold {min_step}");
        // Steps of one kind keep the counted quantile.
        let driving: Vec<Vector2<f64>> = (0..100).map(|i| Vector2::new(i as f64, 0.0)).collect();
        assert_eq!(ChordParam::min_step_of(&driving), Some(0.25));
    }

    #[test]
    fn step_spread_is_one_for_equal_steps_and_large_for_two_kinds() {
        assert_eq!(step_spread(&[2.0; 10]), 1.0);
        let mut mixed = vec![0.01; 90];
        mixed.extend([1.0; 10]);
        assert!(step_spread(&mixed) > 50.0);
        assert_eq!(step_spread(&[]), f64::INFINITY);
    }
    use crate::track::Track;

    /// Total turning of the track, radians.
    fn turning(points: &[Vector2<f64>]) -> f64 {
        let t = Track::build(points).expect("track");
        t.heading.windows(2).map(|w| (w[1] - w[0]).abs()).sum()
    }

    /// ORB-SLAM2 on KITTI 06: every other pose steps back by an eighth of
    /// the forward step, along a straight road driven faster than the
    /// rest, so the back steps pass the stationary threshold; each was a
    /// cusp.
    #[test]
    fn a_sawtooth_of_back_steps_goes_forward() {
        let mut points = Vec::new();
        let mut x = 0.0;
        for i in 0..400 {
            x += match i {
                0..300 => 0.3,
                _ if i % 2 == 0 => 1.0,
                _ => -0.12,
            };
            // Lateral noise, so that each cusp has a direction to turn to.
            points.push(Vector2::new(x, 0.002 * ((i * 7919) % 13) as f64));
        }
        let chord = ChordParam::new(&points).expect("moves");
        for w in chord.points.windows(3) {
            assert!((w[2] - w[1]).dot(&(w[1] - w[0])) > 0.0, "kept a back step");
        }
        // The same road without the back steps turns about as little.
        let forward: Vec<_> = points
            .iter()
            .enumerate()
            .filter(|(i, _)| *i < 300 || i % 2 == 0)
            .map(|(_, p)| *p)
            .collect();
        let (turn, reference) = (turning(&points), turning(&forward));
        assert!(
            turn < 2.0 * reference + 0.1,
            "turning {turn} rad on a straight road ({reference} without the back steps)"
        );
    }

    /// A robot that drives forward and then backs up the same way keeps
    /// both legs: only jitter is left out.
    #[test]
    fn a_true_reversal_is_kept() {
        let mut points: Vec<Vector2<f64>> = (0..40).map(|i| Vector2::new(i as f64, 0.0)).collect();
        points.extend((0..40).map(|i| Vector2::new(38.0 - i as f64, 0.5)));
        let chord = ChordParam::new(&points).expect("moves");
        let min_x = chord.points[40..]
            .iter()
            .map(|p| p.x)
            .fold(f64::INFINITY, f64::min);
        assert!(min_x < 0.0, "the backward leg was lost: min x {min_x}");
        assert!(chord.points.len() >= 75, "kept {}", chord.points.len());
    }

    /// A sparse path (a 1 Hz fix every 70° of a tight U-turn) keeps every
    /// fix: a sharp turn is not a back step.
    #[test]
    fn a_sharp_turn_of_a_sparse_path_keeps_every_fix() {
        let mut points = vec![Vector2::new(0.0, 0.0)];
        let mut heading: f64 = 0.0;
        for i in 0..12 {
            if (3..6).contains(&i) {
                heading += 70f64.to_radians();
            }
            let last = *points.last().unwrap();
            points.push(last + 10.0 * Vector2::new(heading.cos(), heading.sin()));
        }
        let chord = ChordParam::new(&points).expect("moves");
        assert_eq!(chord.points.len(), points.len());
    }
}
