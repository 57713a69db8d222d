//! Kernel smoothing of the path in its chord parameter, with the bandwidth
//! chosen from the data by generalised cross-validation (GCV).
//!
//! A Gaussian kernel smoother is the local-constant equivalent of a
//! smoothing spline; its hat-matrix trace is known in closed form, so GCV
//! costs one pass per candidate bandwidth. Bandwidths are multiples of the
//! typical pose spacing: the choice is scale-free. GCV keeps what the poses
//! follow precisely, a hand's tremor included; the bandwidth is then widened
//! while the path's total turning falls like wobble's, which no real turn's
//! does, and past the noise no wider than a quarter of the road between
//! the path's turns.

use nalgebra::Vector2;

use super::ChordParam;

/// Candidate bandwidths, in units of the typical pose spacing.
const BANDWIDTH_STEPS: [f64; 6] = [1.0, 1.5, 2.0, 3.0, 4.5, 6.0];
/// A narrower candidate for sparse paths (see [`SPARSE_TURN`]).
const SPARSE_STEP: f64 = 0.7;
/// A path is sparse when it turns this much (radians) between consecutive
/// poses at its turns (the [`SPARSE_QUANTILE`] of the per-pose turns): 1 Hz
/// GPS at city speeds turns 30-60° per fix at an intersection, 10 Hz
/// odometry 5°. One pose spacing of smoothing then rounds every
/// intersection into a wide curve that no longer matches a dense path of the
/// same road (KITTI 00 ground truth thinned to 1 Hz lost its true match at
/// 1.0 spacings and kept it at 0.7). Dense paths keep the 1.0 floor: less
/// smoothing there only adds curvature jitter, which moves weak segment
/// boundaries between the two directions of travel.
const SPARSE_TURN: f64 = 0.25;
/// Quantile of the per-pose turns compared with [`SPARSE_TURN`].
const SPARSE_QUANTILE: f64 = 0.95;
/// The kernel is cut at this many bandwidths, and lowered by its value
/// there so that a pose's weight falls to zero continuously as it leaves the
/// reach. Cut without the offset, the weight jumped from 1.1 % to nothing:
/// a pose crossing the reach moved the curvature of a circle by 2.5 %, and
/// with equally spaced poses whether it had crossed was decided by rounding
/// (`tests/stages_analytic.rs`).
const CUTOFF: f64 = 3.0;
/// Mean turning per kept pose (radians) above which a path may be sampled
/// below its wobble: vehicles turn 0.4-0.8° per pose at 10 Hz, sparse GPS
/// 5-7° (its turning does not fall with the bandwidth), a hand-held camera's
/// motion capture at 300 Hz 10° (TUM fr2/desk).
const WOBBLE_TURN_PER_POSE: f64 = 3.0 * std::f64::consts::PI / 180.0;
/// While total turning falls at least like `bandwidth^-0.5`, the smoother
/// still follows wobble, not turns: white position noise falls like
/// `bandwidth^-1.5`, a rounded corner's turning not at all.
const WOBBLE_SLOPE: f64 = 0.5;
/// Turning that falls at least like `bandwidth^-1` is still noise: white
/// position noise falls like `bandwidth^-1.5`, a hand's tremor at 300 Hz
/// like `bandwidth^-1.6` (TUM fr2/desk); the streets of a walk or of a
/// planned route like `bandwidth^-0.4` to `^-0.85`, GPS wander alike.
const NOISE_SLOPE: f64 = 1.0;
/// Past the noise ([`NOISE_SLOPE`]) the widening stops before the bandwidth
/// exceeds this share of the road between the smoothed path's right-angle
/// turns (its length over its turning in quarter turns): two turns that
/// far apart blur into one once the kernel's ±2 sigma spans the road
/// between them. A GPS walk's turning falls like `bandwidth^-0.7` at every
/// scale, so the slope test alone takes it to [`WOBBLE_MAX_STEPS`] pose
/// spacings whatever its rate: 83 m at a fix a second, 405 m at a fix every
/// five seconds, where the thinned walk no longer matches its planned route
/// (smoothed over 14 m; `tests/merge_alike.rs`). Here: 83 and 200 m.
const TURN_SPACING_SHARE: f64 = 0.25;
/// The widest bandwidth the wobble test may reach, in pose spacings.
const WOBBLE_MAX_STEPS: f64 = 64.0;
/// ... and the fewest of the wider bandwidths the path must still span: the
/// slope of a short stretch says little (the online warm-up of the Intel lab
/// log, 24 kept poses turning on the spot, was doubled at 16).
const WOBBLE_MIN_BANDWIDTHS: f64 = 32.0;

/// A Gaussian kernel smoother of a given bandwidth (units of `u`).
#[derive(Debug, Clone, Copy)]
pub struct Smoother {
    /// Standard deviation of the kernel in chord-parameter units.
    pub bandwidth: f64,
}

impl Smoother {
    /// The bandwidth among `BANDWIDTH_STEPS` (and `SPARSE_STEP` for a
    /// sparse path) with the lowest GCV score, doubled while the path's
    /// total turning falls like wobble's (`WOBBLE_*`).
    pub fn choose(chord: &ChordParam) -> Smoother {
        let sparse = is_sparse(&chord.points);
        let steps = sparse
            .then_some(SPARSE_STEP)
            .into_iter()
            .chain(BANDWIDTH_STEPS);
        // (GCV score, steps, fitted points)
        let mut best = (f64::INFINITY, BANDWIDTH_STEPS[0], Vec::new());
        for k in steps {
            let sm = Smoother {
                bandwidth: k * chord.typical_step,
            };
            let (g, fits) = sm.gcv_and_fits(chord);
            if g < best.0 {
                best = (g, k, fits);
            }
        }
        // GCV keeps the bandwidth where the poses are precise, even when
        // they follow a hand's tremor or a drone's hover rather than a path:
        // such a path turns several degrees per pose and its turning falls
        // steeply with the bandwidth, which no real turn does (a corner
        // rounded by a wider kernel turns as much). Widen while it falls.
        let mut k = best.1;
        let mut turning = turning_of(&best.2);
        let widest = (chord.points.len() as f64 / WOBBLE_MIN_BANDWIDTHS).min(WOBBLE_MAX_STEPS);
        if turning > WOBBLE_TURN_PER_POSE * chord.points.len() as f64 {
            while 2.0 * k <= widest {
                let wider = Smoother {
                    bandwidth: 2.0 * k * chord.typical_step,
                }
                .turning(chord);
                let slope = (turning / wider).log2();
                if !(wider > 0.0 && slope >= WOBBLE_SLOPE) {
                    break;
                }
                // Past the noise, no wider than the turns' own spacing allows.
                let between_turns = chord.total() * std::f64::consts::FRAC_PI_2 / wider;
                if slope < NOISE_SLOPE
                    && 2.0 * k * chord.typical_step > TURN_SPACING_SHARE * between_turns
                {
                    break;
                }
                k *= 2.0;
                turning = wider;
            }
        }
        Smoother {
            bandwidth: k * chord.typical_step,
        }
    }

    /// Total turning (radians) of the smoothed path through the kept poses.
    fn turning(&self, chord: &ChordParam) -> f64 {
        turning_of(&self.gcv_and_fits(chord).1)
    }

    /// GCV score `n RSS / (n - tr H)^2` at the kept poses.
    pub fn gcv(&self, chord: &ChordParam) -> f64 {
        self.gcv_and_fits(chord).0
    }

    /// [`Smoother::gcv`] and the smoothed points at the kept poses.
    fn gcv_and_fits(&self, chord: &ChordParam) -> (f64, Vec<Vector2<f64>>) {
        let n = chord.points.len();
        let (mut rss, mut trace) = (0.0, 0.0);
        let mut lo = 0;
        let mut fits = Vec::with_capacity(n);
        for i in 0..n {
            let (fit, self_weight) = self.at(chord, chord.u[i], &mut lo);
            rss += (fit - chord.points[i]).norm_squared();
            trace += self_weight;
            fits.push(fit);
        }
        let dof = n as f64 - trace;
        if dof <= 1.0 {
            return (f64::INFINITY, fits);
        }
        (n as f64 * rss / (dof * dof), fits)
    }

    /// Smoothed position at `u` and the normalised weight of the nearest
    /// kept pose when `u` is exactly a kept pose's parameter (for the trace).
    /// `lo` is a cursor for monotone queries.
    fn at(&self, chord: &ChordParam, u: f64, lo: &mut usize) -> (Vector2<f64>, f64) {
        let reach = CUTOFF * self.bandwidth;
        while *lo < chord.u.len() && chord.u[*lo] < u - reach {
            *lo += 1;
        }
        let window = chord.u[*lo..]
            .iter()
            .copied()
            .zip(chord.points[*lo..].iter().copied());
        match self.kernel(window, u) {
            Some(fit) => fit,
            None => {
                // Beyond the kernel reach of every pose: nearest pose.
                let k = chord.u.partition_point(|&x| x < u).min(chord.u.len() - 1);
                (chord.points[k], 1.0)
            }
        }
    }

    /// How far the kernel reaches (units of `u`): points further than this
    /// from `u` carry no weight, so a grid sample is final once a point
    /// beyond `u + reach()` has arrived.
    pub fn reach(&self) -> f64 {
        CUTOFF * self.bandwidth
    }

    /// The kernel-weighted mean at `u` of `(u_j, p_j)` pairs in increasing
    /// `u_j`, starting at the first within reach (the sum stops at the first
    /// beyond it), and the normalised self weight. `None` when no point is
    /// within reach. One implementation for batch and stream.
    pub fn kernel(
        &self,
        window: impl Iterator<Item = (f64, Vector2<f64>)>,
        u: f64,
    ) -> Option<(Vector2<f64>, f64)> {
        let h = self.bandwidth;
        let reach = CUTOFF * h;
        let inv = 1.0 / (2.0 * h * h);
        let floor = (-0.5 * CUTOFF * CUTOFF).exp();
        let (mut acc, mut w_sum, mut w_self) = (Vector2::zeros(), 0.0, 0.0);
        for (uj, pj) in window {
            if uj > u + reach {
                break;
            }
            if uj < u - reach {
                continue;
            }
            let d = uj - u;
            let w = ((-d * d * inv).exp() - floor).max(0.0);
            acc += w * pj;
            w_sum += w;
            if d == 0.0 {
                w_self = w;
            }
        }
        (w_sum > 0.0).then(|| (acc / w_sum, w_self / w_sum))
    }
}

/// The absolute turn (radians) at each vertex of a polyline, between its
/// consecutive non-zero steps.
fn step_turns(points: &[Vector2<f64>]) -> impl Iterator<Item = f64> + '_ {
    let mut prev: Option<Vector2<f64>> = None;
    points.windows(2).filter_map(move |w| {
        let d = w[1] - w[0];
        if d.norm_squared() == 0.0 {
            return None;
        }
        let turn = prev.map(|e| e.perp(&d).atan2(e.dot(&d)).abs());
        prev = Some(d);
        turn
    })
}

/// Total turning (radians) of a polyline.
fn turning_of(points: &[Vector2<f64>]) -> f64 {
    step_turns(points).sum()
}

/// True when the path turns more than [`SPARSE_TURN`] between consecutive
/// poses at its turns (scale-free: an angle per pose).
fn is_sparse(points: &[Vector2<f64>]) -> bool {
    let mut turns: Vec<f64> = step_turns(points).collect();
    if turns.is_empty() {
        return false;
    }
    let k = ((turns.len() - 1) as f64 * SPARSE_QUANTILE).round() as usize;
    let (_, q, _) = turns.select_nth_unstable_by(k, f64::total_cmp);
    *q > SPARSE_TURN
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Twice round a circle, 2 000 poses a lap, with a tremor across the
    /// path of `amplitude` (fraction of the radius) and a wavelength of a
    /// few pose spacings, like a hand-held camera under motion capture.
    fn circle_with_tremor(amplitude: f64) -> ChordParam {
        let points: Vec<Vector2<f64>> = (0..4000)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 2000.0;
                let r = 1.0 + amplitude * ((i as f64 * 1.1).sin() + 0.7 * (i as f64 * 2.3).cos());
                Vector2::new(r * a.cos(), r * a.sin())
            })
            .collect();
        ChordParam::new(&points).expect("moves")
    }

    #[test]
    fn tremor_is_smoothed_away_and_a_clean_turn_is_not() {
        let shaky = circle_with_tremor(0.002);
        let k = Smoother::choose(&shaky).bandwidth / shaky.typical_step;
        assert!(k >= 4.0, "{k} spacings");
        // What is left turns like the circle: twice 360°, within 10 %.
        let turning = Smoother::choose(&shaky).turning(&shaky).to_degrees();
        assert!((turning / 720.0 - 1.0).abs() < 0.1, "{turning}°");
        let clean = circle_with_tremor(0.0);
        let k = Smoother::choose(&clean).bandwidth / clean.typical_step;
        assert!(k <= BANDWIDTH_STEPS[1], "{k} spacings");
    }
}
