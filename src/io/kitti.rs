//! KITTI odometry poses: 12 numbers per line, the 3x4 row-major matrix
//! `[R | p]` that maps camera coordinates into the world frame.
//!
//! The position is the last column `p`; the orientation is the rotation
//! nearest to the block `R` (files store it rounded, so it is not exactly
//! orthonormal), or none when `R` is far from any rotation.

use std::path::Path;

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::{numbers, parse_error, pose, split_ws, LineFormat};
use crate::{Pose, Result};

/// KITTI lines (no timestamps).
pub(super) struct Kitti;

impl LineFormat for Kitti {
    fn line(&mut self, line: usize, content: &str, path: &Path) -> Result<Option<Pose>> {
        if content.starts_with('#') {
            return Ok(None);
        }
        let fields = split_ws(content);
        if fields.len() != 12 {
            return Err(parse_error(
                path,
                line,
                format!(
                    "expected 12 numbers (3x4 row-major pose), found {}",
                    fields.len()
                ),
            ));
        }
        let v = numbers(fields.into_iter()).map_err(|m| parse_error(path, line, m))?;
        #[allow(non_snake_case)]
        let world_R_cam = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
        let position = Vector3::new(v[3], v[7], v[11]);
        Ok(Some(pose(None, position, nearest_rotation(&world_R_cam))))
    }
}

/// The rotation nearest to `m`, or `None` when `m` is too far from one to
/// mean an orientation (for instance all zeros).
///
/// Polar decomposition by Newton's iteration `R <- (R + R^-T) / 2`, which
/// converges quadratically to the orthonormal factor from a near-rotation;
/// the iteration count is fixed so that no input can make it loop.
fn nearest_rotation(m: &Matrix3<f64>) -> Option<UnitQuaternion<f64>> {
    // Only blocks close to orthonormal with det near +1 are orientations.
    let defect = (m.transpose() * m - Matrix3::identity()).norm();
    if !(defect < 0.1 && m.determinant() > 0.0) {
        return None;
    }
    let mut r = *m;
    for _ in 0..8 {
        let r_inv_t = r.try_inverse()?.transpose();
        r = 0.5 * (r + r_inv_t);
    }
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let q = UnitQuaternion::new_normalize(q.into_inner());
    q.coords.iter().all(|c| c.is_finite()).then_some(q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn badly_scaled_blocks_give_a_rotation_or_none_never_nan() {
        for m in [
            Matrix3::new(1e200, 0.0, 0.0, 0.0, 1e-200, 0.0, 0.0, 0.0, 1.0),
            Matrix3::new(1.0, 1e154, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
            Matrix3::zeros(),
            -Matrix3::identity(),
        ] {
            if let Some(q) = nearest_rotation(&m) {
                assert!(q.coords.iter().all(|c| c.is_finite()), "{m}");
            }
        }
        let q = nearest_rotation(&Matrix3::identity()).unwrap();
        assert!(q.angle() < 1e-12);
    }
}
