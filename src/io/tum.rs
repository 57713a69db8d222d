//! TUM trajectories: `t x y z qx qy qz qw` per line, whitespace separated,
//! `#` comments and blank lines allowed.

use std::path::Path;

use nalgebra::Vector3;

use super::{numbers, parse_error, pose, quaternion, split_ws, LineFormat};
use crate::{Pose, Result};

/// TUM lines.
pub(super) struct Tum;

impl LineFormat for Tum {
    fn line(&mut self, line: usize, content: &str, path: &Path) -> Result<Option<Pose>> {
        if content.starts_with('#') {
            return Ok(None);
        }
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
        Ok(Some(pose(
            Some(v[0]),
            Vector3::new(v[1], v[2], v[3]),
            Some(q),
        )))
    }
}
