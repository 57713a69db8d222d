//! Positions from a CSV whose header names its columns (our extension).
//!
//! The header is the first non-blank line that is not a `#` comment, or a
//! `#` line that names the columns (as in the CARMEN odometry exports). Names are matched case-insensitively after
//! dropping a unit, written either as a suffix (`x_m`, `timestamp_s`) or in
//! brackets (`x [m]`): `t`/`time`/`timestamp`/`stamp` (optional), `x`, `y`,
//! `z` (optional), `theta`/`yaw` (optional: the heading about z, in radians,
//! or degrees as `yaw_deg`/`yaw [deg]`, as wheel odometry logs it). Other
//! columns are ignored. Fields are separated by commas when the header has
//! one, else by whitespace.

use std::path::Path;

use nalgebra::Vector3;

use super::{clip, number, parse_error, pose, LineFormat};
use crate::{Pose, Result};

/// Column positions of the quantities we read, and the time unit in seconds.
#[derive(Debug, Default, PartialEq)]
pub(super) struct Columns {
    t: Option<(usize, f64)>,
    x: usize,
    y: usize,
    z: Option<usize>,
    /// The heading's column and its unit in radians.
    yaw: Option<(usize, f64)>,
    count: usize,
    comma: bool,
}

/// What one header name stands for.
enum Role {
    Time(f64),
    X,
    Y,
    Z,
    /// Heading about z, with its unit in radians.
    Yaw(f64),
    Other,
}

/// CSV lines (an orientation only from a heading): the header, then the data.
#[derive(Default)]
pub(super) struct Csv {
    /// The header's line and columns, once read.
    header: Option<(usize, Columns)>,
}

impl LineFormat for Csv {
    fn line(&mut self, line: usize, content: &str, path: &Path) -> Result<Option<Pose>> {
        let Some((header_line, columns)) = &self.header else {
            // Comment lines before the header are skipped unless they are
            // the header.
            match header_columns(content) {
                Ok(columns) => self.header = Some((line, columns)),
                Err(_) if content.starts_with('#') => {}
                Err(m) => return Err(parse_error(path, line, m)),
            }
            return Ok(None);
        };
        if content.starts_with('#') {
            return Ok(None);
        }
        let fields: Vec<&str> = if columns.comma {
            content.split(',').map(str::trim).collect()
        } else {
            content.split_whitespace().collect()
        };
        if fields.len() != columns.count {
            return Err(parse_error(
                path,
                line,
                format!(
                    "expected {} values like the header (line {header_line}), found {}",
                    columns.count,
                    fields.len()
                ),
            ));
        }
        let get = |i: usize| number(fields[i], i + 1).map_err(|m| parse_error(path, line, m));
        let t = match columns.t {
            Some((i, unit)) => Some(get(i)? * unit),
            None => None,
        };
        let z = match columns.z {
            Some(i) => get(i)?,
            None => 0.0,
        };
        let orientation = match columns.yaw {
            Some((i, unit)) => Some(nalgebra::UnitQuaternion::from_axis_angle(
                &Vector3::z_axis(),
                get(i)? * unit,
            )),
            None => None,
        };
        Ok(Some(pose(
            t,
            Vector3::new(get(columns.x)?, get(columns.y)?, z),
            orientation,
        )))
    }
}

/// Reads the header line; an error when it names no `x` and `y` columns.
pub(super) fn header_columns(header: &str) -> std::result::Result<Columns, String> {
    let header = header.trim_start_matches('#').trim();
    let comma = header.contains(',');
    let names: Vec<&str> = if comma {
        header.split(',').map(str::trim).collect()
    } else {
        header.split_whitespace().collect()
    };
    let (mut t, mut x, mut y, mut z, mut yaw) = (None, None, None, None, None);
    for (i, name) in names.iter().enumerate() {
        // The first column with a role wins; later duplicates are ignored.
        match role(name) {
            Role::Time(unit) => t = t.or(Some((i, unit))),
            Role::X => x = x.or(Some(i)),
            Role::Y => y = y.or(Some(i)),
            Role::Z => z = z.or(Some(i)),
            Role::Yaw(unit) => yaw = yaw.or(Some((i, unit))),
            Role::Other => {}
        }
    }
    match (x, y) {
        (Some(x), Some(y)) => Ok(Columns {
            t,
            x,
            y,
            z,
            yaw,
            count: names.len(),
            comma,
        }),
        _ => Err(format!("header '{}' has no x and y columns", clip(header))),
    }
}

/// The role of a column name such as `X`, `x_m`, `timestamp_s` or `x [m]`.
fn role(name: &str) -> Role {
    let lower = name.trim().to_ascii_lowercase();
    // A unit in brackets or parentheses follows the name.
    let base = lower
        .split(|c: char| c == '[' || c == '(' || c.is_whitespace())
        .next()
        .unwrap_or("");
    let bracketed = lower
        .split_once(['[', '('])
        .and_then(|(_, rest)| rest.split([']', ')']).next())
        .map(str::trim);
    let (stem, unit) = match base.rsplit_once('_') {
        Some((stem, unit)) if UNITS.iter().chain(&ANGLE_UNITS).any(|(u, _)| *u == unit) => {
            (stem, unit)
        }
        _ => (base, bracketed.unwrap_or("")),
    };
    let seconds_per_unit = UNITS
        .iter()
        .find(|(u, _)| *u == unit)
        .map_or(1.0, |(_, s)| *s);
    match stem {
        "t" | "time" | "timestamp" | "stamp" => Role::Time(seconds_per_unit),
        "x" => Role::X,
        "y" => Role::Y,
        "z" => Role::Z,
        "theta" | "yaw" => match ANGLE_UNITS.iter().find(|(u, _)| *u == unit) {
            Some((_, radians)) => Role::Yaw(*radians),
            None => Role::Other,
        },
        _ => Role::Other,
    }
}

/// Unit suffixes and, for times, their length in seconds (1 for lengths:
/// positions keep the file's own unit).
const UNITS: [(&str, f64); 7] = [
    ("s", 1.0),
    ("sec", 1.0),
    ("ms", 1e-3),
    ("us", 1e-6),
    ("ns", 1e-9),
    ("m", 1.0),
    ("", 1.0),
];

/// Angle unit suffixes and their size in radians (none: radians, as CARMEN
/// and ROS log a heading).
const ANGLE_UNITS: [(&str, f64); 3] = [
    ("rad", 1.0),
    ("deg", std::f64::consts::PI / 180.0),
    ("", 1.0),
];
