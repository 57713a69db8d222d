//! EuRoC MAV ground truth CSV: a header line starting with `#`, then
//! `t_ns, px, py, pz, qw, qx, qy, qz, ...` (extra columns ignored).

use std::path::Path;

use nalgebra::Vector3;

use super::{number, parse_error, pose, quaternion, LineFormat};
use crate::{Pose, Result};

/// EuRoC lines; timestamps become seconds.
pub(super) struct Euroc;

impl LineFormat for Euroc {
    fn line(&mut self, line: usize, content: &str, path: &Path) -> Result<Option<Pose>> {
        if content.starts_with('#') {
            return Ok(None);
        }
        let fields: Vec<&str> = content.split(',').map(str::trim).collect();
        if fields.len() < 8 {
            return Err(parse_error(
                path,
                line,
                format!(
                    "expected at least 8 comma-separated values (t_ns, px, py, pz, qw, qx, qy, qz), found {}",
                    fields.len()
                ),
            ));
        }
        let t = nanoseconds_to_seconds(fields[0]).map_err(|m| parse_error(path, line, m))?;
        let mut v = [0.0; 7];
        for (i, slot) in v.iter_mut().enumerate() {
            *slot = number(fields[i + 1], i + 2).map_err(|m| parse_error(path, line, m))?;
        }
        let q = quaternion(v[3], v[4], v[5], v[6]).map_err(|m| parse_error(path, line, m))?;
        Ok(Some(pose(Some(t), Vector3::new(v[0], v[1], v[2]), Some(q))))
    }
}

/// Seconds from a nanosecond timestamp, exact in the integer part: EuRoC
/// stamps (~1.4e18 ns) have more digits than an f64 holds.
fn nanoseconds_to_seconds(field: &str) -> std::result::Result<f64, String> {
    if let Ok(ns) = field.parse::<i64>() {
        let (s, rem) = (ns.div_euclid(1_000_000_000), ns.rem_euclid(1_000_000_000));
        return Ok(s as f64 + rem as f64 * 1e-9);
    }
    number(field, 1).map(|ns| ns * 1e-9)
}
