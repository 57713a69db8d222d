//! Bad trajectory input ends in a clear error naming the file and line, and
//! never in a panic, whatever the bytes.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use turnprint::io::{parse_trajectory, read_trajectory, Format};
use turnprint::Error;

mod common;

/// Writes `text` to a file named `name` in a fresh temporary directory.
fn file_with(dir: &tempfile::TempDir, name: &str, text: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Reads `text` from a file named `name` and returns the parse error's line
/// and its one-line message, checking the message names the file and line.
fn parse_failure(name: &str, text: &str, format: Format) -> (usize, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = file_with(&dir, name, text.as_bytes());
    match read_trajectory(&path, format) {
        Err(Error::Parse {
            path: p,
            line,
            message,
        }) => {
            assert_eq!(p, path);
            let shown = Error::Parse {
                path: p,
                line,
                message: message.clone(),
            }
            .to_string();
            assert!(
                shown.starts_with(&format!("{}:{line}: ", path.display())),
                "{shown}"
            );
            (line, message)
        }
        other => panic!("{name}: expected a parse error, got {other:?}"),
    }
}

#[test]
fn empty_file_has_no_poses() {
    for (name, format) in [
        ("empty.txt", Format::Auto),
        ("empty.tum", Format::Tum),
        ("empty.csv", Format::Csv),
        ("empty.gpx", Format::Auto),
        ("empty.txt", Format::Kitti),
        ("empty.txt", Format::Euroc),
        ("empty.txt", Format::Xyz),
    ] {
        let (line, message) = parse_failure(name, "", format);
        assert_eq!(line, 1);
        assert_eq!(message, "no poses in file", "{name} {format}");
    }
}

#[test]
fn only_comments_has_no_poses_and_points_at_the_end() {
    let (line, message) = parse_failure("c.txt", "# a\n\n# b\n", Format::Auto);
    assert_eq!((line, message.as_str()), (3, "no poses in file"));
    let (line, message) = parse_failure("c.csv", "t,x,y\n# nothing yet\n", Format::Auto);
    assert_eq!((line, message.as_str()), (2, "no poses in file"));
    let gpx = "<?xml version=\"1.0\"?>\n<gpx version=\"1.1\">\n<trk></trk>\n</gpx>\n";
    let (line, message) = parse_failure("c.gpx", gpx, Format::Auto);
    assert_eq!((line, message.as_str()), (4, "no poses in file"));
}

#[test]
fn nan_and_inf_are_non_finite_values() {
    let cases = [
        ("a.tum", "0 1 2 3 0 0 0 1\n1 nan 2 3 0 0 0 1\n", 2),
        ("a.tum", "# c\n0 1 2 3 0 0 0 1\n1 1 2 3 0 0 0 inf\n", 3),
        ("a.txt", "1 0 0 NaN 0 1 0 0 0 0 1 0\n", 1),
        ("a.xyz", "1 2\n-inf 3\n", 2),
        ("a.csv", "t,x,y\n0,1,2\n1,infinity,2\n", 3),
        (
            "a.csv",
            "#t_ns, px, py, pz, qw, qx, qy, qz\n1403715524907143168,nan,0,0,1,0,0,0\n",
            2,
        ),
    ];
    for (name, text, expected_line) in cases {
        let (line, message) = parse_failure(name, text, Format::Auto);
        assert_eq!(line, expected_line, "{name}: {message}");
        assert!(message.contains("non-finite value"), "{name}: {message}");
    }
    let gpx = "<gpx><trk><trkseg>\n<trkpt lat=\"NaN\" lon=\"8\"></trkpt>\n</trkseg></trk></gpx>";
    let (line, message) = parse_failure("a.gpx", gpx, Format::Auto);
    assert_eq!(line, 2);
    assert!(message.contains("non-finite value"), "{message}");
}

#[test]
fn wrong_column_count_names_the_expected_columns() {
    let cases = [
        (
            "a.tum",
            "0 1 2 3 0 0 0 1\n1 2 3 0 0 0 1\n",
            Format::Auto,
            2,
            "expected 8 numbers",
        ),
        (
            "a.txt",
            "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n",
            Format::Auto,
            2,
            "expected 12 numbers",
        ),
        (
            "a.xyz",
            "1 2 3\n1 2\n",
            Format::Auto,
            2,
            "expected 3 numbers like line 1",
        ),
        (
            "a.xyz",
            "1 2 3 4\n",
            Format::Xyz,
            1,
            "expected 2 or 3 numbers",
        ),
        (
            "a.csv",
            "t,x,y\n0,1,2\n1,2\n",
            Format::Auto,
            3,
            "expected 3 values",
        ),
        (
            "a.csv",
            "#t_ns, px\n1403715524907143168,1,2,3,1,0,0\n",
            Format::Euroc,
            2,
            "at least 8",
        ),
        (
            "a.txt",
            "1 2 3 4 5\n",
            Format::Auto,
            1,
            "cannot tell the format",
        ),
    ];
    for (name, text, format, expected_line, words) in cases {
        let (line, message) = parse_failure(name, text, format);
        assert_eq!(line, expected_line, "{name}: {message}");
        assert!(message.contains(words), "{name}: {message}");
    }
}

#[test]
fn non_numeric_fields_are_reported_with_their_column() {
    let (line, message) = parse_failure(
        "a.tum",
        "0 1 2 3 0 0 0 1\n\n1 2 x3 4 0 0 0 1\n",
        Format::Auto,
    );
    assert_eq!(line, 3);
    assert!(
        message.contains("not a number: 'x3' in column 3"),
        "{message}"
    );
    let (line, message) = parse_failure("a.csv", "Time,X,Y\n1,2,abc\n", Format::Auto);
    assert_eq!(line, 2);
    assert!(message.contains("'abc'"), "{message}");
    let (line, message) = parse_failure("a.csv", "a,b,c\n1,2,3\n", Format::Csv);
    assert_eq!(line, 1);
    assert!(message.contains("no x and y columns"), "{message}");
    let gpx = "<gpx><trk><trkseg>\n<trkpt lat=\"48\" lon=\"8\">\n<ele>high</ele></trkpt>\n</trkseg></trk></gpx>";
    let (line, message) = parse_failure("a.gpx", gpx, Format::Auto);
    assert_eq!(line, 3);
    assert!(message.contains("'high' is not a number"), "{message}");
    let gpx = "<gpx><trk><trkseg>\n<trkpt lat=\"48\" lon=\"8\">\n<time>yesterday</time></trkpt>\n</trkseg></trk></gpx>";
    let (line, message) = parse_failure("a.gpx", gpx, Format::Auto);
    assert_eq!(line, 3);
    assert!(message.contains("not an ISO 8601"), "{message}");
    let gpx = "<gpx><trk><trkseg>\n<trkpt lat=\"91\" lon=\"8\"/>\n</trkseg></trk></gpx>";
    let (line, message) = parse_failure("a.gpx", gpx, Format::Auto);
    assert_eq!(line, 2);
    assert!(message.contains("lat '91'"), "{message}");
}

#[test]
fn zero_quaternion_is_an_error() {
    let (line, message) = parse_failure("a.tum", "0 1 2 3 0 0 0 0\n", Format::Auto);
    assert_eq!(line, 1);
    assert!(message.contains("quaternion"), "{message}");
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let err = read_trajectory(Path::new("/no/such/file.txt"), Format::Auto).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err:?}");
    assert!(err.to_string().starts_with("/no/such/file.txt: "), "{err}");
}

#[test]
fn binary_file_is_not_utf8_text() {
    let dir = tempfile::tempdir().unwrap();
    let path = file_with(&dir, "b.txt", b"0 1 2 3 0 0 0 1\n\xff\xfe\x00junk\n");
    match read_trajectory(&path, Format::Auto) {
        Err(Error::Parse { line, message, .. }) => {
            assert_eq!(line, 2);
            assert_eq!(message, "not UTF-8 text");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn truncated_gpx_is_reported() {
    // The GPX track of the first 40 fixes of KITTI 00's real GPS, cut
    // inside the 3rd track point's <ele> and after a complete element (the
    // cases without it run when it is absent).
    if let Some(fixture) = common::kitti_gps_gpx(40) {
        for cut in [fixture.find("<ele>116.3").unwrap() + 300, fixture.len() / 2] {
            let truncated = &fixture[..cut];
            let (line, message) = parse_failure("cut.gpx", truncated, Format::Auto);
            assert!(
                message.contains("truncated GPX") || message.contains("malformed GPX"),
                "{message}"
            );
            assert!(
                line >= 1 && line <= truncated.lines().count().max(1),
                "line {line}"
            );
        }
    }
    let (_, message) = parse_failure("cut.gpx", "<gpx><trk><trkseg><trkpt lat=\"4", Format::Auto);
    assert!(message.contains("GPX"), "{message}");
    let (line, message) = parse_failure("x.gpx", "<kml>\n</kml>", Format::Auto);
    assert_eq!(line, 1);
    assert!(message.contains("not a GPX file"), "{message}");
}

/// Lines that look like the formats, with damage mixed in, so random input
/// reaches past the first check of each parser.
fn plausible_text() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just("0".to_string()),
        Just("1.5".to_string()),
        Just("-2e3".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("1e308".to_string()),
        Just("1403715524907143168".to_string()),
        Just(",".to_string()),
        Just(" ".to_string()),
        Just("\n".to_string()),
        Just("#".to_string()),
        Just("t,x,y".to_string()),
        Just("x [m]".to_string()),
        Just("<gpx>".to_string()),
        Just("<trkpt lat=\"48.1\" lon=\"8\">".to_string()),
        Just("<trkpt lat=\"1\" lon=\"2\"/>".to_string()),
        Just("<ele>".to_string()),
        Just("</ele>".to_string()),
        Just("<time>2011-10-03T12:00:00Z</time>".to_string()),
        Just("</trkpt>".to_string()),
        Just("&amp;".to_string()),
        Just("<![CDATA[5]]>".to_string()),
        "[ -~]{0,6}",
    ];
    proptest::collection::vec(token, 0..60).prop_map(|t| t.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn no_parser_panics_on_random_text(text in "\\PC{0,300}") {
        for format in Format::ALL {
            for name in ["f.txt", "f.csv", "f.gpx"] {
                let _ = parse_trajectory(&text, format, Path::new(name));
            }
        }
    }

    #[test]
    fn no_parser_panics_on_plausible_damaged_text(text in plausible_text()) {
        for format in Format::ALL {
            for name in ["f.txt", "f.csv", "f.gpx"] {
                let result = parse_trajectory(&text, format, Path::new(name));
                if let Ok(traj) = result {
                    prop_assert!(!traj.poses.is_empty());
                    for pose in &traj.poses {
                        prop_assert!(pose.position.iter().all(|v| v.is_finite()));
                        prop_assert!(pose.t.is_none_or(f64::is_finite));
                    }
                }
            }
        }
    }

    #[test]
    fn no_panic_on_random_bytes_read_from_a_file(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let dir = tempfile::tempdir().unwrap();
        let path = file_with(&dir, "r.txt", &bytes);
        for format in Format::ALL {
            let _ = read_trajectory(&path, format);
        }
    }

    #[test]
    fn kitti_matrices_of_any_finite_numbers_never_panic(v in proptest::collection::vec(-1e300f64..1e300, 12)) {
        let line: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        let _ = parse_trajectory(&line.join(" "), Format::Kitti, Path::new("k.txt"));
    }
}
