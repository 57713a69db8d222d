//! Relative pose of two calibrated cameras from matched bearing vectors.
//!
//! Works on unit bearings, so any pair of camera models (pinhole, fisheye,
//! omnidirectional) is handled by the same maths:
//!
//! * Epipolar constraint: with `x_b = R x_a + t` (the pose `b_T_a`), matched
//!   bearings satisfy `f_bᵀ E f_a = 0`, `E = [t]ₓ R`.
//! * Minimal-ish solver: the linear 8-point method on bearings; each row of the
//!   design matrix is `f_b ⊗ f_a`, `E` is its null vector projected onto the
//!   essential manifold (singular values 1, 1, 0).
//! * Error: the spherical Sampson error, `f_bᵀ E f_a` over the norm of its
//!   gradient in the tangent planes of both bearings (radians, first order);
//!   inliers are below `threshold_sigmas` times the pair's angular noise
//!   `sqrt(σ_a² + σ_b²)`, σ the angle of one pixel at the keypoint's pyramid
//!   level. RANSAC scores by MSAC; the pose is refined by Levenberg-Marquardt
//!   on the same error.
//! * When the baseline is too small to observe (pure rotation, the essential
//!   matrix is then undefined) a rotation-only model `f_b = R f_a` fitted by
//!   two-point RANSAC explains as many matches; the pose is then reported with
//!   a zero translation.
//!
//! Acceptance needs, besides a consistent model (defaults in parentheses):
//!
//! * at least `min_inliers` inliers (30) and an inlier ratio of at least
//!   `min_inlier_ratio` (0.25) of the matches;
//! * a unique optimum: no second local optimum more than `rival_rotation`
//!   (5°) away whose MSAC cost is within `rival_cost_margin` (2 χ²₂(95 %))
//!   of the best (near-planar scenes and narrow overlaps leave two poses
//!   that fit equally well, which no local covariance shows);
//! * a well-conditioned fit: rotation standard deviation from the
//!   refinement's information matrix below `max_rotation_std` (5°);
//! * a homography taking at most `max_homography_share` (0.55) of the
//!   ORB-SLAM model-selection score (planar scene);
//! * at least `min_cheirality` (80 %) of the inliers with measurable parallax
//!   in front of both cameras.
//!
//! A translation direction less certain than `max_translation_std` (10°) is
//! not reported (rotation only). Inliers: Sampson error below
//! `threshold_sigmas` (2) σ.

#![allow(non_snake_case)]

use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, SymmetricEigen, Vector3};

use super::homography::{homography_share, ransac_homography};
pub use super::refine::{epipolar_rms, refine_pose, sampson_error};

/// RANSAC always draws at least this many samples: adaptive stopping alone
/// ends too early when a near-degenerate sample (all far points) fits many.
pub(super) const MIN_ITERATIONS: usize = 50;

/// The 95 % bound of a two-dimensional chi-square, the unit of cost margins.
const CHI2_GAMMA: f64 = 5.99;

/// One matched pair of bearings with their angular noise (radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correspondence {
    /// Unit bearing in camera a.
    pub a: Vector3<f64>,
    /// Unit bearing in camera b.
    pub b: Vector3<f64>,
    /// Combined angular noise of the pair, `sqrt(σ_a² + σ_b²)`.
    pub sigma: f64,
}

/// Thresholds of the relative-pose test; all are angles in units of the
/// keypoint noise, counts or fractions (no metric quantities).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseParams {
    /// Inlier when the angular error is below this many σ.
    pub threshold_sigmas: f64,
    /// Most RANSAC iterations per model.
    pub max_iterations: usize,
    /// Probability of drawing one all-inlier sample, for adaptive stopping.
    pub confidence: f64,
    /// Fewest inliers accepted.
    pub min_inliers: usize,
    /// Smallest fraction of the matches that must be inliers.
    pub min_inlier_ratio: f64,
    /// Largest standard deviation (radians) of the refined rotation; a
    /// larger one means the matches do not determine the pose (degenerate).
    pub max_rotation_std: f64,
    /// Largest standard deviation (radians) of the translation direction for
    /// it to be reported; beyond it the pose is reported as rotation only.
    pub max_translation_std: f64,
    /// A second local optimum at least this far in rotation (radians) ...
    pub rival_rotation: f64,
    /// ... whose MSAC cost (sum of squared normalised errors, truncated) is
    /// within this margin of the best makes the pose ambiguous.
    pub rival_cost_margin: f64,
    /// Rejected as planar (ambiguous pose) when a homography takes more than
    /// this share of the model-selection score (ORB-SLAM uses 0.45).
    pub max_homography_share: f64,
    /// Smallest fraction of inliers with parallax that triangulate in front of both cameras.
    pub min_cheirality: f64,
    /// The rotation-only model is chosen when its inliers reach this fraction
    /// of the essential-matrix inliers.
    pub rotation_only_fraction: f64,
}

impl Default for PoseParams {
    fn default() -> Self {
        PoseParams {
            threshold_sigmas: 2.0,
            max_iterations: 1000,
            confidence: 0.999,
            min_inliers: 30,
            min_inlier_ratio: 0.25,
            max_rotation_std: 5f64.to_radians(),
            max_translation_std: 10f64.to_radians(),
            rival_rotation: 5f64.to_radians(),
            rival_cost_margin: 2.0 * CHI2_GAMMA,
            max_homography_share: 0.55,
            min_cheirality: 0.8,
            rotation_only_fraction: 0.9,
        }
    }
}

/// Which model explained the matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseKind {
    /// Rotation and translation direction from the essential matrix.
    General,
    /// Baseline too small to observe: rotation only, translation reported as zero.
    RotationOnly,
}

/// An accepted relative pose `b_T_a` (maps points from camera a to camera b).
#[derive(Debug, Clone, PartialEq)]
pub struct RelativePose {
    /// Rotation from a to b.
    pub b_R_a: Rotation3<f64>,
    /// Unit translation direction (position of a's origin seen in b), zero when rotation only.
    pub b_t_a: Vector3<f64>,
    /// Indices of the inlier correspondences.
    pub inliers: Vec<usize>,
    /// Model that explained the matches.
    pub kind: PoseKind,
    /// Standard deviation (radians) of the rotation, from the refinement (NaN for the rotation-only model).
    pub rotation_std: f64,
    /// Standard deviation (radians) of the translation direction (NaN for the rotation-only model).
    pub translation_std: f64,
}

/// Result of the relative-pose test.
#[derive(Debug, Clone, PartialEq)]
pub enum PoseOutcome {
    /// A consistent, well-conditioned pose with enough inliers.
    Accepted(RelativePose),
    /// Why no pose was accepted, with the best inlier count seen.
    Rejected {
        /// Why no pose was accepted.
        reason: String,
        /// Inliers of the best model seen (0 when none was fitted).
        inliers: usize,
    },
}

/// SplitMix64: a tiny deterministic generator so verdicts are reproducible.
pub(super) struct SplitMix(pub(super) u64);

impl SplitMix {
    pub(super) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// `k` distinct indices below `n` (k << n).
    pub(super) fn sample(&mut self, n: usize, k: usize, out: &mut Vec<usize>) {
        out.clear();
        while out.len() < k {
            let i = (self.next() % n as u64) as usize;
            if !out.contains(&i) {
                out.push(i);
            }
        }
    }
}

/// `Σ r rᵀ` with `r = f_b ⊗ f_a`, the normal matrix of the 8-point system.
fn normal_matrix(corr: &[Correspondence], idx: &[usize]) -> SMatrix<f64, 9, 9> {
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for &i in idx {
        let c = &corr[i];
        let mut r = SVector::<f64, 9>::zeros();
        for p in 0..3 {
            for q in 0..3 {
                r[3 * p + q] = c.b[p] * c.a[q];
            }
        }
        ata.syger(1.0, &r, &r, 1.0);
    }
    ata
}

/// Essential matrix from >= 8 correspondences (least squares).
fn eight_point(corr: &[Correspondence], idx: &[usize]) -> Option<Matrix3<f64>> {
    let eig = SymmetricEigen::new(normal_matrix(corr, idx));
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let e = eig.eigenvectors.column(order[0]);
    let E = Matrix3::new(e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8]);
    let svd = E.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let E = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) * v_t;
    E.iter().all(|v| v.is_finite()).then_some(E)
}

/// Collects the inliers of `E` and returns the MSAC cost (squared normalised
/// error, truncated at `k²`), which prefers tight fits among equal counts.
fn essential_inliers(
    E: &Matrix3<f64>,
    corr: &[Correspondence],
    k: f64,
    out: &mut Vec<usize>,
) -> f64 {
    out.clear();
    let mut cost = 0.0;
    for (i, c) in corr.iter().enumerate() {
        let e = sampson_error(E, c).abs() / c.sigma;
        if e < k {
            out.push(i);
            cost += e * e;
        } else {
            cost += k * k;
        }
    }
    cost
}

/// Rotation minimising `Σ |f_b - R f_a|²` (Kabsch).
fn kabsch(corr: &[Correspondence], idx: &[usize]) -> Option<Rotation3<f64>> {
    let mut h = Matrix3::zeros();
    for &i in idx {
        h += corr[i].b * corr[i].a.transpose();
    }
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    Some(Rotation3::from_matrix_unchecked(r))
}

/// Collects the inliers of a pure rotation and returns its MSAC cost.
fn rotation_inliers(
    R: &Rotation3<f64>,
    corr: &[Correspondence],
    k: f64,
    out: &mut Vec<usize>,
) -> f64 {
    out.clear();
    let mut cost = 0.0;
    for (i, c) in corr.iter().enumerate() {
        let e = (R * c.a).angle(&c.b) / c.sigma;
        if e < k {
            out.push(i);
            cost += e * e;
        } else {
            cost += k * k;
        }
    }
    cost
}

/// Iterations needed to draw one all-inlier sample of size `s` with probability `p`.
pub(super) fn needed_iterations(inliers: usize, n: usize, s: i32, p: f64, cap: usize) -> usize {
    let w = inliers as f64 / n as f64;
    let all = w.powi(s);
    if all <= 0.0 {
        return cap;
    }
    if all >= 1.0 {
        return 1;
    }
    (((1.0 - p).ln() / (1.0 - all).ln()).ceil() as usize).min(cap)
}

/// Depths `(d_a, d_b)` of the point seen along `a` and `b` with `d_b b = d_a R a + t` (least squares).
fn triangulate_depths(R: &Matrix3<f64>, t: &Vector3<f64>, c: &Correspondence) -> (f64, f64) {
    let m1 = -(R * c.a);
    let m2 = c.b;
    let (a11, a12, a22) = (m1.dot(&m1), m1.dot(&m2), m2.dot(&m2));
    let (r1, r2) = (m1.dot(t), m2.dot(t));
    let det = a11 * a22 - a12 * a12;
    if det.abs() < 1e-12 {
        return (f64::INFINITY, f64::INFINITY);
    }
    ((a22 * r1 - a12 * r2) / det, (a11 * r2 - a12 * r1) / det)
}

/// Fraction of the informative inliers (parallax above the noise, so that
/// the sign of their depth is measured) that triangulate in front of both
/// cameras; 1 when no inlier is informative.
fn cheirality(
    R: &Rotation3<f64>,
    t: &Vector3<f64>,
    corr: &[Correspondence],
    inliers: &[usize],
) -> f64 {
    let (mut informative, mut front) = (0usize, 0usize);
    for &i in inliers {
        let c = &corr[i];
        if (R * c.a).angle(&c.b) < 2.0 * c.sigma {
            continue;
        }
        informative += 1;
        let (da, db) = triangulate_depths(R.matrix(), t, c);
        if da > 0.0 && db > 0.0 {
            front += 1;
        }
    }
    if informative == 0 {
        1.0
    } else {
        front as f64 / informative as f64
    }
}

/// The decomposition of `E` whose inliers lie in front of both cameras, with that fraction.
fn decompose(
    E: &Matrix3<f64>,
    corr: &[Correspondence],
    inliers: &[usize],
) -> Option<(Rotation3<f64>, Vector3<f64>, f64)> {
    let svd = E.svd(true, true);
    let (mut u, v_t) = (svd.u?, svd.v_t?);
    let mut v = v_t.transpose();
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v.determinant() < 0.0 {
        v = -v;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let t: Vector3<f64> = u.column(2).into();
    let mut best: Option<(Rotation3<f64>, Vector3<f64>, f64)> = None;
    for R in [u * w * v.transpose(), u * w.transpose() * v.transpose()] {
        for t in [t, -t] {
            let R = Rotation3::from_matrix_unchecked(R);
            let fraction = cheirality(&R, &t, corr, inliers);
            if best.as_ref().is_none_or(|b| fraction > b.2) {
                best = Some((R, t, fraction));
            }
        }
    }
    best
}

/// Number of successive best RANSAC models that are locally optimised.
const LOCAL_STARTS: usize = 4;
/// Number of distinct cheap models kept to look for a rival optimum.
const RIVAL_POOL: usize = 6;

/// A general pose hypothesis after local optimisation.
struct Refined {
    R: Rotation3<f64>,
    t: Vector3<f64>,
    inliers: Vec<usize>,
    cost: f64,
    information: SMatrix<f64, 5, 5>,
}

/// Local optimisation of one essential matrix: decompose (cheirality), then
/// alternately refine on the inliers and re-select them, since the inlier set
/// of a rough model holds a few wrong matches that pull the refinement off.
fn local_optimise(
    E: &Matrix3<f64>,
    corr: &[Correspondence],
    inliers: &[usize],
    p: &PoseParams,
) -> Option<Refined> {
    let (mut R, mut t, _) = decompose(E, corr, inliers)?;
    let mut current = inliers.to_vec();
    let mut selected = Vec::with_capacity(corr.len());
    let mut cost = f64::INFINITY;
    let mut information = SMatrix::<f64, 5, 5>::zeros();
    for _ in 0..3 {
        (R, t, information) = refine_pose(R, t, corr, &current);
        cost = essential_inliers(
            &(t.cross_matrix() * R.matrix()),
            corr,
            p.threshold_sigmas,
            &mut selected,
        );
        if selected == current || selected.len() < 8 {
            break;
        }
        std::mem::swap(&mut selected, &mut current);
    }
    if current.len() < 8 {
        return None;
    }
    // The Sampson error cannot tell the four decompositions of E apart: choose again by cheirality.
    let (R, t, _) = decompose(&(t.cross_matrix() * R.matrix()), corr, &current)?;
    Some(Refined {
        R,
        t,
        inliers: current,
        cost,
        information,
    })
}

/// LO-RANSAC for the essential matrix: MSAC over 8-point samples, then the
/// last few best models are locally optimised and the lowest cost wins
/// (the angular cost has local minima along the rotation-translation
/// ambiguity of narrow fields of view, so one start is not enough).
fn ransac_essential(
    corr: &[Correspondence],
    p: &PoseParams,
    rng: &mut SplitMix,
) -> Option<(Refined, Option<Refined>)> {
    let n = corr.len();
    let mut best_cost = f64::INFINITY;
    let mut starts: Vec<(Matrix3<f64>, Vec<usize>)> = Vec::new();
    // The cheapest mutually distinct models, to look for a rival optimum.
    let mut pool: Vec<(f64, Matrix3<f64>, Vec<usize>)> = Vec::new();
    let (mut sample, mut inl) = (Vec::with_capacity(8), Vec::with_capacity(n));
    let mut iterations = p.max_iterations;
    let mut it = 0;
    while it < iterations {
        it += 1;
        rng.sample(n, 8, &mut sample);
        let Some(E) = eight_point(corr, &sample) else {
            continue;
        };
        let cost = essential_inliers(&E, corr, p.threshold_sigmas, &mut inl);
        if cost < best_cost {
            best_cost = cost;
            if starts.len() == LOCAL_STARTS {
                starts.remove(0);
            }
            starts.push((E, inl.clone()));
            iterations = needed_iterations(inl.len(), n, 8, p.confidence, p.max_iterations)
                .max(MIN_ITERATIONS);
        }
        let worst = pool.iter().map(|m| m.0).fold(f64::NEG_INFINITY, f64::max);
        if pool.len() < RIVAL_POOL || cost < worst {
            let near = pool
                .iter()
                .position(|m| (m.1 - E).norm().min((m.1 + E).norm()) < 0.3);
            match near {
                Some(k) if cost < pool[k].0 => pool[k] = (cost, E, inl.clone()),
                Some(_) => {}
                None => {
                    if pool.len() == RIVAL_POOL {
                        let k = pool
                            .iter()
                            .enumerate()
                            .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
                            .map_or(0, |(k, _)| k);
                        pool.swap_remove(k);
                    }
                    pool.push((cost, E, inl.clone()));
                }
            }
        }
    }
    // Refine every start; the lowest cost wins, and the best optimum whose
    // rotation differs clearly from the winner's is its rival.
    // Near-identical starts (same E up to sign) converge alike: optimise one.
    let mut distinct: Vec<(&Matrix3<f64>, &Vec<usize>)> = Vec::new();
    for (E, inliers) in starts
        .iter()
        .rev()
        .map(|(E, i)| (E, i))
        .chain(pool.iter().map(|(_, E, i)| (E, i)))
    {
        if inliers.len() >= 8
            && distinct
                .iter()
                .all(|(F, _)| (*F - E).norm().min((*F + E).norm()) >= 0.3)
        {
            distinct.push((E, inliers));
        }
    }
    let mut refined: Vec<Refined> = distinct
        .into_iter()
        .filter_map(|(E, inliers)| local_optimise(E, corr, inliers, p))
        .collect();
    let k = refined
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.cost.total_cmp(&b.1.cost))
        .map(|(k, _)| k)?;
    let best = refined.swap_remove(k);
    let rival = refined
        .into_iter()
        .filter(|r| (r.R.inverse() * best.R).angle() > p.rival_rotation)
        .min_by(|a, b| a.cost.total_cmp(&b.cost));
    Some((best, rival))
}

/// Two-point RANSAC for a pure rotation, refitted on its inliers.
fn ransac_rotation(
    corr: &[Correspondence],
    p: &PoseParams,
    rng: &mut SplitMix,
) -> (Option<Rotation3<f64>>, Vec<usize>) {
    let n = corr.len();
    let (mut best_R, mut best, mut best_cost) = (None, Vec::new(), f64::INFINITY);
    let (mut sample, mut inl) = (Vec::with_capacity(2), Vec::with_capacity(n));
    let mut iterations = p.max_iterations;
    let mut it = 0;
    while it < iterations {
        it += 1;
        rng.sample(n, 2, &mut sample);
        let Some(R) = kabsch(corr, &sample) else {
            continue;
        };
        let cost = rotation_inliers(&R, corr, p.threshold_sigmas, &mut inl);
        if cost < best_cost {
            best_cost = cost;
            std::mem::swap(&mut best, &mut inl);
            best_R = Some(R);
            iterations = needed_iterations(best.len(), n, 2, p.confidence, p.max_iterations)
                .max(MIN_ITERATIONS);
        }
    }
    for _ in 0..3 {
        if best.len() < 2 {
            break;
        }
        let Some(R) = kabsch(corr, &best) else { break };
        let cost = rotation_inliers(&R, corr, p.threshold_sigmas, &mut inl);
        if cost >= best_cost {
            break;
        }
        best_cost = cost;
        std::mem::swap(&mut best, &mut inl);
        best_R = Some(R);
    }
    (best_R, best)
}

/// Estimates and checks the relative pose `b_T_a` from matched bearings.
/// `seed` makes the RANSAC sampling reproducible.
pub fn estimate_relative_pose(corr: &[Correspondence], p: &PoseParams, seed: u64) -> PoseOutcome {
    let n = corr.len();
    if n < p.min_inliers.max(8) {
        return PoseOutcome::Rejected {
            reason: format!("{n} matches, fewer than {} needed", p.min_inliers.max(8)),
            inliers: 0,
        };
    }
    let mut rng = SplitMix(seed ^ 0x5DEE_CE66_D1CE_4E5B);
    let (general, rival) = match ransac_essential(corr, p, &mut rng) {
        Some((best, rival)) => (Some(best), rival),
        None => (None, None),
    };
    let (R_only, r_inliers) = ransac_rotation(corr, p, &mut rng);
    let e_inliers = general.as_ref().map_or(Vec::new(), |g| g.inliers.clone());
    let best_count = e_inliers.len().max(r_inliers.len());
    let ratio_needed = (p.min_inlier_ratio * n as f64).ceil() as usize;
    let enough = |count: usize| count >= p.min_inliers && count >= ratio_needed;
    if !enough(best_count) {
        return PoseOutcome::Rejected {
            reason: format!(
                "{best_count} inliers of {n} matches (need {} and {:.0} %)",
                p.min_inliers,
                100.0 * p.min_inlier_ratio
            ),
            inliers: best_count,
        };
    }
    if r_inliers.len() as f64 >= p.rotation_only_fraction * e_inliers.len() as f64 {
        if let Some(R) = R_only {
            return PoseOutcome::Accepted(RelativePose {
                b_R_a: R,
                b_t_a: Vector3::zeros(),
                inliers: r_inliers,
                kind: PoseKind::RotationOnly,
                rotation_std: f64::NAN,
                translation_std: f64::NAN,
            });
        }
    }
    let Some(Refined {
        R,
        t,
        information,
        cost,
        ..
    }) = general
    else {
        return PoseOutcome::Rejected {
            reason: "no essential matrix".into(),
            inliers: 0,
        };
    };
    if !enough(e_inliers.len()) {
        return PoseOutcome::Rejected {
            reason: format!("{} essential inliers of {n} matches", e_inliers.len()),
            inliers: e_inliers.len(),
        };
    }
    // Two clearly different poses that fit about equally well: the matches
    // do not decide (near-planar or narrow overlap), whatever the local
    // covariance of either says.
    if let Some(r) = &rival {
        if r.cost - cost < p.rival_cost_margin {
            return PoseOutcome::Rejected {
                reason: format!(
                    "ambiguous pose: a second pose {:.1}° away fits nearly as well (cost {:.1} vs {:.1})",
                    (r.R.inverse() * R).angle().to_degrees(),
                    r.cost,
                    cost
                ),
                inliers: e_inliers.len(),
            };
        }
    }
    let (rotation_std, translation_std) = pose_std(&information);
    if rotation_std.is_nan() || rotation_std > p.max_rotation_std {
        return PoseOutcome::Rejected {
            reason: format!(
                "ill-conditioned pose: rotation σ {:.3}° > {:.3}°",
                rotation_std.to_degrees(),
                p.max_rotation_std.to_degrees()
            ),
            inliers: e_inliers.len(),
        };
    }
    // A plane explains the matches: the essential matrix has a twofold
    // ambiguity that no covariance shows, so the pose is not determined.
    if let Some(H) = ransac_homography(corr, &e_inliers, p, &mut rng) {
        let share = homography_share(&R, &t, &H, corr);
        if share > p.max_homography_share {
            return PoseOutcome::Rejected {
                reason: format!("planar scene: the homography takes {:.0} % of the model score, the pose is ambiguous", 100.0 * share),
                inliers: e_inliers.len(),
            };
        }
    }
    let front = cheirality(&R, &t, corr, &e_inliers);
    if front < p.min_cheirality {
        return PoseOutcome::Rejected {
            reason: format!(
                "only {:.0} % of inliers with parallax in front of both cameras",
                100.0 * front
            ),
            inliers: e_inliers.len(),
        };
    }
    // A rotation well determined with a translation direction that is not
    // (parallax close to the noise): report the rotation only.
    let kind = if translation_std <= p.max_translation_std {
        PoseKind::General
    } else {
        PoseKind::RotationOnly
    };
    let b_t_a = if kind == PoseKind::General {
        t.normalize()
    } else {
        Vector3::zeros()
    };
    PoseOutcome::Accepted(RelativePose {
        b_R_a: R,
        b_t_a,
        inliers: e_inliers,
        kind,
        rotation_std,
        translation_std,
    })
}

/// Largest standard deviations (radians) of the rotation and of the
/// translation direction, from the inverse of the information matrix.
fn pose_std(information: &SMatrix<f64, 5, 5>) -> (f64, f64) {
    let Some(cov) = information.try_inverse() else {
        return (f64::INFINITY, f64::INFINITY);
    };
    let rot = SymmetricEigen::new(cov.fixed_view::<3, 3>(0, 0).into_owned())
        .eigenvalues
        .max();
    let tra = SymmetricEigen::new(cov.fixed_view::<2, 2>(3, 3).into_owned())
        .eigenvalues
        .max();
    (rot.max(0.0).sqrt(), tra.max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Synthetic scene: known `b_T_a`, exact bearings plus a few outliers.
    #[test]
    fn recovers_a_known_pose_from_exact_bearings() {
        let mut rng = SplitMix(7);
        let mut uniform = || (rng.next() >> 11) as f64 / (1u64 << 53) as f64;
        let R = Rotation3::new(Vector3::new(0.05, -0.3, 0.02));
        let t = Vector3::new(0.8, 0.1, 0.4);
        let mut corr = Vec::new();
        for i in 0..200 {
            let p = Vector3::new(
                uniform() * 20.0 - 10.0,
                uniform() * 6.0 - 3.0,
                5.0 + uniform() * 30.0,
            );
            let q = R * p + t;
            let mut b = q.normalize();
            if i % 10 == 0 {
                b = Vector3::new(uniform() - 0.5, uniform() - 0.5, 1.0).normalize();
            }
            corr.push(Correspondence {
                a: p.normalize(),
                b,
                sigma: 1e-3,
            });
        }
        let PoseOutcome::Accepted(pose) = estimate_relative_pose(&corr, &PoseParams::default(), 1)
        else {
            panic!("rejected");
        };
        assert_eq!(pose.kind, PoseKind::General);
        let err = (pose.b_R_a.matrix() - R.matrix()).norm();
        assert!(err < 1e-6, "rotation error {err}");
        assert!(
            pose.b_t_a.angle(&t) < 1e-6,
            "{:?} vs {:?}",
            pose.b_t_a,
            t.normalize()
        );
        assert!(pose.inliers.len() >= 175);
    }

    #[test]
    fn pure_rotation_is_reported_without_translation() {
        let mut rng = SplitMix(3);
        let mut uniform = || (rng.next() >> 11) as f64 / (1u64 << 53) as f64;
        let R = Rotation3::new(Vector3::new(0.1, 0.4, -0.05));
        let corr: Vec<_> = (0..100)
            .map(|_| {
                let a = Vector3::new(uniform() - 0.5, uniform() - 0.5, 1.0).normalize();
                Correspondence {
                    a,
                    b: R * a,
                    sigma: 1e-3,
                }
            })
            .collect();
        let PoseOutcome::Accepted(pose) = estimate_relative_pose(&corr, &PoseParams::default(), 1)
        else {
            panic!("rejected");
        };
        assert_eq!(pose.kind, PoseKind::RotationOnly);
        let err = (pose.b_R_a.matrix() - R.matrix()).norm();
        assert!(err < 1e-6, "rotation error {err}");
        assert_eq!(pose.b_t_a, Vector3::zeros());
    }
}
