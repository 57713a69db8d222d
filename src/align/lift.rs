//! The 3D similarity of a matched overlap. The 2D stages see each path in
//! its own best-fit plane; a path that climbs or bends out of that plane
//! (a hill, a ramp) tilts its plane, so the planes' lift maps the common
//! road with a tilt error that grows with the distance from the overlap's
//! centre. The overlap's own 3D correspondences remove it.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use super::{MAX_SCALE_FACTOR, MUCH_CLOSER};
use crate::geometry::Similarity3;

/// Thinnest spread across the correspondences (square root of the ratio of
/// the two largest scatter eigenvalues) that still fixes a 3D rotation: a
/// straight road leaves the roll about itself free.
const MIN_SPREAD_RATIO: f64 = 0.05;
/// Largest rotation (radians) the 3D fit may add to the lift: tilts between
/// a path's plane and its road are a few degrees, more means the fit is
/// misled (noisy heights, a near-degenerate spread), unless it is much
/// closer (`align::MUCH_CLOSER`; the lift of a 30 % part of TUM fr2/desk
/// was 22-43° and 1-19 % in scale off).
const MAX_TILT: f64 = 0.15;
/// Largest relative scale change the 3D fit may make to the lift.
const MAX_SCALE_CHANGE: f64 = 0.05;

/// Refines the lifted similarity `a_T_b` by the least-squares 3D fit of
/// corresponding points (`p_a ~ a_T_b p_b`), when they span enough to fix a
/// rotation and the fit stays near the lift or brings the points much
/// closer; otherwise returns the lift.
#[allow(non_snake_case)]
pub fn refine_lift(a_T_b: &Similarity3, pairs: &[(Vector3<f64>, Vector3<f64>)]) -> Similarity3 {
    let (p_a, p_b): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = pairs.iter().copied().unzip();
    if !spread_enough(&p_b) {
        return *a_T_b;
    }
    let Some(fit) = Similarity3::fit(&p_b, &p_a) else {
        return *a_T_b;
    };
    let scale_change = (fit.scale / a_T_b.scale - 1.0).abs();
    let near = fit.angle_to(a_T_b) <= MAX_TILT && scale_change <= MAX_SCALE_CHANGE;
    let closer = || {
        (fit.scale / a_T_b.scale).ln().abs() <= MAX_SCALE_FACTOR.ln()
            && MUCH_CLOSER * median_residual(&fit, pairs) / fit.scale
                < median_residual(a_T_b, pairs) / a_T_b.scale
    };
    if near || closer() {
        fit
    } else {
        *a_T_b
    }
}

/// Distance between `p_a` and `a_T_b p_b` of each pair.
#[allow(non_snake_case)]
fn residuals<'a>(
    a_T_b: &'a Similarity3,
    pairs: &'a [(Vector3<f64>, Vector3<f64>)],
) -> impl Iterator<Item = f64> + 'a {
    pairs
        .iter()
        .map(|(p_a, p_b)| (p_a - a_T_b.apply(p_b)).norm())
}

/// Median distance between `p_a` and `a_T_b p_b` over the pairs.
#[allow(non_snake_case)]
fn median_residual(a_T_b: &Similarity3, pairs: &[(Vector3<f64>, Vector3<f64>)]) -> f64 {
    let mut d: Vec<f64> = residuals(a_T_b, pairs).collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0)
}

/// RMS distance between `p_a` and `a_T_b p_b` over the pairs (infinite for
/// none: nothing measured).
#[allow(non_snake_case)]
pub fn rms_residual(a_T_b: &Similarity3, pairs: &[(Vector3<f64>, Vector3<f64>)]) -> f64 {
    if pairs.is_empty() {
        return f64::INFINITY;
    }
    let sum: f64 = residuals(a_T_b, pairs).map(|d| d * d).sum();
    (sum / pairs.len() as f64).sqrt()
}

/// Whether the points spread in two directions, not along one line.
fn spread_enough(points: &[Vector3<f64>]) -> bool {
    if points.len() < 3 {
        return false;
    }
    let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let scatter = points.iter().fold(Matrix3::zeros(), |acc, p| {
        let d = p - mean;
        acc + d * d.transpose()
    });
    let mut eig = SymmetricEigen::new(scatter).eigenvalues;
    eig.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    eig[0] > 0.0 && (eig[1].max(0.0) / eig[0]).sqrt() >= MIN_SPREAD_RATIO
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// A road that turns and climbs: its 3D fit fixes a small tilt of the lift.
    #[test]
    #[allow(non_snake_case)]
    fn a_tilted_lift_is_corrected_by_the_overlap_points() {
        let truth = Similarity3 {
            scale: 2.0,
            rotation: *Rotation3::from_euler_angles(0.3, -0.2, 1.0).matrix(),
            translation: Vector3::new(5.0, -3.0, 1.0),
        };
        let p_b: Vec<Vector3<f64>> = (0..100)
            .map(|i| {
                let t = i as f64 / 99.0 * std::f64::consts::PI;
                Vector3::new(50.0 * t.cos(), 50.0 * t.sin(), 8.0 * t)
            })
            .collect();
        let pairs: Vec<_> = p_b.iter().map(|p| (truth.apply(p), *p)).collect();
        let tilt = Rotation3::from_euler_angles(0.05, 0.0, 0.0);
        let lifted = Similarity3 {
            rotation: tilt.matrix() * truth.rotation,
            ..truth
        };
        let refined = refine_lift(&lifted, &pairs);
        assert!((refined.rotation - truth.rotation).norm() < 1e-9);
        assert!((refined.scale - truth.scale).abs() < 1e-9);
    }

    /// A path that leaves every plane (a drone, a hand-held camera): the
    /// lift may be off by tens of degrees, and the fit, four times closer,
    /// replaces it.
    #[test]
    #[allow(non_snake_case)]
    fn a_lift_far_off_is_replaced_when_the_fit_is_much_closer() {
        let truth = Similarity3 {
            scale: 0.5,
            rotation: *Rotation3::from_euler_angles(-0.4, 0.7, 2.0).matrix(),
            translation: Vector3::new(1.0, 2.0, -3.0),
        };
        let p_b: Vec<Vector3<f64>> = (0..200)
            .map(|i| {
                let t = i as f64 / 199.0 * 4.0 * std::f64::consts::PI;
                Vector3::new(2.0 * t.cos(), 2.0 * t.sin(), (1.5 * t).sin())
            })
            .collect();
        let pairs: Vec<_> = p_b.iter().map(|p| (truth.apply(p), *p)).collect();
        let lifted = Similarity3 {
            rotation: Rotation3::from_euler_angles(0.5, 0.0, 0.2).matrix() * truth.rotation,
            ..truth
        };
        let refined = refine_lift(&lifted, &pairs);
        assert!((refined.rotation - truth.rotation).norm() < 1e-9);
    }

    /// A straight road leaves its roll free: the lift is kept.
    #[test]
    fn a_straight_overlap_keeps_the_lift() {
        let p_b: Vec<Vector3<f64>> = (0..50).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        let pairs: Vec<_> = p_b.iter().map(|p| (*p, *p)).collect();
        let lifted = Similarity3 {
            rotation: *Rotation3::from_euler_angles(0.1, 0.0, 0.0).matrix(),
            ..Similarity3::identity()
        };
        assert_eq!(refine_lift(&lifted, &pairs), lifted);
    }
}
