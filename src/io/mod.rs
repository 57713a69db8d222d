//! Reading trajectories from the file formats of `cli.md` ("Inputs") and
//! writing them back as TUM.
//!
//! Every text reader turns a whole file's text into a [`Trajectory`]; a line
//! it cannot understand ends the read with [`Error::Parse`] naming the file
//! and the 1-based line. ROS 2 bags (MCAP, binary) give the poses of one
//! topic ([`read_trajectory_topic`]; with the `mcap` feature). Readers never
//! panic, whatever the input.

mod csv;
mod detect;
mod euroc;
mod gpx;
mod kitti;
mod lines;
#[cfg(feature = "mcap")]
mod mcap;
#[cfg(feature = "mcap")]
mod mcap_fields;
mod tum;
mod writer;
mod xyz;

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::{Error, Pose, Result, Trajectory};

#[cfg(feature = "mcap")]
pub use self::mcap::{read_mcap_bytes, RECORD_LIMIT};
pub use gpx::{geodetic_to_enu, Geodetic};
pub use lines::PoseLines;
pub use writer::{write_tum, write_tum_to};

/// A trajectory file format (`--format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Format {
    /// Chosen by extension, then by sniffing the content.
    #[default]
    Auto,
    /// `t x y z qx qy qz qw` per line.
    Tum,
    /// 12 numbers per line: a 3x4 row-major pose matrix.
    Kitti,
    /// EuRoC ground-truth CSV (`t_ns, px, py, pz, qw, qx, qy, qz, ...`).
    Euroc,
    /// `x y [z]` per line, whitespace or comma separated.
    Xyz,
    /// GPX 1.0/1.1 track points, converted to a local ENU frame in metres.
    Gpx,
    /// A CSV with a header naming its columns (`t`, `x`, `y`, `z`).
    Csv,
    /// A ROS 2 bag in MCAP: the poses of one topic of one of the
    /// [`MCAP_POSE_TYPES`], timed by their header stamps (`mcap` feature).
    Mcap,
}

/// The ROS 2 message types a trajectory can be read from in an MCAP bag.
pub const MCAP_POSE_TYPES: [&str; 3] = [
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
];

impl Format {
    /// Every format, `Auto` first.
    pub const ALL: [Format; 8] = [
        Format::Auto,
        Format::Tum,
        Format::Kitti,
        Format::Euroc,
        Format::Xyz,
        Format::Gpx,
        Format::Csv,
        Format::Mcap,
    ];

    /// The lowercase name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Format::Auto => "auto",
            Format::Tum => "tum",
            Format::Kitti => "kitti",
            Format::Euroc => "euroc",
            Format::Xyz => "xyz",
            Format::Gpx => "gpx",
            Format::Csv => "csv",
            Format::Mcap => "mcap",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Format {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        Format::ALL
            .into_iter()
            .find(|f| f.name() == lower)
            .ok_or_else(|| {
                let names: Vec<&str> = Format::ALL.iter().map(|f| f.name()).collect();
                format!(
                    "unknown format '{s}' (expected one of: {})",
                    names.join(", ")
                )
            })
    }
}

/// Reads the trajectory in `path`; `Format::Auto` detects the format. An
/// MCAP bag must then hold exactly one pose topic: see
/// [`read_trajectory_topic`].
pub fn read_trajectory(path: &Path, format: Format) -> Result<Trajectory> {
    read_trajectory_topic(path, format, None)
}

/// Reads the trajectory in `path`, from the MCAP bag's `topic` when given
/// (`--topic`); `Format::Auto` detects the format (`.mcap`, or the MCAP
/// magic bytes, is a bag).
///
/// Without a topic a bag must have exactly one topic of the
/// [`MCAP_POSE_TYPES`], else the error names the pose topics there are; a
/// topic absent from the bag is an error naming the topics present with
/// their message types. Text formats have no topics: a topic given for one
/// is an error.
pub fn read_trajectory_topic(
    path: &Path,
    format: Format,
    topic: Option<&str>,
) -> Result<Trajectory> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_bytes(bytes, format, path, topic)
}

/// Reads a whole trajectory from `input` (stdin, say), named `name` in
/// messages; `Format::Auto` detects the format from the content.
pub fn read_trajectory_from(
    input: impl std::io::Read,
    name: &Path,
    format: Format,
) -> Result<Trajectory> {
    read_trajectory_from_topic(input, name, format, None)
}

/// [`read_trajectory_topic`] for a whole file read from `input` (stdin,
/// say), named `name` in messages.
pub fn read_trajectory_from_topic(
    mut input: impl std::io::Read,
    name: &Path,
    format: Format,
    topic: Option<&str>,
) -> Result<Trajectory> {
    let mut bytes = Vec::new();
    input.read_to_end(&mut bytes).map_err(|source| Error::Io {
        path: name.to_path_buf(),
        source,
    })?;
    parse_bytes(bytes, format, name, topic)
}

/// Whether `Format::Auto` takes the file at `path` holding `bytes` for an
/// MCAP bag: by extension, else by its magic bytes (a bag on stdin).
fn is_mcap(bytes: &[u8], path: &Path) -> bool {
    bytes.starts_with(b"\x89MCAP")
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// Reads the MCAP bag in `bytes`.
#[cfg(feature = "mcap")]
fn read_mcap(bytes: &[u8], topic: Option<&str>, path: &Path) -> Result<Trajectory> {
    mcap::read(bytes, topic, &path.display().to_string())
}

/// Without the `mcap` feature: an error saying so.
#[cfg(not(feature = "mcap"))]
fn read_mcap(_: &[u8], _: Option<&str>, path: &Path) -> Result<Trajectory> {
    Err(Error::input(
        path.display().to_string(),
        "reading MCAP bags needs turnprint built with the `mcap` feature",
    ))
}

/// Parses a whole file's bytes: an MCAP bag, else UTF-8 text.
fn parse_bytes(
    bytes: Vec<u8>,
    format: Format,
    path: &Path,
    topic: Option<&str>,
) -> Result<Trajectory> {
    if format == Format::Mcap || (format == Format::Auto && is_mcap(&bytes, path)) {
        return read_mcap(&bytes, topic, path);
    }
    if let Some(topic) = topic {
        return Err(Error::input(
            path.display().to_string(),
            format!("topic '{topic}' given, but only MCAP bags have topics"),
        ));
    }
    let text = match String::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => {
            let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let line = 1 + valid.iter().filter(|&&b| b == b'\n').count();
            return Err(parse_error(path, line, "not UTF-8 text"));
        }
    };
    parse_trajectory(&text, format, path)
}

/// The format `Format::Auto` picks for `text` read from `path`: by
/// extension, then by content (rules in the `detect` module).
pub fn detect_format(text: &str, path: &Path) -> Result<Format> {
    detect::detect(text.strip_prefix('\u{feff}').unwrap_or(text), path)
}

/// Parses a whole file's `text`; `path` is used for detection and messages.
pub fn parse_trajectory(text: &str, format: Format, path: &Path) -> Result<Trajectory> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let format = match format {
        Format::Auto => detect::detect(text, path)?,
        f => f,
    };
    if format == Format::Mcap {
        return Err(Error::input(path.display().to_string(), NO_MCAP_TEXT));
    }
    let poses = match line_format(format) {
        Some(mut reader) => {
            let mut poses = Vec::new();
            for (line, content) in content_lines(text) {
                poses.extend(reader.line(line, content, path)?);
            }
            poses
        }
        // GPX (detection never answers `Auto`; MCAP returned above).
        None => gpx::parse(text, path)?,
    };
    if poses.is_empty() {
        let last_line = text.lines().count().max(1);
        return Err(parse_error(path, last_line, "no poses in file"));
    }
    Ok(Trajectory {
        source: path.display().to_string(),
        poses,
    })
}

/// Why an MCAP bag cannot be parsed from text.
const NO_MCAP_TEXT: &str =
    "an MCAP bag is binary, not text: read it as a file (read_trajectory_topic)";

/// A line-oriented format read one non-blank, trimmed line at a time (`#`
/// lines included: a CSV header may be one), so that whole files and
/// streams ([`PoseLines`]) share one parser.
trait LineFormat: Send {
    /// The pose on `line` (1-based) holding `content`, or `None` for a
    /// comment or header.
    fn line(&mut self, line: usize, content: &str, path: &Path) -> Result<Option<Pose>>;
}

/// The line reader of `format`; `None` for GPX (XML, read whole), MCAP
/// (binary) and `Auto` (not yet decided).
fn line_format(format: Format) -> Option<Box<dyn LineFormat>> {
    match format {
        Format::Tum => Some(Box::new(tum::Tum)),
        Format::Kitti => Some(Box::new(kitti::Kitti)),
        Format::Euroc => Some(Box::new(euroc::Euroc)),
        Format::Xyz => Some(Box::new(xyz::Xyz::default())),
        Format::Csv => Some(Box::new(csv::Csv::default())),
        Format::Gpx | Format::Mcap | Format::Auto => None,
    }
}

/// An [`Error::Parse`] for `path` at 1-based `line`.
fn parse_error(path: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        path: PathBuf::from(path),
        line,
        message: message.into(),
    }
}

/// The lines of a line-oriented text format: `(1-based line number,
/// trimmed text)`, skipping blank lines.
fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty())
}

/// Parses one field as a finite number; the error message names the column.
fn number(field: &str, column: usize) -> std::result::Result<f64, String> {
    let field = field.trim();
    match field.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("non-finite value '{field}' in column {column}")),
        Err(_) => Err(format!(
            "not a number: '{}' in column {column}",
            clip(field)
        )),
    }
}

/// Parses every field as a finite number.
fn numbers<'a>(fields: impl Iterator<Item = &'a str>) -> std::result::Result<Vec<f64>, String> {
    fields.enumerate().map(|(i, f)| number(f, i + 1)).collect()
}

/// Fields split on whitespace.
fn split_ws(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// Fields split on commas and/or whitespace (empty fields dropped).
fn split_comma_ws(line: &str) -> Vec<&str> {
    line.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect()
}

/// A field shortened for a one-line message.
fn clip(s: &str) -> String {
    const MAX: usize = 40;
    if s.chars().count() <= MAX {
        s.to_string()
    } else {
        let head: String = s.chars().take(MAX).collect();
        format!("{head}...")
    }
}

/// An orientation from quaternion components, or an error for a zero one.
fn quaternion(
    w: f64,
    x: f64,
    y: f64,
    z: f64,
) -> std::result::Result<nalgebra::UnitQuaternion<f64>, String> {
    let q = nalgebra::Quaternion::new(w, x, y, z);
    let norm = q.norm();
    // A quaternion this far from unit length is not an orientation at all
    // (typically zeros in a column that should hold one).
    if !norm.is_finite() || norm < 1e-6 {
        return Err(format!("quaternion ({x} {y} {z} {w}) has no length"));
    }
    Ok(nalgebra::UnitQuaternion::new_normalize(q))
}

/// A pose with every field given.
fn pose(
    t: Option<f64>,
    position: nalgebra::Vector3<f64>,
    orientation: Option<nalgebra::UnitQuaternion<f64>>,
) -> Pose {
    Pose {
        t,
        position,
        orientation,
    }
}
