//! Absolute and relative pose error of positions, as evo defines them:
//! APE aligns the estimate to the truth by Umeyama (SE(3), or Sim(3) for an
//! estimate of unknown scale) and takes the statistics of the position
//! errors; RPE compares each step of `delta` poses, frame-free.

#![allow(non_snake_case)]

use nalgebra::Vector3;
use turnprint::geometry::Similarity3;

/// The alignment applied before the errors are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Alignment {
    /// Rotation and translation (evo `-a`).
    Se3,
    /// Rotation, translation and scale (evo `-as`).
    Sim3,
}

/// Statistics of a set of errors (evo's `rmse`, `mean`, `median`, `max`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorStats {
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// Largest.
    pub max: f64,
}

impl ErrorStats {
    /// Statistics of `errors`; `None` when empty.
    pub fn of(errors: &[f64]) -> Option<Self> {
        if errors.is_empty() {
            return None;
        }
        let n = errors.len() as f64;
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let m = sorted.len();
        // numpy's median: the mean of the two middle values for even counts.
        let median = if m % 2 == 1 {
            sorted[m / 2]
        } else {
            0.5 * (sorted[m / 2 - 1] + sorted[m / 2])
        };
        Some(ErrorStats {
            rmse: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
            mean: errors.iter().sum::<f64>() / n,
            median,
            max: sorted[m - 1],
        })
    }
}

/// `truth_T_estimate` by Umeyama, with or without scale.
fn align(est: &[Vector3<f64>], gt: &[Vector3<f64>], alignment: Alignment) -> Option<Similarity3> {
    match alignment {
        Alignment::Se3 => Similarity3::fit_rigid(est, gt),
        Alignment::Sim3 => Similarity3::fit(est, gt),
    }
}

/// APE of the translation part: `estimate[i]` pairs with `truth[i]`.
/// `None` for fewer than 3 pairs or a degenerate estimate.
pub fn ape(
    estimate: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    alignment: Alignment,
) -> Option<ErrorStats> {
    let n = estimate.len().min(truth.len());
    let (est, gt) = (&estimate[..n], &truth[..n]);
    let truth_T_estimate = align(est, gt, alignment)?;
    let errors: Vec<f64> = est
        .iter()
        .zip(gt)
        .map(|(e, g)| (truth_T_estimate.apply(e) - g).norm())
        .collect();
    ErrorStats::of(&errors)
}

/// RPE of the translation part over steps of `delta` poses, on positions
/// only: the length of the difference of each step's displacement vectors
/// after the estimate is rotated (and, for Sim(3), scaled) into the truth's
/// frame by the APE alignment. evo's RPE on full poses expresses each step
/// in its own pose frame instead; with positions only this is the nearest
/// frame-free measure, so it is not compared with evo.
pub fn rpe_positions(
    estimate: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    delta: usize,
    alignment: Alignment,
) -> Option<ErrorStats> {
    let n = estimate.len().min(truth.len());
    let (est, gt) = (&estimate[..n], &truth[..n]);
    let a = align(est, gt, alignment)?;
    let delta = delta.max(1);
    let errors: Vec<f64> = (0..n.saturating_sub(delta))
        .map(|i| {
            let de = a.scale * (a.rotation * (est[i + delta] - est[i]));
            (de - (gt[i + delta] - gt[i])).norm()
        })
        .collect();
    ErrorStats::of(&errors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    #[test]
    fn a_moved_copy_of_the_truth_has_no_error_after_alignment() {
        let truth: Vec<_> = (0..50)
            .map(|i| Vector3::new(i as f64, (i as f64 * 0.3).sin() * 5.0, 0.1 * i as f64))
            .collect();
        let r = Rotation3::from_euler_angles(0.3, -0.2, 1.1);
        let moved: Vec<_> = truth
            .iter()
            .map(|p| r * p + Vector3::new(5.0, -3.0, 2.0))
            .collect();
        assert!(ape(&moved, &truth, Alignment::Se3).unwrap().rmse < 1e-9);
        let scaled: Vec<_> = moved.iter().map(|p| 0.1 * p).collect();
        assert!(ape(&scaled, &truth, Alignment::Sim3).unwrap().rmse < 1e-9);
        assert!(ape(&scaled, &truth, Alignment::Se3).unwrap().rmse > 1.0);
    }

    #[test]
    fn a_constant_offset_on_half_the_path_shows_as_its_rms() {
        // A planar circle, every other pose 1 above it and the rest 1 below:
        // no rigid motion takes that away.
        let truth: Vec<_> = (0..100)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 100.0;
                Vector3::new(50.0 * a.cos(), 50.0 * a.sin(), 0.0)
            })
            .collect();
        let est: Vec<_> = truth
            .iter()
            .enumerate()
            .map(|(i, p)| p + Vector3::new(0.0, 0.0, if i % 2 == 0 { 1.0 } else { -1.0 }))
            .collect();
        let s = ape(&est, &truth, Alignment::Se3).unwrap();
        assert!(
            (s.rmse - 1.0).abs() < 1e-6 && (s.median - 1.0).abs() < 1e-6,
            "{s:?}"
        );
    }
}
