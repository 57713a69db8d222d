//! TUM trajectories: `t x y z qx qy qz qw` per line, whitespace separated,
//! `#` comments and blank lines allowed.

use std::path::Path;

use nalgebra::Vector3;

use super::{data_lines, numbers, parse_error, pose, quaternion, split_ws};
use crate::{Pose, Result};

/// Parses TUM text into poses.
pub(super) fn parse(text: &str, path: &Path) -> Result<Vec<Pose>> {
    let mut poses = Vec::new();
    for (line, content) in data_lines(text) {
        let fields = split_ws(content);
        if fields.len() != 8 {
            return Err(parse_error(
                path,
                line,
                format!(
                    "expected 8 numbers (t x y z qx qy qz qw), found {}",
                    fields.len()
                ),
            ));
        }
        let v = numbers(fields.into_iter()).map_err(|m| parse_error(path, line, m))?;
        let q = quaternion(v[7], v[4], v[5], v[6]).map_err(|m| parse_error(path, line, m))?;
        poses.push(pose(Some(v[0]), Vector3::new(v[1], v[2], v[3]), Some(q)));
    }
    Ok(poses)
}
