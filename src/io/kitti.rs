//! KITTI odometry poses: 12 numbers per line, the 3x4 row-major matrix
//! `[R | p]` that maps camera coordinates into the world frame.
//!
//! The position is the last column `p`; the orientation is the rotation
//! nearest to the block `R` (files store it rounded, so it is not exactly
//! orthonormal).

use std::path::Path;

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::{data_lines, numbers, parse_error, pose, split_ws};
use crate::{Pose, Result};

/// Parses KITTI text into poses (no timestamps).
pub(super) fn parse(text: &str, path: &Path) -> Result<Vec<Pose>> {
    let mut poses = Vec::new();
    for (line, content) in data_lines(text) {
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
        poses.push(pose(None, position, nearest_rotation(&world_R_cam)));
    }
    Ok(poses)
}

/// The rotation nearest to `m`, or `None` when `m` is too far from one to
/// mean an orientation (for instance all zeros).
fn nearest_rotation(m: &Matrix3<f64>) -> Option<UnitQuaternion<f64>> {
    // det = 1 for a rotation; a block far from that is not one.
    let det = m.determinant();
    if !(0.5..=2.0).contains(&det) {
        return None;
    }
    // Bounded iterations: the default (0) would iterate until convergence.
    let r = Rotation3::from_matrix_eps(m, 1e-12, 100, Rotation3::identity());
    let q = UnitQuaternion::from_rotation_matrix(&r);
    q.coords.iter().all(|c| c.is_finite()).then_some(q)
}
