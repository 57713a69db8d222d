//! Inputs the fuzz targets in `fuzz/` found to break a promise, minimised
//! and inlined: each test is named after the bug it pins down.
//!
//! `cargo test --no-default-features --test fuzz_regressions`

use std::path::Path;

use turnprint::io::{parse_trajectory, read_trajectory_from, Format};
use turnprint::{Error, Trajectory};

/// Reads `bytes` as a file named `name`.
fn read(bytes: &[u8], format: Format, name: &str) -> turnprint::Result<Trajectory> {
    read_trajectory_from(bytes, Path::new(name), format)
}

/// The line and message of the parse error reading `bytes` must end in.
fn parse_error(bytes: &[u8], format: Format, name: &str) -> (usize, String) {
    match read(bytes, format, name) {
        Err(Error::Parse { line, message, .. }) => (line, message),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn gpx_elevations_far_apart_overflow_the_enu_position() {
    let gpx = b"<gpx><trk><trkseg>\n<trkpt lat=\"0\" lon=\"0\"><ele>-1e308</ele></trkpt>\n<trkpt lat=\"0\" lon=\"0\">\n<ele>1e308</ele></trkpt></trkseg></trk></gpx>";
    let (line, message) = parse_error(gpx, Format::Gpx, "f.gpx");
    assert_eq!(line, 4, "{message}");
    assert!(
        message.contains("elevation 1e308 m is out of range"),
        "{message}"
    );
    // One far point alone is still finite metres from itself.
    let one = b"<gpx><trk><trkseg><trkpt lat=\"0\" lon=\"0\"><ele>1e308</ele></trkpt></trkseg></trk></gpx>";
    let t = parse_trajectory(
        std::str::from_utf8(one).unwrap(),
        Format::Auto,
        Path::new("f.gpx"),
    )
    .unwrap();
    assert_eq!(t.poses[0].position, nalgebra::Vector3::zeros());
}
