//! GPX 1.0/1.1 tracks: every `trkpt` (with `lat`, `lon`, optional `ele` and
//! `time`) becomes a pose in a local east-north-up frame in metres. Tracks
//! and segments are joined in file order; waypoints are not part of the
//! path and are ignored. A file without track points is read from its route
//! points (`rtept`, same fields): planned routes and some watches' exports
//! hold a path only as a route.
//!
//! Maths (WGS84, a = 6378137 m, f = 1/298.257223563, e² = f(2 - f)):
//! a geodetic point (φ, λ, h) has ECEF coordinates
//! `X = (N + h) cos φ cos λ`, `Y = (N + h) cos φ sin λ`,
//! `Z = (N (1 - e²) + h) sin φ` with `N = a / sqrt(1 - e² sin² φ)`;
//! its ENU coordinates at the origin (φ₀, λ₀, h₀) are `R (P - P₀)` with rows
//! `e = (-sin λ₀, cos λ₀, 0)`, `n = (-sin φ₀ cos λ₀, -sin φ₀ sin λ₀, cos φ₀)`,
//! `u = (cos φ₀ cos λ₀, cos φ₀ sin λ₀, sin φ₀)`.
//! The origin is the first track point, its elevation included; a missing
//! `ele` counts as 0. `time` (ISO 8601) becomes seconds since the Unix epoch.

use std::path::Path;

use nalgebra::Vector3;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use super::{clip, parse_error, pose};
use crate::{Pose, Result};

/// WGS84 semi-major axis (m).
const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening.
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// A WGS84 geodetic position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geodetic {
    /// Latitude in degrees, north positive.
    pub lat_deg: f64,
    /// Longitude in degrees, east positive.
    pub lon_deg: f64,
    /// Height above the ellipsoid in metres.
    pub height: f64,
}

impl Geodetic {
    /// Earth-centred, earth-fixed coordinates in metres.
    pub fn to_ecef(&self) -> Vector3<f64> {
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let (sin_lat, cos_lat) = self.lat_deg.to_radians().sin_cos();
        let (sin_lon, cos_lon) = self.lon_deg.to_radians().sin_cos();
        let n = WGS84_A / (1.0 - e2 * sin_lat * sin_lat).sqrt();
        Vector3::new(
            (n + self.height) * cos_lat * cos_lon,
            (n + self.height) * cos_lat * sin_lon,
            (n * (1.0 - e2) + self.height) * sin_lat,
        )
    }
}

/// East-north-up coordinates (metres) of `point` in the frame at `origin`.
pub fn geodetic_to_enu(origin: &Geodetic, point: &Geodetic) -> Vector3<f64> {
    let d = point.to_ecef() - origin.to_ecef();
    let (sin_lat, cos_lat) = origin.lat_deg.to_radians().sin_cos();
    let (sin_lon, cos_lon) = origin.lon_deg.to_radians().sin_cos();
    Vector3::new(
        -sin_lon * d.x + cos_lon * d.y,
        -sin_lat * cos_lon * d.x - sin_lat * sin_lon * d.y + cos_lat * d.z,
        cos_lat * cos_lon * d.x + cos_lat * sin_lon * d.y + sin_lat * d.z,
    )
}

/// A track point being read.
#[derive(Default)]
struct Point {
    /// A route point (`rtept`), not a track point.
    route: bool,
    line: usize,
    depth: usize,
    lat: Option<String>,
    lon: Option<String>,
    ele: Option<(String, usize)>,
    time: Option<(String, usize)>,
}

impl Point {
    /// The element it was read from.
    fn tag(&self) -> &'static str {
        if self.route {
            "rtept"
        } else {
            "trkpt"
        }
    }
}

/// Which child of `trkpt` the text being read belongs to.
#[derive(Clone, Copy, PartialEq)]
enum Field {
    Ele,
    Time,
}

/// The 1-based line of a byte position, counted on from the position asked
/// before: the reader asks at every event in increasing order, so the whole
/// file costs one pass (counting from the start at each event was quadratic:
/// minutes for a GPS watch's 3 MB track).
struct LineIndex<'a> {
    text: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> LineIndex<'a> {
    fn new(text: &'a str) -> Self {
        LineIndex {
            text: text.as_bytes(),
            pos: 0,
            line: 1,
        }
    }

    /// The line of byte `pos` (positions past the end: the last line).
    fn line(&mut self, pos: u64) -> usize {
        let end = usize::try_from(pos).map_or(self.text.len(), |p| p.min(self.text.len()));
        if end < self.pos {
            *self = LineIndex {
                text: self.text,
                pos: 0,
                line: 1,
            };
        }
        let newlines = self.text[self.pos..end].iter().filter(|&&b| b == b'\n');
        self.line += newlines.count();
        self.pos = end;
        self.line
    }
}

/// Parses GPX text into ENU poses.
pub(super) fn parse(text: &str, path: &Path) -> Result<Vec<Pose>> {
    let mut lines = LineIndex::new(text);
    let mut line_at = |pos: u64| lines.line(pos);
    let mut reader = Reader::from_str(text);
    let mut open: Vec<String> = Vec::new();
    let mut seen_root = false;
    let mut point: Option<Point> = None;
    let mut field: Option<(Field, String, usize)> = None;
    let mut geodetic: Vec<Fix> = Vec::new();
    // Route points, the path when there is no track point.
    let mut route: Vec<Fix> = Vec::new();
    let mut keep = |p: Point| -> Result<()> {
        let into = if p.route { &mut route } else { &mut geodetic };
        into.push(finish_point(p, path)?);
        Ok(())
    };
    loop {
        let line = line_at(reader.buffer_position());
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(e) => {
                let at = line_at(reader.error_position());
                return Err(parse_error(path, at, format!("malformed GPX (XML): {e}")));
            }
        };
        match event {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(event, Event::Empty(_));
                let name = e.local_name().as_ref().to_string();
                if !seen_root {
                    if name != "gpx" {
                        return Err(parse_error(
                            path,
                            line,
                            format!("not a GPX file: root element is <{}>", clip(&name)),
                        ));
                    }
                    seen_root = true;
                }
                match (name.as_str(), &point) {
                    ("trkpt" | "rtept", Some(outer)) => {
                        let message = format!("<{name}> inside <{}>", outer.tag());
                        return Err(parse_error(path, line, message));
                    }
                    ("trkpt" | "rtept", None) => {
                        let p = Point {
                            route: name == "rtept",
                            ..start_point(e, line, open.len())
                        };
                        if empty {
                            keep(p)?;
                        } else {
                            point = Some(p);
                        }
                    }
                    ("ele", Some(p)) if !empty && open.len() == p.depth + 1 => {
                        field = Some((Field::Ele, String::new(), line))
                    }
                    ("time", Some(p)) if !empty && open.len() == p.depth + 1 => {
                        field = Some((Field::Time, String::new(), line))
                    }
                    _ => {}
                }
                if !empty {
                    open.push(name);
                }
            }
            Event::End(e) => {
                let name = e.local_name().as_ref().to_string();
                open.pop();
                if let Some((kind, value, at)) = field.take() {
                    if let Some(p) = point.as_mut() {
                        match kind {
                            Field::Ele => p.ele = Some((value, at)),
                            Field::Time => p.time = Some((value, at)),
                        }
                    }
                }
                if name == "trkpt" || name == "rtept" {
                    if let Some(p) = point.take() {
                        keep(p)?;
                    }
                }
            }
            Event::Text(t) => {
                if let Some((_, value, _)) = field.as_mut() {
                    value.push_str(&t.xml10_content());
                }
            }
            Event::CData(c) => {
                if let Some((_, value, _)) = field.as_mut() {
                    value.push_str(&c.xml10_content());
                }
            }
            Event::GeneralRef(r) => {
                if let Some((_, value, _)) = field.as_mut() {
                    // Kept verbatim: a number or a time never holds one, so
                    // the value is then reported as invalid.
                    value.push('&');
                    value.push_str(&r);
                    value.push(';');
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(name) = open.last() {
        return Err(parse_error(
            path,
            text.lines().count().max(1),
            format!("truncated GPX: <{}> is not closed", clip(name)),
        ));
    }
    if !seen_root && !text.trim().is_empty() {
        return Err(parse_error(path, 1, "not a GPX file: no XML element"));
    }
    if geodetic.is_empty() {
        geodetic = route;
    }
    let Some(origin) = geodetic.first().map(|f| f.at) else {
        return Ok(Vec::new());
    };
    geodetic
        .iter()
        .map(|f| {
            let enu = geodetic_to_enu(&origin, &f.at);
            // Heights are only checked finite, so two far enough apart (a
            // damaged `<ele>`) put the point past the largest f64 in metres.
            if !enu.iter().all(|v| v.is_finite()) {
                return Err(parse_error(
                    path,
                    f.height_line,
                    format!(
                        "elevation {:e} m is out of range: the point is not a finite distance in metres from the first ({:e} m)",
                        f.at.height, origin.height
                    ),
                ));
            }
            Ok(pose(f.t, enu, None))
        })
        .collect()
}

/// A completed track point.
struct Fix {
    at: Geodetic,
    t: Option<f64>,
    /// The line of its `<ele>` (of the `<trkpt>` without one).
    height_line: usize,
}

/// A track point from its start tag: `lat` and `lon` kept as text.
fn start_point(e: &BytesStart<'_>, line: usize, depth: usize) -> Point {
    let mut p = Point {
        line,
        depth,
        ..Point::default()
    };
    for attr in e.attributes().flatten() {
        let value = attr.value.to_string();
        match attr.key.local_name().as_ref() {
            "lat" => p.lat = Some(value),
            "lon" => p.lon = Some(value),
            _ => {}
        }
    }
    p
}

/// The geodetic position and time of a completed track point.
fn finish_point(p: Point, path: &Path) -> Result<Fix> {
    let coordinate = |value: &Option<String>, name: &str, limit: f64| {
        let Some(text) = value else {
            let message = format!("<{}> without {name}", p.tag());
            return Err(parse_error(path, p.line, message));
        };
        match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() <= limit => Ok(v),
            Ok(v) if !v.is_finite() => Err(parse_error(
                path,
                p.line,
                format!("non-finite value '{}' in {name}", clip(text)),
            )),
            _ => Err(parse_error(
                path,
                p.line,
                format!(
                    "{name} '{}' is not a number in [-{limit}, {limit}]",
                    clip(text)
                ),
            )),
        }
    };
    let lat_deg = coordinate(&p.lat, "lat", 90.0)?;
    let lon_deg = coordinate(&p.lon, "lon", 180.0)?;
    let height = match &p.ele {
        None => 0.0,
        Some((text, line)) => match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                return Err(parse_error(
                    path,
                    *line,
                    format!("non-finite value '{}' in <ele>", clip(text.trim())),
                ))
            }
            Err(_) => {
                return Err(parse_error(
                    path,
                    *line,
                    format!("<ele> '{}' is not a number", clip(text.trim())),
                ))
            }
        },
    };
    let t = match &p.time {
        None => None,
        Some((text, line)) => {
            Some(seconds_since_epoch(text.trim()).map_err(|m| parse_error(path, *line, m))?)
        }
    };
    Ok(Fix {
        at: Geodetic {
            lat_deg,
            lon_deg,
            height,
        },
        t,
        height_line: p.ele.as_ref().map_or(p.line, |(_, line)| *line),
    })
}

/// Seconds since the Unix epoch of an ISO 8601 / xsd:dateTime stamp; one
/// without a zone is taken as UTC (GPX requires UTC).
fn seconds_since_epoch(text: &str) -> std::result::Result<f64, String> {
    let seconds = |s: i64, ns: u32| s as f64 + f64::from(ns) * 1e-9;
    if let Ok(dt) = chrono::DateTime::parse_from_rfc3339(text) {
        return Ok(seconds(dt.timestamp(), dt.timestamp_subsec_nanos()));
    }
    match chrono::NaiveDateTime::parse_from_str(text, "%Y-%m-%dT%H:%M:%S%.f") {
        Ok(naive) => {
            let dt = naive.and_utc();
            Ok(seconds(dt.timestamp(), dt.timestamp_subsec_nanos()))
        }
        Err(_) => Err(format!(
            "<time> '{}' is not an ISO 8601 date-time",
            clip(text)
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::LineIndex;

    #[test]
    fn lines_are_counted_forwards_backwards_and_past_the_end() {
        let text = "a\nbb\n\nccc\nd";
        let mut lines = LineIndex::new(text);
        let expect = |pos: usize| {
            1 + text.as_bytes()[..pos.min(text.len())]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
        };
        for pos in [0, 1, 2, 4, 5, 6, 9, 3, 0, 11, 12, 100, 7] {
            assert_eq!(lines.line(pos as u64), expect(pos), "byte {pos}");
        }
        assert_eq!(lines.line(u64::MAX), 5);
    }
}
