//! Non-linear refinement of a relative pose on the spherical Sampson error,
//! with the information matrix that tells how well the matches determine it.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

use super::relative_pose::Correspondence;

/// Spherical Sampson error (radians): `fᵦᵀ E fₐ` over the norm of its
/// gradient in the tangent planes of both bearings, the first-order angular
/// distance of the pair to the epipolar constraint.
pub fn sampson_error(E: &Matrix3<f64>, c: &Correspondence) -> f64 {
    let line_b = E * c.a;
    let line_a = E.transpose() * c.b;
    let grad_b = line_b - c.b * c.b.dot(&line_b);
    let grad_a = line_a - c.a * c.a.dot(&line_a);
    c.b.dot(&line_b)
        / (grad_a.norm_squared() + grad_b.norm_squared())
            .sqrt()
            .max(1e-300)
}

/// Signed spherical Sampson residuals of the inliers in units of their noise.
fn residuals(
    R: &Rotation3<f64>,
    t: &Vector3<f64>,
    corr: &[Correspondence],
    idx: &[usize],
    out: &mut Vec<f64>,
) {
    out.clear();
    let E = t.cross_matrix() * R.matrix();
    out.extend(
        idx.iter()
            .map(|&i| sampson_error(&E, &corr[i]) / corr[i].sigma),
    );
}

/// Root mean square of the normalised angular epipolar errors of `idx` under `b_T_a = (R, t)`.
pub fn epipolar_rms(
    R: &Rotation3<f64>,
    t: &Vector3<f64>,
    corr: &[Correspondence],
    idx: &[usize],
) -> f64 {
    let mut r = Vec::new();
    residuals(R, &t.normalize(), corr, idx, &mut r);
    (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

/// Applies a 5-dof update: rotation vector `δ[0..3]` on the left of `R`,
/// tangent step `δ[3..5]` of the unit translation.
fn perturb(
    R: &Rotation3<f64>,
    t: &Vector3<f64>,
    d: &SVector<f64, 5>,
) -> (Rotation3<f64>, Vector3<f64>) {
    let e1 = t
        .cross(&if t.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        })
        .normalize();
    let e2 = t.cross(&e1);
    let R = Rotation3::new(Vector3::new(d[0], d[1], d[2])) * R;
    (R, (t + e1 * d[3] + e2 * d[4]).normalize())
}

/// `JᵀJ` and `Jᵀr` of the residuals at `(R, t)` (forward differences);
/// with residuals in units of their noise `JᵀJ` is the pose information matrix.
fn normal_equations(
    R: &Rotation3<f64>,
    t: &Vector3<f64>,
    corr: &[Correspondence],
    idx: &[usize],
    r0: &[f64],
    scratch: &mut Vec<f64>,
) -> (SMatrix<f64, 5, 5>, SVector<f64, 5>) {
    let h = 1e-7;
    let mut columns = vec![Vec::new(); 5];
    for (k, column) in columns.iter_mut().enumerate() {
        let mut d = SVector::<f64, 5>::zeros();
        d[k] = h;
        let (Rp, tp) = perturb(R, t, &d);
        residuals(&Rp, &tp, corr, idx, scratch);
        *column = scratch.iter().zip(r0).map(|(p, q)| (p - q) / h).collect();
    }
    let mut jtj = SMatrix::<f64, 5, 5>::zeros();
    let mut jtr = SVector::<f64, 5>::zeros();
    for p in 0..5 {
        jtr[p] = columns[p].iter().zip(r0).map(|(j, r)| j * r).sum();
        for q in p..5 {
            let v: f64 = columns[p].iter().zip(&columns[q]).map(|(x, y)| x * y).sum();
            jtj[(p, q)] = v;
            jtj[(q, p)] = v;
        }
    }
    (jtj, jtr)
}

/// Levenberg-Marquardt on the spherical Sampson residuals of the inliers:
/// the linear 8-point fit weighs rays unevenly, this minimises angular errors.
/// Returns the refined pose and its information matrix (rotation vector
/// first, then the two tangent directions of the unit translation).
pub fn refine_pose(
    R: Rotation3<f64>,
    t: Vector3<f64>,
    corr: &[Correspondence],
    idx: &[usize],
) -> (Rotation3<f64>, Vector3<f64>, SMatrix<f64, 5, 5>) {
    let (mut R, mut t) = (R, t.normalize());
    let (mut r0, mut r1, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
    residuals(&R, &t, corr, idx, &mut r0);
    let mut cost: f64 = r0.iter().map(|v| v * v).sum();
    let mut lambda = 1e-3;
    for _ in 0..40 {
        let (jtj, jtr) = normal_equations(&R, &t, corr, idx, &r0, &mut scratch);
        let mut improved = false;
        for _ in 0..5 {
            let mut damped = jtj;
            for k in 0..5 {
                damped[(k, k)] *= 1.0 + lambda;
            }
            let Some(step) = damped.cholesky().map(|c| c.solve(&(-jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let (Rn, tn) = perturb(&R, &t, &step);
            residuals(&Rn, &tn, corr, idx, &mut r1);
            let new_cost: f64 = r1.iter().map(|v| v * v).sum();
            if new_cost < cost {
                let gain = (cost - new_cost) / cost.max(1e-300);
                (R, t, cost) = (Rn, tn, new_cost);
                std::mem::swap(&mut r0, &mut r1);
                lambda = (lambda * 0.3).max(1e-9);
                improved = gain > 1e-10;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let (information, _) = normal_equations(&R, &t, corr, idx, &r0, &mut scratch);
    (R, t, information)
}
