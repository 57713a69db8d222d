//! Kernel smoothing of the path in its chord parameter, with the bandwidth
//! chosen from the data by generalised cross-validation (GCV).
//!
//! A Gaussian kernel smoother is the local-constant equivalent of a
//! smoothing spline; its hat-matrix trace is known in closed form, so GCV
//! costs one pass per candidate bandwidth. Bandwidths are multiples of the
//! typical pose spacing: the choice is scale-free.

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
/// The kernel is cut at this many bandwidths.
const CUTOFF: f64 = 3.0;

/// A Gaussian kernel smoother of a given bandwidth (units of `u`).
#[derive(Debug, Clone, Copy)]
pub struct Smoother {
    /// Standard deviation of the kernel in chord-parameter units.
    pub bandwidth: f64,
}

impl Smoother {
    /// The bandwidth among `BANDWIDTH_STEPS` (and `SPARSE_STEP` for a
    /// sparse path) with the lowest GCV score.
    pub fn choose(chord: &ChordParam) -> Smoother {
        let sparse = is_sparse(&chord.points);
        let steps = sparse
            .then_some(SPARSE_STEP)
            .into_iter()
            .chain(BANDWIDTH_STEPS);
        let mut best = (f64::INFINITY, BANDWIDTH_STEPS[0]);
        for k in steps {
            let sm = Smoother {
                bandwidth: k * chord.typical_step,
            };
            let g = sm.gcv(chord);
            if g < best.0 {
                best = (g, k);
            }
        }
        Smoother {
            bandwidth: best.1 * chord.typical_step,
        }
    }

    /// GCV score `n RSS / (n - tr H)^2` at the kept poses.
    pub fn gcv(&self, chord: &ChordParam) -> f64 {
        let n = chord.points.len();
        let (mut rss, mut trace) = (0.0, 0.0);
        let mut lo = 0;
        for i in 0..n {
            let (fit, self_weight) = self.at(chord, chord.u[i], &mut lo);
            rss += (fit - chord.points[i]).norm_squared();
            trace += self_weight;
        }
        let dof = n as f64 - trace;
        if dof <= 1.0 {
            return f64::INFINITY;
        }
        n as f64 * rss / (dof * dof)
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
        let (mut acc, mut w_sum, mut w_self) = (Vector2::zeros(), 0.0, 0.0);
        for (uj, pj) in window {
            if uj > u + reach {
                break;
            }
            if uj < u - reach {
                continue;
            }
            let d = uj - u;
            let w = (-d * d * inv).exp();
            acc += w * pj;
            w_sum += w;
            if d == 0.0 {
                w_self = w;
            }
        }
        (w_sum > 0.0).then(|| (acc / w_sum, w_self / w_sum))
    }
}

/// True when the path turns more than [`SPARSE_TURN`] between consecutive
/// poses at its turns (scale-free: an angle per pose).
fn is_sparse(points: &[Vector2<f64>]) -> bool {
    let mut turns: Vec<f64> = points
        .windows(3)
        .filter_map(|w| {
            let (d0, d1) = (w[1] - w[0], w[2] - w[1]);
            let n = d0.norm() * d1.norm();
            (n > 0.0).then(|| (d0.perp(&d1)).atan2(d0.dot(&d1)).abs())
        })
        .collect();
    if turns.is_empty() {
        return false;
    }
    let k = ((turns.len() - 1) as f64 * SPARSE_QUANTILE).round() as usize;
    let (_, q, _) = turns.select_nth_unstable_by(k, f64::total_cmp);
    *q > SPARSE_TURN
}
