//! Best-fit plane of a 3D path: the path is assumed nearly planar (its height
//! is small next to its extent), so it is studied in the plane's 2D frame.

use nalgebra::{Matrix3, SymmetricEigen, Vector2, Vector3};

use super::{Similarity2, Similarity3};

/// A plane with an orthonormal frame: `world_R_plane` has columns
/// `(e1, e2, n)` (a proper rotation), `origin` is the points' centroid.
///
/// Plane coordinates: `l = world_R_plane^T (p - origin)`; `(l.x, l.y)` is the
/// 2D position, `l.z` the height above the plane.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_snake_case)]
pub struct Plane {
    /// Centroid of the fitted points.
    pub origin: Vector3<f64>,
    /// Columns `(e1, e2, n)`: the in-plane axes and the normal.
    pub world_R_plane: Matrix3<f64>,
}

impl Plane {
    /// Least-squares plane: the normal is the eigenvector of the scatter
    /// matrix with the smallest eigenvalue, `e1` the one with the largest.
    pub fn fit(points: &[Vector3<f64>]) -> Plane {
        let n = points.len().max(1) as f64;
        let origin = points.iter().fold(Vector3::zeros(), |acc, p| acc + p) / n;
        let mut scatter = Matrix3::zeros();
        for p in points {
            let d = p - origin;
            scatter += d * d.transpose();
        }
        let eig = SymmetricEigen::new(scatter);
        let mut order = [0usize, 1, 2];
        order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
        let e1 = eig.eigenvectors.column(order[0]).into_owned();
        let e2 = eig.eigenvectors.column(order[1]).into_owned();
        // Non-finite input would give NaN axes: fall back to the identity frame.
        if !(e1.iter().chain(e2.iter()).all(|v| v.is_finite())) {
            return Plane {
                origin,
                world_R_plane: Matrix3::identity(),
            };
        }
        let normal = e1.cross(&e2).normalize();
        Plane {
            origin,
            world_R_plane: Matrix3::from_columns(&[e1, e2, normal]),
        }
    }

    /// The same plane seen from the other side: `e2 -> -e2`, `n -> -n`.
    /// 2D coordinates mirror (`y -> -y`), so curvature changes sign.
    pub fn mirrored(&self) -> Plane {
        let c = self.world_R_plane;
        Plane {
            origin: self.origin,
            world_R_plane: Matrix3::from_columns(&[
                c.column(0).into_owned(),
                -c.column(1).into_owned(),
                -c.column(2).into_owned(),
            ]),
        }
    }

    /// The plane's unit normal `n`.
    pub fn normal(&self) -> Vector3<f64> {
        self.world_R_plane.column(2).into_owned()
    }

    /// Plane coordinates `l = world_R_plane^T (p - origin)`.
    pub fn local(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.world_R_plane.transpose() * (p - self.origin)
    }

    /// 2D position of a point in the plane.
    pub fn to_2d(&self, p: &Vector3<f64>) -> Vector2<f64> {
        self.local(p).xy()
    }

    /// Lifts a 2D similarity `a_T_b` between the planes of A (`self`) and
    /// B (`b_plane`) to 3D, heights scaled with the path:
    ///
    /// `p_A = o_A + A_R (s R2 l_B + [t2; 0])` with `l_B = B_R^T (p_B - o_B)`,
    /// `R2` extended by 1 on the normal, so the 3D rotation is
    /// `A_R R2 B_R^T` and the translation `o_A + A_R [t2; 0] - s R o_B`.
    #[allow(non_snake_case)]
    pub fn lift(&self, b_plane: &Plane, a_T_b: &Similarity2) -> Similarity3 {
        let (c, s) = (a_T_b.angle.cos(), a_T_b.angle.sin());
        let r2 = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let rotation = self.world_R_plane * r2 * b_plane.world_R_plane.transpose();
        let t2 = Vector3::new(a_T_b.translation.x, a_T_b.translation.y, 0.0);
        let translation =
            self.origin + self.world_R_plane * t2 - a_T_b.scale * (rotation * b_plane.origin);
        Similarity3 {
            scale: a_T_b.scale,
            rotation,
            translation,
        }
    }
}
