//! Bare positions: `x y [z]` per line, whitespace or comma separated, `#`
//! comments; a missing `z` is 0.

use std::path::Path;

use nalgebra::Vector3;

use super::{numbers, parse_error, pose, split_comma_ws, LineFormat};
use crate::{Pose, Result};

/// xyz lines (no timestamps, no orientation).
#[derive(Default)]
pub(super) struct Xyz {
    /// Numbers per line and the line that set it: every line must have as
    /// many as the first (a change is a damaged line, not a change of
    /// dimension).
    columns: Option<(usize, usize)>,
}

impl LineFormat for Xyz {
    fn line(&mut self, line: usize, content: &str, path: &Path) -> Result<Option<Pose>> {
        if content.starts_with('#') {
            return Ok(None);
        }
        let fields = split_comma_ws(content);
        match self.columns {
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
            None => self.columns = Some((fields.len(), line)),
        }
        let v = numbers(fields.into_iter()).map_err(|m| parse_error(path, line, m))?;
        let z = v.get(2).copied().unwrap_or(0.0);
        Ok(Some(pose(None, Vector3::new(v[0], v[1], z), None)))
    }
}
