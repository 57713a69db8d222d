//! Similarity transforms for the evaluation: the random frame changes applied
//! to test paths and the errors between two similarities (the least-squares
//! fit that recovers a noisy source's true similarity is the library's
//! [`Similarity3::fit`]).
//! All are [`Similarity3`] (`p_dst = s R p_src + t`), the library's own.

use nalgebra::{Matrix3, UnitQuaternion, Vector3, Vector4};
use rand::Rng;

use turnprint::geometry::Similarity3;
use turnprint::{Pose, Trajectory};

/// One standard normal sample (Box-Muller), so no extra distribution crate
/// is needed.
pub fn gaussian(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A rotation drawn uniformly from SO(3): a normalised 4D Gaussian vector is
/// a uniformly distributed unit quaternion.
pub fn random_rotation(rng: &mut impl Rng) -> UnitQuaternion<f64> {
    loop {
        let v = Vector4::new(gaussian(rng), gaussian(rng), gaussian(rng), gaussian(rng));
        if v.norm() > 1e-6 {
            return UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(v));
        }
    }
}

/// A random similarity: scale log-uniform in [0.01, 100], rotation uniform,
/// translation uniform in a cube of half-side `extent` (source units) times
/// the scale, so the translation is comparable to the path's own size.
pub fn random_similarity(rng: &mut impl Rng, extent: f64) -> Similarity3 {
    let scale = 10f64.powf(rng.random_range(-2.0..=2.0));
    let rotation = random_rotation(rng).to_rotation_matrix().into_inner();
    let translation = Vector3::new(
        rng.random_range(-1.0..=1.0),
        rng.random_range(-1.0..=1.0),
        rng.random_range(-1.0..=1.0),
    ) * (extent * scale);
    Similarity3 {
        scale,
        rotation,
        translation,
    }
}

/// `path` under a random similarity ([`random_similarity`], extent 100)
/// and driven the other way (its times negated, so that they still rise),
/// and the similarity that takes it back (`path_T_moved`).
#[allow(non_snake_case)]
pub fn moved_and_reversed(path: &Trajectory, rng: &mut impl Rng) -> (Trajectory, Similarity3) {
    let moved_T_path = random_similarity(rng, 100.0);
    let turn = UnitQuaternion::from_matrix(&moved_T_path.rotation);
    let poses = path
        .poses
        .iter()
        .rev()
        .map(|p| Pose {
            t: p.t.map(|t| -t),
            position: moved_T_path.apply(&p.position),
            orientation: p.orientation.map(|q| turn * q),
        })
        .collect();
    let moved = Trajectory {
        source: path.source.clone(),
        poses,
    };
    (moved, moved_T_path.inverse())
}

/// Angle (degrees) of the rotation taking `r_true` to `r_est`.
pub fn rotation_error_deg(r_est: &Matrix3<f64>, r_true: &Matrix3<f64>) -> f64 {
    turnprint::geometry::similarity::angle_between(r_est, r_true).to_degrees()
}

/// Relative scale error in percent: `100 |s_est / s_true - 1|`.
pub fn scale_error_pct(s_est: f64, s_true: f64) -> f64 {
    100.0 * (s_est / s_true - 1.0).abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};

    #[test]
    fn random_rotations_are_proper_and_spread() {
        let mut rng = StdRng::seed_from_u64(7);
        let mut mean_angle = 0.0;
        for _ in 0..500 {
            let m = random_rotation(&mut rng).to_rotation_matrix().into_inner();
            assert!((m * m.transpose() - Matrix3::identity()).norm() < 1e-12);
            assert!((m.determinant() - 1.0).abs() < 1e-12);
            mean_angle += rotation_error_deg(&m, &Matrix3::identity()) / 500.0;
        }
        // Uniform rotations have mean angle pi/2 + 2/pi rad = 126.5 deg.
        assert!((mean_angle - 126.5).abs() < 5.0, "mean angle {mean_angle}");
    }

    #[test]
    fn random_scales_span_four_decades() {
        let mut rng = StdRng::seed_from_u64(8);
        let scales: Vec<f64> = (0..2000)
            .map(|_| random_similarity(&mut rng, 100.0).scale)
            .collect();
        assert!(scales.iter().all(|s| (0.01..=100.0).contains(s)));
        let below_one = scales.iter().filter(|s| **s < 1.0).count();
        assert!((900..1100).contains(&below_one), "{below_one} below 1");
        assert!(scales.iter().any(|s| *s < 0.02) && scales.iter().any(|s| *s > 50.0));
    }

    #[test]
    fn fit_recovers_a_random_similarity() {
        let mut rng = StdRng::seed_from_u64(9);
        let src: Vec<Vector3<f64>> = (0..50)
            .map(|_| {
                Vector3::new(gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng)) * 30.0
            })
            .collect();
        for _ in 0..20 {
            let truth = random_similarity(&mut rng, 100.0);
            let dst: Vec<_> = src.iter().map(|p| truth.apply(p)).collect();
            let fit = Similarity3::fit(&src, &dst).unwrap();
            assert!(scale_error_pct(fit.scale, truth.scale) < 1e-8);
            assert!(rotation_error_deg(&fit.rotation, &truth.rotation) < 1e-5);
            let back = truth.inverse();
            assert!((back.apply(&dst[3]) - src[3]).norm() < 1e-6 * (1.0 + src[3].norm()));
        }
    }

    #[test]
    fn fit_rejects_degenerate_input() {
        let p = vec![Vector3::new(1.0, 2.0, 3.0); 5];
        assert!(Similarity3::fit(&p, &p).is_none());
        assert!(Similarity3::fit(&p[..2], &p[..2]).is_none());
    }

    /// Moved, reversed and taken back, a path is itself again, in its
    /// order; moved, its times still rise.
    #[test]
    #[allow(non_snake_case)]
    fn a_path_moved_and_reversed_is_taken_back_by_the_returned_similarity() {
        let path = Trajectory {
            source: "walk".into(),
            poses: (0..20)
                .map(|i| Pose {
                    t: Some(i as f64 * 0.1),
                    ..Pose::at(Vector3::new(i as f64, (i as f64 * 0.3).sin(), 0.5))
                })
                .collect(),
        };
        let (moved, path_T_moved) = moved_and_reversed(&path, &mut StdRng::seed_from_u64(3));
        assert!(moved.poses.windows(2).all(|w| w[0].t < w[1].t));
        for (p, m) in path.poses.iter().zip(moved.poses.iter().rev()) {
            assert!((path_T_moved.apply(&m.position) - p.position).norm() < 1e-9);
        }
    }
}
