//! Similarity transforms (rotation, translation, uniform scale) and their
//! least-squares estimation from point pairs.
//!
//! `a_T_b` maps points from frame b to frame a: `p_a = s R p_b + t`.

use nalgebra::{Matrix3, Rotation2, Rotation3, Vector2, Vector3};

/// A 2D similarity `p_a = s R(angle) p_b + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity2 {
    /// Uniform scale `s > 0`.
    pub scale: f64,
    /// Rotation angle in radians.
    pub angle: f64,
    /// Translation `t`.
    pub translation: Vector2<f64>,
}

impl Similarity2 {
    /// The identity.
    pub fn identity() -> Self {
        Similarity2 {
            scale: 1.0,
            angle: 0.0,
            translation: Vector2::zeros(),
        }
    }

    /// Applies the transform to a point of b.
    pub fn apply(&self, p_b: &Vector2<f64>) -> Vector2<f64> {
        self.applier()(p_b)
    }

    /// [`Similarity2::apply`] with the rotation's sine and cosine computed
    /// once, for loops over many points (the same results, bit for bit).
    pub fn applier(&self) -> impl Fn(&Vector2<f64>) -> Vector2<f64> {
        let (s, c) = self.angle.sin_cos();
        let (scale, t) = (self.scale, self.translation);
        move |p_b| scale * Vector2::new(c * p_b.x - s * p_b.y, s * p_b.x + c * p_b.y) + t
    }

    /// The inverse `b_T_a`.
    pub fn inverse(&self) -> Self {
        let inv_scale = 1.0 / self.scale;
        let rot = Rotation2::new(-self.angle);
        Similarity2 {
            scale: inv_scale,
            angle: -self.angle,
            translation: -(rot * self.translation) * inv_scale,
        }
    }

    /// Weighted least-squares similarity `a_T_b` from pairs `(p_a, p_b)`
    /// (Umeyama in closed form: in 2D the optimal rotation and scale are the
    /// argument and modulus of `sum w conj(b') a'` over centred points).
    /// Returns `None` when the b points are all at one place.
    pub fn fit(pairs: &[(Vector2<f64>, Vector2<f64>)], weights: Option<&[f64]>) -> Option<Self> {
        Self::fit_with(pairs, weights, false)
    }

    /// [`Similarity2::fit`] with the scale held at 1: the rotation is the
    /// same argument of `sum w conj(b') a'`, the translation maps the b
    /// centroid onto the a centroid. For pairs that fix no scale, such as
    /// points and their nearest points on a straight road crossing theirs
    /// at a small angle (the projection shrinks the points along the road
    /// by its cosine, and points past the road's end collapse onto it).
    pub fn fit_rigid(pairs: &[(Vector2<f64>, Vector2<f64>)]) -> Option<Self> {
        Self::fit_with(pairs, None, true)
    }

    fn fit_with(
        pairs: &[(Vector2<f64>, Vector2<f64>)],
        weights: Option<&[f64]>,
        rigid: bool,
    ) -> Option<Self> {
        let w_of = |i: usize| weights.map_or(1.0, |w| w[i]);
        let mut w_sum = 0.0;
        let (mut ca, mut cb) = (Vector2::zeros(), Vector2::zeros());
        for (i, (a, b)) in pairs.iter().enumerate() {
            let w = w_of(i);
            w_sum += w;
            ca += w * a;
            cb += w * b;
        }
        if w_sum <= 0.0 {
            return None;
        }
        ca /= w_sum;
        cb /= w_sum;
        let (mut dot, mut cross, mut var_b) = (0.0, 0.0, 0.0);
        for (i, (a, b)) in pairs.iter().enumerate() {
            let w = w_of(i);
            let (da, db) = (a - ca, b - cb);
            dot += w * db.dot(&da);
            cross += w * (db.x * da.y - db.y * da.x);
            var_b += w * db.norm_squared();
        }
        if var_b <= f64::MIN_POSITIVE || !(dot.is_finite() && cross.is_finite()) {
            return None;
        }
        let scale = match rigid {
            true => 1.0,
            false => dot.hypot(cross) / var_b,
        };
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        let angle = cross.atan2(dot);
        let mut t = Similarity2 {
            scale,
            angle,
            translation: Vector2::zeros(),
        };
        t.translation = ca - t.apply(&cb);
        Some(t)
    }

    /// Exact similarity taking `b0 -> a0` and `b1 -> a1`.
    pub fn from_two(
        a0: &Vector2<f64>,
        a1: &Vector2<f64>,
        b0: &Vector2<f64>,
        b1: &Vector2<f64>,
    ) -> Option<Self> {
        Self::fit(&[(*a0, *b0), (*a1, *b1)], None)
    }
}

/// A 3D similarity `p_a = s R p_b + t` with `R` a proper rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity3 {
    /// Uniform scale `s > 0`.
    pub scale: f64,
    /// Proper rotation `R`.
    pub rotation: Matrix3<f64>,
    /// Translation `t`.
    pub translation: Vector3<f64>,
}

impl Similarity3 {
    /// The identity.
    pub fn identity() -> Self {
        Similarity3 {
            scale: 1.0,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// Applies the transform to a point of b.
    pub fn apply(&self, p_b: &Vector3<f64>) -> Vector3<f64> {
        self.scale * (self.rotation * p_b) + self.translation
    }

    /// The inverse `b_T_a`.
    pub fn inverse(&self) -> Self {
        let rt = self.rotation.transpose();
        Similarity3 {
            scale: 1.0 / self.scale,
            rotation: rt,
            translation: -(rt * self.translation) / self.scale,
        }
    }

    /// Composition `self * other` (apply `other` first).
    pub fn compose(&self, other: &Similarity3) -> Self {
        Similarity3 {
            scale: self.scale * other.scale,
            rotation: self.rotation * other.rotation,
            translation: self.scale * (self.rotation * other.translation) + self.translation,
        }
    }

    /// The rigid motion with this rotation that moves `c` where this
    /// transform does: `R p + (s R c + t - R c)`.
    pub fn rigid_about(&self, c: &Vector3<f64>) -> Self {
        Similarity3 {
            scale: 1.0,
            rotation: self.rotation,
            translation: self.apply(c) - self.rotation * c,
        }
    }

    /// Least-squares similarity with `dst_i ~ s R src_i + t` (Umeyama 1991):
    /// with centred point sets and `Sigma = (1/n) sum dst_c src_c^T = U D V^T`,
    /// `R = U S V^T` (`S` flips the last axis when `det(U V^T) < 0`),
    /// `s = tr(D S) / var(src)`, `t = mean(dst) - s R mean(src)`.
    /// `None` for fewer than 3 pairs or a degenerate (single-point) source.
    pub fn fit(src: &[Vector3<f64>], dst: &[Vector3<f64>]) -> Option<Self> {
        let n = src.len();
        if n < 3 || dst.len() != n {
            return None;
        }
        let mean = |v: &[Vector3<f64>]| v.iter().sum::<Vector3<f64>>() / n as f64;
        let (mu_src, mu_dst) = (mean(src), mean(dst));
        let mut sigma = Matrix3::zeros();
        let mut var_src = 0.0;
        for (s, d) in src.iter().zip(dst) {
            let (sc, dc) = (s - mu_src, d - mu_dst);
            sigma += dc * sc.transpose();
            var_src += sc.norm_squared();
        }
        sigma /= n as f64;
        var_src /= n as f64;
        if var_src <= f64::EPSILON {
            return None;
        }
        let svd = sigma.try_svd(true, true, f64::EPSILON, SVD_ITERATIONS)?;
        let (u, v_t) = (svd.u?, svd.v_t?);
        let d = &svd.singular_values;
        let mut signs = Vector3::new(1.0, 1.0, 1.0);
        if (u * v_t).determinant() < 0.0 {
            signs[2] = -1.0;
        }
        let rotation = if d[1] <= COLLINEAR * d[0] {
            // Collinear points fix no rotation about their line: the least
            // rotation that carries the source's line onto the target's.
            least_rotation(&v_t.row(0).transpose(), &u.column(0).into_owned())
        } else {
            u * Matrix3::from_diagonal(&signs) * v_t
        };
        // tr(Rᵀ Sigma) = tr(D S), and d_0 on a line.
        let scale = (rotation.transpose() * sigma).trace() / var_src;
        let translation = mu_dst - scale * (rotation * mu_src);
        Some(Similarity3 {
            scale,
            rotation,
            translation,
        })
    }

    /// Least-squares rigid transform (`s = 1`) with `dst_i ~ R src_i + t`:
    /// the rotation of [`Similarity3::fit`] with the scale held at 1, so
    /// `t = mean(dst) - R mean(src)` (Umeyama 1991 without scale).
    pub fn fit_rigid(src: &[Vector3<f64>], dst: &[Vector3<f64>]) -> Option<Self> {
        let s = Self::fit(src, dst)?;
        let n = src.len() as f64;
        let mu_src = src.iter().sum::<Vector3<f64>>() / n;
        let mu_dst = dst.iter().sum::<Vector3<f64>>() / n;
        Some(Similarity3 {
            scale: 1.0,
            rotation: s.rotation,
            translation: mu_dst - s.rotation * mu_src,
        })
    }

    /// Angle in radians of the rotation taking `other`'s to this one's.
    pub fn angle_to(&self, other: &Similarity3) -> f64 {
        angle_between(&self.rotation, &other.rotation)
    }

    /// Rotation angle in radians (the geodesic distance to the identity).
    pub fn angle(&self) -> f64 {
        angle_between(&self.rotation, &Matrix3::identity())
    }
}

/// Ratio of the second singular value of the cross-covariance to the first
/// below which [`Similarity3::fit`] takes its points as collinear: √ε, where
/// the rotation about their line would be set by rounding alone.
const COLLINEAR: f64 = 1.5e-8;

/// Iterations at most of a 3x3 SVD: its implicit-shift QR steps reach
/// machine precision within a few per singular value on any finite matrix,
/// and the bound ends them on input that would never converge.
const SVD_ITERATIONS: usize = 100;

/// The rotation of least angle taking unit vector `a` to unit vector `b`
/// (Rodrigues about `a x b`); for opposite vectors, a half turn about the
/// axis most nearly perpendicular to both.
fn least_rotation(a: &Vector3<f64>, b: &Vector3<f64>) -> Matrix3<f64> {
    let axis = a.cross(b);
    let (sin, cos) = (axis.norm(), a.dot(b));
    if sin > f64::EPSILON {
        let k = axis / sin;
        let kx = k.cross_matrix();
        return Matrix3::identity() + sin * kx + (1.0 - cos) * kx * kx;
    }
    if cos > 0.0 {
        return Matrix3::identity();
    }
    let least = a.iamin();
    let k = a.cross(&Vector3::ith(least, 1.0)).normalize();
    2.0 * k * k.transpose() - Matrix3::identity()
}

/// The rotation nearest to `m` in the Frobenius norm, `U diag(1, 1, det(U
/// V^T)) V^T` for `m = U D V^T` (a rotation up to rounding, or a sum of
/// rotations), with the SVD bounded by `SVD_ITERATIONS`: nalgebra's
/// `Rotation3::from_matrix` iterates until it converges, which a
/// degenerate matrix never does. Identity where `m` is not finite.
pub fn nearest_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let projected = m
        .iter()
        .all(|x| x.is_finite())
        .then(|| m.try_svd(true, true, f64::EPSILON, SVD_ITERATIONS))
        .flatten()
        .and_then(|svd| {
            let (u, v_t) = (svd.u?, svd.v_t?);
            let flip = (u * v_t).determinant().signum();
            Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, flip)) * v_t)
        });
    projected.map_or_else(Rotation3::identity, Rotation3::from_matrix_unchecked)
}

/// Angle in radians of the rotation taking `b` to `a`,
/// `acos((tr(a bᵀ) - 1) / 2)` (clamped against rounding).
pub fn angle_between(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (((a * b.transpose()).trace() - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points along a gently winding road (not collinear).
    fn road() -> Vec<Vector2<f64>> {
        (0..20)
            .map(|i| {
                let t = i as f64;
                Vector2::new(t, 3.0 * (t / 4.0).sin())
            })
            .collect()
    }

    #[allow(non_snake_case)]
    fn pairs_under(a_T_b: &Similarity2) -> Vec<(Vector2<f64>, Vector2<f64>)> {
        road().into_iter().map(|p| (a_T_b.apply(&p), p)).collect()
    }

    #[test]
    #[allow(non_snake_case)]
    fn fits_recover_the_transform_that_made_the_pairs() {
        let a_T_b = Similarity2 {
            scale: 1.7,
            angle: 0.4,
            translation: Vector2::new(-3.0, 8.0),
        };
        let fit = Similarity2::fit(&pairs_under(&a_T_b), None).expect("spread points");
        let rigid_a_T_b = Similarity2 {
            scale: 1.0,
            ..a_T_b
        };
        let rigid = Similarity2::fit_rigid(&pairs_under(&rigid_a_T_b)).expect("spread points");
        for (got, want) in [(fit, a_T_b), (rigid, rigid_a_T_b)] {
            assert!((got.scale - want.scale).abs() < 1e-12, "{got:?}");
            assert!((got.angle - want.angle).abs() < 1e-12, "{got:?}");
            assert!(
                (got.translation - want.translation).norm() < 1e-12,
                "{got:?}"
            );
        }
    }

    /// Points of a straight and their nearest points on a straight crossing
    /// it at 20 degrees: the projection shrinks them by the cosine, so the
    /// similarity fit's scale falls below 1; the rigid fit keeps 1 and still
    /// turns the points towards the other road.
    #[test]
    fn the_rigid_fit_keeps_the_scale_where_nearest_points_shrink_it() {
        let (sin, cos) = 20f64.to_radians().sin_cos();
        let pairs: Vec<_> = (0..8)
            .map(|i| {
                let b = Vector2::new(5.0 * i as f64, 0.0);
                let along = b.dot(&Vector2::new(cos, sin));
                (along * Vector2::new(cos, sin), b)
            })
            .collect();
        let fit = Similarity2::fit(&pairs, None).expect("spread points");
        let rigid = Similarity2::fit_rigid(&pairs).expect("spread points");
        assert!(fit.scale < 0.95, "{fit:?}");
        assert_eq!(rigid.scale, 1.0);
        assert!((rigid.angle - fit.angle).abs() < 1e-12 && rigid.angle > 0.0);
    }

    /// Regression: a fit of points on one line took any rotation about the
    /// line (a half turn, on the second lap of a rectangle against the
    /// first), which a loop closure read as a roll of 180 degrees. The fit
    /// now takes the least rotation that lays the lines onto each other.
    #[test]
    fn collinear_points_fit_without_a_turn_about_their_line() {
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3);
        let src: Vec<Vector3<f64>> = (0..50)
            .map(|i| Vector3::new(i as f64, 0.5 * i as f64, 0.0))
            .collect();
        let dst: Vec<Vector3<f64>> = src
            .iter()
            .map(|p| 2.0 * (turn * p) + Vector3::new(7.0, -1.0, 3.0))
            .collect();
        let fit = Similarity3::fit(&src, &dst).expect("spread points");
        assert!(
            angle_between(&fit.rotation, turn.matrix()) < 1e-9,
            "{fit:?}"
        );
        assert!((fit.scale - 2.0).abs() < 1e-9, "{fit:?}");
        for (s, d) in src.iter().zip(&dst) {
            assert!((fit.apply(s) - d).norm() < 1e-9);
        }
    }

    /// A matrix that no rotation is near (zero, rank one, not finite) still
    /// gives a rotation, and a rotation gives itself.
    #[test]
    fn the_nearest_rotation_of_any_matrix_is_a_rotation() {
        let turn = Rotation3::from_euler_angles(0.3, -1.2, 2.9);
        let v = Vector3::new(1.0, 2.0, 3.0);
        for (m, want) in [
            (*turn.matrix(), Some(turn)),
            (Matrix3::zeros(), None),
            (v * v.transpose(), None),
            (Matrix3::from_element(f64::NAN), Some(Rotation3::identity())),
            (-Matrix3::identity(), None),
        ] {
            let r = nearest_rotation(&m);
            let r = r.matrix();
            assert!(
                (r.transpose() * r - Matrix3::identity()).norm() < 1e-9,
                "{m}"
            );
            assert!((r.determinant() - 1.0).abs() < 1e-9, "{m}");
            if let Some(want) = want {
                assert!(angle_between(r, want.matrix()) < 1e-9, "{m}");
            }
        }
    }
}
