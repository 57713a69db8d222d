//! Homographies between bearing vectors, used to recognise planar (or
//! parallax-free) scenes in which the essential matrix leaves the pose
//! ambiguous.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, SymmetricEigen, Vector3};

use super::refine::sampson_error;
use super::relative_pose::{
    needed_iterations, Correspondence, PoseParams, SplitMix, MIN_ITERATIONS,
};

/// Homography between bearings, `f_b ∝ H f_a`, from >= 4 correspondences
/// (least squares on `f_b × H f_a = 0`).
fn homography(corr: &[Correspondence], idx: &[usize]) -> Option<Matrix3<f64>> {
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for &i in idx {
        let (a, b) = (&corr[i].a, &corr[i].b);
        let mut rows = [SVector::<f64, 9>::zeros(); 3];
        for j in 0..3 {
            rows[0][6 + j] = b.y * a[j];
            rows[0][3 + j] = -b.z * a[j];
            rows[1][j] = b.z * a[j];
            rows[1][6 + j] = -b.x * a[j];
            rows[2][3 + j] = b.x * a[j];
            rows[2][j] = -b.y * a[j];
        }
        for r in &rows {
            ata.syger(1.0, r, r, 1.0);
        }
    }
    let eig = SymmetricEigen::new(ata);
    let k = eig.eigenvalues.imin();
    let h = eig.eigenvectors.column(k);
    let H = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    H.iter().all(|v| v.is_finite()).then_some(H)
}

/// Inliers of a homography: the angle between `f_b` and `±H f_a` below `k σ`.
fn homography_inliers(H: &Matrix3<f64>, corr: &[Correspondence], k: f64, out: &mut Vec<usize>) {
    out.clear();
    for (i, c) in corr.iter().enumerate() {
        let v = H * c.a;
        let sin = c.b.cross(&v).norm() / v.norm().max(1e-300);
        if sin < k * c.sigma {
            out.push(i);
        }
    }
}

/// Best homography among `subset` (RANSAC on 4-point samples, then a refit).
pub(super) fn ransac_homography(
    corr: &[Correspondence],
    subset: &[usize],
    p: &PoseParams,
    rng: &mut SplitMix,
) -> Option<Matrix3<f64>> {
    let sub: Vec<Correspondence> = subset.iter().map(|&i| corr[i]).collect();
    let n = sub.len();
    if n < 4 {
        return None;
    }
    let (mut best, mut best_H, mut sample, mut inl) = (
        Vec::new(),
        None,
        Vec::with_capacity(4),
        Vec::with_capacity(n),
    );
    let mut iterations = p.max_iterations;
    let mut it = 0;
    while it < iterations {
        it += 1;
        rng.sample(n, 4, &mut sample);
        let Some(H) = homography(&sub, &sample) else {
            continue;
        };
        homography_inliers(&H, &sub, p.threshold_sigmas, &mut inl);
        if inl.len() > best.len() {
            std::mem::swap(&mut best, &mut inl);
            best_H = Some(H);
            iterations = needed_iterations(best.len(), n, 4, p.confidence, p.max_iterations)
                .max(MIN_ITERATIONS);
        }
    }
    if best.len() >= 4 {
        if let Some(H) = homography(&sub, &best) {
            homography_inliers(&H, &sub, p.threshold_sigmas, &mut inl);
            if inl.len() >= best.len() {
                return Some(H);
            }
        }
    }
    best_H
}

/// Chi-square bounds (95 %) of a one- and a two-dimensional normalised error.
const CHI2_1: f64 = 3.84;
const CHI2_2: f64 = 5.99;

/// Share of the homography in the model-selection scores of ORB-SLAM
/// (Mur-Artal et al. 2015): `S_M = Σ max(0, Γ - e²)` over all matches with the
/// model's inlier bound (`χ²₁` for the epipolar, `χ²₂` for the transfer
/// error) and the common `Γ = χ²₂`; `S_H / (S_H + S_E)` above 0.45 means a
/// plane (or too little parallax) explains the matches as well as the
/// essential matrix, whose pose is then ambiguous.
pub(super) fn homography_share(
    R: &Rotation3<f64>,
    t: &Vector3<f64>,
    H: &Matrix3<f64>,
    corr: &[Correspondence],
) -> f64 {
    let E = t.cross_matrix() * R.matrix();
    let (mut s_e, mut s_h) = (0.0, 0.0);
    for c in corr {
        let e2 = (sampson_error(&E, c) / c.sigma).powi(2);
        if e2 < CHI2_1 {
            s_e += CHI2_2 - e2;
        }
        let v = H * c.a;
        let h2 = (c.b.cross(&v).norm() / v.norm().max(1e-300) / c.sigma).powi(2);
        if h2 < CHI2_2 {
            s_h += CHI2_2 - h2;
        }
    }
    if s_e + s_h <= 0.0 {
        0.0
    } else {
        s_h / (s_e + s_h)
    }
}
