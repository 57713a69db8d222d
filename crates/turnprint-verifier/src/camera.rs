//! Camera models that turn pixels into bearing vectors and back.
//!
//! The verifier compares keyframes from different cameras by working on unit
//! bearing vectors, never on pixels; the renderer uses the same models to cast
//! one ray per pixel, so rendering and verification are exact inverses.
//!
//! Conventions: camera frame x right, y down, z forward (OpenCV / KITTI).
//! Pixel coordinates are (u, v) with (0, 0) the centre of the top-left pixel.

use nalgebra::{Matrix2, Unit, Vector2, Vector3};

/// Newton iterations used by the inverse distortion; converges to ~1e-12 in a few.
const NEWTON_ITERATIONS: usize = 20;

/// A central camera: pinhole with radial-tangential distortion, OpenCV fisheye
/// (Kannala-Brandt) or the Mei unified omnidirectional model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraModel {
    /// `m = (x/z, y/z)`, distorted by `k1, k2` (radial) and `p1, p2` (tangential),
    /// then `u = fx m_x + cx`, `v = fy m_y + cy`.
    Pinhole {
        /// Focal length along x (pixels).
        fx: f64,
        /// Focal length along y (pixels).
        fy: f64,
        /// Principal point, u (pixels).
        cx: f64,
        /// Principal point, v (pixels).
        cy: f64,
        /// Radial distortion coefficient of r² (r on the normalised plane).
        k1: f64,
        /// Radial distortion coefficient of r⁴.
        k2: f64,
        /// First tangential distortion coefficient.
        p1: f64,
        /// Second tangential distortion coefficient.
        p2: f64,
    },
    /// OpenCV fisheye: `θ = atan2(|(x, y)|, z)`,
    /// `θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`, `m = θ_d (x, y) / |(x, y)|`.
    /// Using `atan2` keeps the model valid beyond 90° off axis (190° lenses).
    Fisheye {
        /// Focal length along x (pixels).
        fx: f64,
        /// Focal length along y (pixels).
        fy: f64,
        /// Principal point, u (pixels).
        cx: f64,
        /// Principal point, v (pixels).
        cy: f64,
        /// Coefficients `k1..k4` of θ², θ⁴, θ⁶, θ⁸ in `θ_d` (θ in radians).
        k: [f64; 4],
    },
    /// Mei unified model: the unit bearing `s` is projected from the point
    /// `(0, 0, -ξ)`: `m = (s_x, s_y) / (s_z + ξ)`, then radial-tangential
    /// distortion and the affine map as for the pinhole.
    Omni {
        /// Mirror parameter ξ in [0, 1]: the projection centre lies ξ unit-sphere
        /// radii behind the sphere's centre (0: pinhole).
        xi: f64,
        /// Focal length along x (pixels).
        fx: f64,
        /// Focal length along y (pixels).
        fy: f64,
        /// Principal point, u (pixels).
        cx: f64,
        /// Principal point, v (pixels).
        cy: f64,
        /// Radial distortion coefficient of r² (r on the normalised plane).
        k1: f64,
        /// Radial distortion coefficient of r⁴.
        k2: f64,
        /// First tangential distortion coefficient.
        p1: f64,
        /// Second tangential distortion coefficient.
        p2: f64,
    },
}

/// Radial-tangential distortion of a normalised point (Brown-Conrady, OpenCV order).
fn distort_rt(m: Vector2<f64>, k1: f64, k2: f64, p1: f64, p2: f64) -> Vector2<f64> {
    let (x, y) = (m.x, m.y);
    let r2 = x * x + y * y;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2;
    Vector2::new(
        x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
        y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
    )
}

/// Jacobian of [`distort_rt`] with respect to the undistorted point.
fn distort_rt_jacobian(m: Vector2<f64>, k1: f64, k2: f64, p1: f64, p2: f64) -> Matrix2<f64> {
    let (x, y) = (m.x, m.y);
    let r2 = x * x + y * y;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2;
    // d(radial)/dx = (2 k1 + 4 k2 r²) x
    let dradial = 2.0 * k1 + 4.0 * k2 * r2;
    Matrix2::new(
        radial + x * dradial * x + 2.0 * p1 * y + 6.0 * p2 * x,
        x * dradial * y + 2.0 * p1 * x + 2.0 * p2 * y,
        y * dradial * x + 2.0 * p1 * x + 2.0 * p2 * y,
        radial + y * dradial * y + 6.0 * p1 * y + 2.0 * p2 * x,
    )
}

/// Inverts [`distort_rt`] by Newton's method started at the distorted point.
/// Returns `None` when the iteration does not converge (outside the model's domain).
fn undistort_rt(md: Vector2<f64>, k1: f64, k2: f64, p1: f64, p2: f64) -> Option<Vector2<f64>> {
    if k1 == 0.0 && k2 == 0.0 && p1 == 0.0 && p2 == 0.0 {
        return Some(md);
    }
    let mut m = md;
    for _ in 0..NEWTON_ITERATIONS {
        let residual = distort_rt(m, k1, k2, p1, p2) - md;
        if residual.norm() < 1e-14 {
            return Some(m);
        }
        let step = distort_rt_jacobian(m, k1, k2, p1, p2).try_inverse()? * residual;
        m -= step;
    }
    let residual = distort_rt(m, k1, k2, p1, p2) - md;
    (residual.norm() < 1e-9).then_some(m)
}

/// `θ_d(θ)` of the fisheye model and its derivative.
fn fisheye_theta_d(theta: f64, k: &[f64; 4]) -> (f64, f64) {
    let t2 = theta * theta;
    let poly = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
    let dpoly = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
    (theta * poly, dpoly)
}

impl CameraModel {
    /// Builds a model from the IPC parameter block: `kind` 0 pinhole
    /// (`fx fy cx cy k1 k2 p1 p2`), 1 fisheye (`fx fy cx cy k1 k2 k3 k4`),
    /// 2 omni (`xi fx fy cx cy k1 k2 p1 p2`).
    pub fn from_params(kind: u32, p: &[f64; 12]) -> Result<Self, String> {
        let model = match kind {
            0 => CameraModel::Pinhole {
                fx: p[0],
                fy: p[1],
                cx: p[2],
                cy: p[3],
                k1: p[4],
                k2: p[5],
                p1: p[6],
                p2: p[7],
            },
            1 => CameraModel::Fisheye {
                fx: p[0],
                fy: p[1],
                cx: p[2],
                cy: p[3],
                k: [p[4], p[5], p[6], p[7]],
            },
            2 => CameraModel::Omni {
                xi: p[0],
                fx: p[1],
                fy: p[2],
                cx: p[3],
                cy: p[4],
                k1: p[5],
                k2: p[6],
                p1: p[7],
                p2: p[8],
            },
            other => {
                return Err(format!(
                    "unknown camera kind {other} (0 pinhole, 1 fisheye, 2 omni)"
                ))
            }
        };
        model.validate()?;
        Ok(model)
    }

    /// The IPC parameter block of this model (inverse of [`CameraModel::from_params`]).
    pub fn to_params(&self) -> (u32, [f64; 12]) {
        let mut p = [0.0; 12];
        match *self {
            CameraModel::Pinhole {
                fx,
                fy,
                cx,
                cy,
                k1,
                k2,
                p1,
                p2,
            } => {
                p[..8].copy_from_slice(&[fx, fy, cx, cy, k1, k2, p1, p2]);
                (0, p)
            }
            CameraModel::Fisheye { fx, fy, cx, cy, k } => {
                p[..8].copy_from_slice(&[fx, fy, cx, cy, k[0], k[1], k[2], k[3]]);
                (1, p)
            }
            CameraModel::Omni {
                xi,
                fx,
                fy,
                cx,
                cy,
                k1,
                k2,
                p1,
                p2,
            } => {
                p[..9].copy_from_slice(&[xi, fx, fy, cx, cy, k1, k2, p1, p2]);
                (2, p)
            }
        }
    }

    /// Checks that the parameters describe a usable camera (finite, positive focal lengths).
    pub fn validate(&self) -> Result<(), String> {
        let (kind, p) = self.to_params();
        if p.iter().any(|v| !v.is_finite()) {
            return Err(format!("camera kind {kind}: non-finite parameter in {p:?}"));
        }
        let (fx, fy) = match *self {
            CameraModel::Pinhole { fx, fy, .. } | CameraModel::Fisheye { fx, fy, .. } => (fx, fy),
            CameraModel::Omni { xi, fx, fy, .. } => {
                if !(0.0..=1.0).contains(&xi) {
                    return Err(format!("omni camera: xi = {xi} outside [0, 1]"));
                }
                (fx, fy)
            }
        };
        if fx <= 0.0 || fy <= 0.0 {
            return Err(format!(
                "camera kind {kind}: focal lengths must be positive (fx {fx}, fy {fy})"
            ));
        }
        Ok(())
    }

    /// A distortion-free pinhole with horizontal field of view `hfov` (radians),
    /// square pixels and the principal point at the image centre.
    pub fn standard_pinhole(width: u32, height: u32, hfov: f64) -> Self {
        let f = 0.5 * width as f64 / (0.5 * hfov).tan();
        CameraModel::Pinhole {
            fx: f,
            fy: f,
            cx: 0.5 * (width as f64 - 1.0),
            cy: 0.5 * (height as f64 - 1.0),
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
        }
    }

    /// A full-frame fisheye whose image diagonal spans `diagonal_fov` (radians,
    /// e.g. 190°), close to equidistant with a mild Kannala-Brandt polynomial.
    pub fn standard_fisheye(width: u32, height: u32, diagonal_fov: f64) -> Self {
        let k = [-0.01, 0.002, 0.0, 0.0];
        let (theta_d, _) = fisheye_theta_d(0.5 * diagonal_fov, &k);
        let half_diagonal = 0.5 * ((width as f64).powi(2) + (height as f64).powi(2)).sqrt();
        let f = half_diagonal / theta_d;
        CameraModel::Fisheye {
            fx: f,
            fy: f,
            cx: 0.5 * (width as f64 - 1.0),
            cy: 0.5 * (height as f64 - 1.0),
            k,
        }
    }

    /// A Mei omnidirectional camera with mirror parameter `xi` whose image
    /// diagonal spans `diagonal_fov` (radians), with mild radial distortion.
    pub fn standard_omni(width: u32, height: u32, xi: f64, diagonal_fov: f64) -> Self {
        let half = 0.5 * diagonal_fov;
        let (k1, k2) = (-0.02, 0.001);
        let m = half.sin() / (half.cos() + xi);
        let md = distort_rt(Vector2::new(m, 0.0), k1, k2, 0.0, 0.0).x;
        let half_diagonal = 0.5 * ((width as f64).powi(2) + (height as f64).powi(2)).sqrt();
        let f = half_diagonal / md;
        CameraModel::Omni {
            xi,
            fx: f,
            fy: f,
            cx: 0.5 * (width as f64 - 1.0),
            cy: 0.5 * (height as f64 - 1.0),
            k1,
            k2,
            p1: 0.0,
            p2: 0.0,
        }
    }

    /// Pixel of the ray along `bearing` (any length), or `None` when the ray is
    /// outside the model's domain (behind a pinhole, beyond the omni horizon).
    /// The pixel may lie outside the image; check with [`CameraModel::in_image`].
    pub fn project(&self, bearing: &Vector3<f64>) -> Option<Vector2<f64>> {
        match *self {
            CameraModel::Pinhole {
                fx,
                fy,
                cx,
                cy,
                k1,
                k2,
                p1,
                p2,
            } => {
                if bearing.z <= 0.0 {
                    return None;
                }
                let m = Vector2::new(bearing.x / bearing.z, bearing.y / bearing.z);
                let md = distort_rt(m, k1, k2, p1, p2);
                Some(Vector2::new(fx * md.x + cx, fy * md.y + cy))
            }
            CameraModel::Fisheye { fx, fy, cx, cy, k } => {
                let r = bearing.x.hypot(bearing.y);
                let theta = r.atan2(bearing.z);
                let (theta_d, slope) = fisheye_theta_d(theta, &k);
                if slope <= 0.0 {
                    // Past the polynomial's turning point the model folds back.
                    return None;
                }
                let (dx, dy) = if r > 0.0 {
                    (bearing.x / r, bearing.y / r)
                } else {
                    (0.0, 0.0)
                };
                Some(Vector2::new(fx * theta_d * dx + cx, fy * theta_d * dy + cy))
            }
            CameraModel::Omni {
                xi,
                fx,
                fy,
                cx,
                cy,
                k1,
                k2,
                p1,
                p2,
            } => {
                let n = bearing.norm();
                if n == 0.0 {
                    return None;
                }
                let s = bearing / n;
                let denom = s.z + xi;
                if denom <= 1e-9 {
                    return None;
                }
                let m = Vector2::new(s.x / denom, s.y / denom);
                let md = distort_rt(m, k1, k2, p1, p2);
                Some(Vector2::new(fx * md.x + cx, fy * md.y + cy))
            }
        }
    }

    /// Unit bearing of the ray through `pixel`, or `None` when no ray maps there
    /// (distortion not invertible, beyond the fisheye polynomial's range).
    pub fn unproject(&self, pixel: &Vector2<f64>) -> Option<Unit<Vector3<f64>>> {
        match *self {
            CameraModel::Pinhole {
                fx,
                fy,
                cx,
                cy,
                k1,
                k2,
                p1,
                p2,
            } => {
                let md = Vector2::new((pixel.x - cx) / fx, (pixel.y - cy) / fy);
                let m = undistort_rt(md, k1, k2, p1, p2)?;
                Some(Unit::new_normalize(Vector3::new(m.x, m.y, 1.0)))
            }
            CameraModel::Fisheye { fx, fy, cx, cy, k } => {
                let md = Vector2::new((pixel.x - cx) / fx, (pixel.y - cy) / fy);
                let theta_d = md.norm();
                if theta_d == 0.0 {
                    return Some(Vector3::z_axis());
                }
                // Newton on θ_d(θ) = |m|, from the equidistant guess θ = θ_d.
                let mut theta = theta_d;
                let mut converged = false;
                for _ in 0..NEWTON_ITERATIONS {
                    let (value, slope) = fisheye_theta_d(theta, &k);
                    if slope <= 0.0 {
                        return None;
                    }
                    let step = (value - theta_d) / slope;
                    theta -= step;
                    if step.abs() < 1e-14 {
                        converged = true;
                        break;
                    }
                }
                let (value, slope) = fisheye_theta_d(theta, &k);
                if !(converged || (value - theta_d).abs() < 1e-10)
                    || slope <= 0.0
                    || theta > std::f64::consts::PI
                {
                    return None;
                }
                let (sin, cos) = theta.sin_cos();
                Some(Unit::new_normalize(Vector3::new(
                    sin * md.x / theta_d,
                    sin * md.y / theta_d,
                    cos,
                )))
            }
            CameraModel::Omni {
                xi,
                fx,
                fy,
                cx,
                cy,
                k1,
                k2,
                p1,
                p2,
            } => {
                let md = Vector2::new((pixel.x - cx) / fx, (pixel.y - cy) / fy);
                let m = undistort_rt(md, k1, k2, p1, p2)?;
                // Lift onto the unit sphere: s = λ (m_x, m_y, 1) - (0, 0, ξ) with
                // λ = (ξ + sqrt(1 + (1 - ξ²) r²)) / (1 + r²).
                let r2 = m.norm_squared();
                let disc = 1.0 + (1.0 - xi * xi) * r2;
                if disc < 0.0 {
                    return None;
                }
                let lambda = (xi + disc.sqrt()) / (1.0 + r2);
                Some(Unit::new_normalize(Vector3::new(
                    lambda * m.x,
                    lambda * m.y,
                    lambda - xi,
                )))
            }
        }
    }

    /// True when `pixel` lies inside a `width` x `height` image.
    pub fn in_image(pixel: &Vector2<f64>, width: u32, height: u32) -> bool {
        pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x < width as f64 - 0.5
            && pixel.y < height as f64 - 0.5
    }

    /// Angle (radians) subtended by one pixel at `pixel`, the unit in which the
    /// verifier measures geometric error so that thresholds hold for any camera.
    pub fn pixel_angle(&self, pixel: &Vector2<f64>) -> Option<f64> {
        let a = self.unproject(pixel)?;
        let bx = self.unproject(&(pixel + Vector2::new(1.0, 0.0)))?;
        let by = self.unproject(&(pixel + Vector2::new(0.0, 1.0)))?;
        Some(0.5 * (a.angle(&bx) + a.angle(&by)))
    }
}
