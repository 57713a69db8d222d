//! Bare positions: `x y [z]` per line, whitespace or comma separated, `#`
//! comments; a missing `z` is 0.

use std::path::Path;

use nalgebra::Vector3;

use super::{data_lines, numbers, parse_error, pose, split_comma_ws};
use crate::{Pose, Result};

/// Parses xyz text into poses (no timestamps, no orientation).
pub(super) fn parse(text: &str, path: &Path) -> Result<Vec<Pose>> {
    let mut poses = Vec::new();
    // Every line must have as many numbers as the first: a change is a
    // damaged line, not a change of dimension.
    let mut columns: Option<(usize, usize)> = None;
    for (line, content) in data_lines(text) {
        let fields = split_comma_ws(content);
        match columns {
            _ if !(2..=3).contains(&fields.len()) => {
                return Err(parse_error(
                    path,
                    line,
                    format!("expected 2 or 3 numbers (x y [z]), found {}", fields.len()),
                ))
            }
            Some((n, first)) if n != fields.len() => {
                return Err(parse_error(
                    path,
                    line,
                    format!(
                        "expected {n} numbers like line {first}, found {}",
                        fields.len()
                    ),
                ))
            }
            Some(_) => {}
            None => columns = Some((fields.len(), line)),
        }
        let v = numbers(fields.into_iter()).map_err(|m| parse_error(path, line, m))?;
        let z = v.get(2).copied().unwrap_or(0.0);
        poses.push(pose(None, Vector3::new(v[0], v[1], z), None));
    }
    Ok(poses)
}
