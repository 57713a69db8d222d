//! Reading every kind of file in the shared data: detection, pose counts,
//! values and timestamps against the files' own text, a TUM round trip, and
//! the GPX east-north-up conversion against independently computed
//! distances. Files absent from the data location are skipped.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use turnprint::io::{
    detect_format, geodetic_to_enu, parse_trajectory, read_trajectory, write_tum, Format, Geodetic,
};

mod common;

/// The GPX track of the first 40 fixes of KITTI 00's GPS, made from
/// `gtsam_data/KittiGps_converted.txt` ([`common::kitti_gps_gpx`]).
const GPX: &str = "kitti_gps_head.gpx";

/// `name` (the shared data's layout, or [`GPX`], written into `dir`) where
/// it is, or `None` after a line saying it is skipped.
fn data(dir: &Path, name: &str) -> Option<PathBuf> {
    if name == GPX {
        let path = dir.join(GPX);
        if !path.is_file() {
            std::fs::write(&path, common::kitti_gps_gpx(40)?).unwrap();
        }
        return Some(path);
    }
    common::shared(name)
}

/// Every one of `names` where it is ([`data`]), or `None` when one is absent.
fn all<const N: usize>(dir: &Path, names: [&str; N]) -> Option<[PathBuf; N]> {
    let mut paths = Vec::with_capacity(N);
    for name in names {
        paths.push(data(dir, name)?);
    }
    paths.try_into().ok()
}

fn detected(path: &Path) -> Format {
    let text = std::fs::read_to_string(path).unwrap();
    detect_format(&text, path).unwrap()
}

/// Numbers of the `line`-th (1-based) line of a file, split on commas and
/// whitespace: the expected values come straight from the file.
fn numbers_of_line(path: &Path, line: usize) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .nth(line - 1)
        .unwrap()
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .map(|f| f.parse().unwrap())
        .collect()
}

#[test]
fn auto_detection_picks_the_format_of_every_kind_of_shared_file() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("kitti_gt/00.txt", Format::Kitti),
        ("kitti_gt/02.txt", Format::Kitti),
        ("kitti_gt/05.txt", Format::Kitti),
        ("kitti_gt/06.txt", Format::Kitti),
        ("kitti_gt/08.txt", Format::Kitti),
        ("kitti_orbslam2_vio/00_orbslam2_tum.txt", Format::Tum),
        ("kitti_orbslam2_vio/06_orbslam2_tum.txt", Format::Tum),
        ("gtsam_data/KittiGps_converted.txt", Format::Csv),
        ("euroc/V102_groundtruth.csv", Format::Euroc),
        ("carmen/fr079_odom.csv", Format::Csv),
        (GPX, Format::Gpx),
        ("evo/KITTI_00_ORB.txt", Format::Kitti),
        ("evo/KITTI_00_SPTAM.txt", Format::Kitti),
        ("evo/georeferenced.tum", Format::Tum),
        ("evo/fr2_desk_groundtruth.txt", Format::Tum),
        ("evo/fr2_desk_ORB_kf_mono.txt", Format::Tum),
        ("euroc/MH_01_easy.txt", Format::Tum),
        ("euroc/V1_01_easy_original.txt", Format::Tum),
        ("carmen/intel_odom.csv", Format::Csv),
    ];
    for (name, format) in cases {
        let Some(path) = data(dir.path(), name) else {
            continue;
        };
        assert_eq!(detected(&path), format, "{name}");
    }
}

#[test]
fn detection_sniffs_content_when_the_extension_says_nothing() {
    let p = Path::new("trajectory.dat");
    let detect = |text: &str| detect_format(text, p).unwrap();
    assert_eq!(detect("<?xml version=\"1.0\"?>\n<gpx></gpx>"), Format::Gpx);
    assert_eq!(detect("# x y\n1 2\n3 4\n"), Format::Csv);
    assert_eq!(detect("1 2 3\n"), Format::Xyz);
    assert_eq!(detect("1,2\n"), Format::Xyz);
    assert_eq!(detect("t x y z qx qy qz qw\n"), Format::Csv);
    assert_eq!(detect("0 1 2 3 0 0 0 1\n"), Format::Tum);
    // Extension first: a .tum file is TUM whatever it holds.
    assert_eq!(
        detect_format("1 2 3\n", Path::new("a.tum")).unwrap(),
        Format::Tum
    );
    assert_eq!(detect_format("", Path::new("a.GPX")).unwrap(), Format::Gpx);
    assert_eq!(detect("1403715524907143168,1,2,3,1,0,0,0\n"), Format::Euroc);
    // Comma-separated TUM or EuRoC with seconds: ambiguous, so no guess.
    assert!(detect_format("0.5,1,2,3,0,0,0,1\n", p).is_err());
    let err = detect_format("1 2 3 4 5\n", p).unwrap_err().to_string();
    assert!(err.starts_with("trajectory.dat:1:"), "{err}");
    assert!(err.contains("--format"), "{err}");
}

#[test]
fn every_kind_of_file_reads_with_the_right_pose_count() {
    let dir = tempfile::tempdir().unwrap();
    // Comment lines (georeferenced 2, fr2/desk 3, the CSV headers) are no
    // poses.
    let cases = [
        ("kitti_gt/00.txt", 4541),
        ("kitti_gt/02.txt", 4661),
        ("kitti_gt/05.txt", 2761),
        ("kitti_gt/06.txt", 1101),
        ("kitti_gt/08.txt", 4071),
        ("kitti_orbslam2_vio/00_orbslam2_tum.txt", 4541),
        ("kitti_orbslam2_vio/06_orbslam2_tum.txt", 1101),
        ("gtsam_data/KittiGps_converted.txt", 470),
        ("euroc/V102_groundtruth.csv", 16702),
        ("carmen/fr079_odom.csv", 8951),
        (GPX, 40),
        ("evo/KITTI_00_ORB.txt", 4541),
        ("evo/georeferenced.tum", 1000),
        ("evo/fr2_desk_groundtruth.txt", 20957),
        ("carmen/intel_odom.csv", 26915),
    ];
    for (name, count) in cases {
        let Some(path) = data(dir.path(), name) else {
            continue;
        };
        let traj = read_trajectory(&path, Format::Auto).unwrap();
        assert_eq!(traj.len(), count, "{name}");
        assert_eq!(traj.source, path.display().to_string());
    }
}

#[test]
fn kitti_positions_are_the_last_column_and_orientation_the_rotation_block() {
    let Some(path) = common::shared("kitti_gt/00.txt") else {
        return;
    };
    let traj = read_trajectory(&path, Format::Kitti).unwrap();
    for line in [1, 2, 1000, 4541] {
        let v = numbers_of_line(&path, line);
        let pose = &traj.poses[line - 1];
        assert_eq!(pose.position, Vector3::new(v[3], v[7], v[11]));
        assert_eq!(pose.t, None);
        let r = pose.orientation.unwrap().to_rotation_matrix();
        for (i, j) in [
            (0, 0),
            (0, 1),
            (0, 2),
            (1, 0),
            (1, 1),
            (1, 2),
            (2, 0),
            (2, 1),
            (2, 2),
        ] {
            assert!(
                (r[(i, j)] - v[4 * i + j]).abs() < 1e-5,
                "line {line} R{i}{j}"
            );
        }
    }
}

#[test]
fn tum_timestamps_are_the_kitti_frame_times() {
    let dir = tempfile::tempdir().unwrap();
    let Some([tum, times]) = all(
        dir.path(),
        [
            "kitti_orbslam2_vio/00_orbslam2_tum.txt",
            "kitti_gt/00_times.txt",
        ],
    ) else {
        return;
    };
    let traj = read_trajectory(&tum, Format::Auto).unwrap();
    let times = std::fs::read_to_string(times).unwrap();
    let times: Vec<f64> = times.lines().map(|l| l.trim().parse().unwrap()).collect();
    assert_eq!(times.len(), traj.len());
    for (pose, t) in traj.poses.iter().zip(&times) {
        // The TUM file rounds to microseconds.
        assert!((pose.t.unwrap() - t).abs() < 1e-5);
    }
    let v = numbers_of_line(&tum, 2);
    let pose = &traj.poses[1];
    assert_eq!(pose.position, Vector3::new(v[1], v[2], v[3]));
    let q = pose.orientation.unwrap();
    let norm = (v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]).sqrt();
    assert!((q.coords.x - v[4] / norm).abs() < 1e-12);
    assert!((q.coords.w - v[7] / norm).abs() < 1e-12);
}

#[test]
fn euroc_times_are_nanoseconds_and_quaternions_scalar_first() {
    let Some(path) = common::shared("euroc/V102_groundtruth.csv") else {
        return;
    };
    let traj = read_trajectory(&path, Format::Auto).unwrap();
    let first = &traj.poses[0];
    // 1403715524907143168 ns, line 2 of the file.
    assert!((first.t.unwrap() - 1_403_715_524.907_143).abs() < 1e-6);
    assert_eq!(first.position, Vector3::new(0.515356, 1.996773, 0.971104));
    let q = first.orientation.unwrap();
    let norm =
        (0.161996f64.powi(2) + 0.789985f64.powi(2) + 0.205376f64.powi(2) + 0.554528f64.powi(2))
            .sqrt();
    assert!((q.coords.w - 0.161996 / norm).abs() < 1e-12);
    assert!((q.coords.x - 0.789985 / norm).abs() < 1e-12);
    assert!((q.coords.y + 0.205376 / norm).abs() < 1e-12);
    assert!((q.coords.z - 0.554528 / norm).abs() < 1e-12);
    // 200 Hz ground truth: consecutive stamps 5 ms apart.
    let dt = traj.poses[1].t.unwrap() - first.t.unwrap();
    assert!((dt - 0.005).abs() < 1e-6, "{dt}");
}

#[test]
fn csv_reads_named_columns_and_ignores_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let Some([gps_path, odom_path]) = all(
        dir.path(),
        ["gtsam_data/KittiGps_converted.txt", "carmen/fr079_odom.csv"],
    ) else {
        return;
    };
    let gps = read_trajectory(&gps_path, Format::Auto).unwrap();
    let v = numbers_of_line(&gps_path, 2);
    assert_eq!(gps.poses[0].t, Some(v[0]));
    assert_eq!(gps.poses[0].position, Vector3::new(v[1], v[2], v[3]));
    let odom = read_trajectory(&odom_path, Format::Auto).unwrap();
    // theta is the heading about z, and z is 0.
    assert_eq!(odom.poses[0].t, Some(1211.530144));
    assert_eq!(
        odom.poses[0].position,
        Vector3::new(-3.034287, 8.291214, 0.0)
    );
    let theta = numbers_of_line(&odom_path, 2)[3];
    let q = odom.poses[0]
        .orientation
        .expect("theta gives an orientation");
    assert!((q.angle() - theta.abs()).abs() < 1e-12);
    assert!((q * Vector3::x()).z.abs() < 1e-12);
    assert!(((q * Vector3::x()).y.atan2((q * Vector3::x()).x) - theta).abs() < 1e-12);
    let ms = parse_trajectory(
        "x [m],stamp [ms],y\n1,2500,3\n",
        Format::Csv,
        Path::new("m.csv"),
    )
    .unwrap();
    assert_eq!(ms.poses[0].t, Some(2.5));
    assert_eq!(ms.poses[0].position, Vector3::new(1.0, 3.0, 0.0));
    assert_eq!(ms.poses[0].orientation, None);
    for header in ["t,x,y,yaw_deg", "t,x,y,yaw [deg]", "t x y theta_rad"] {
        let value = if header.contains("deg") {
            "90"
        } else {
            "1.5707963267948966"
        };
        let sep = if header.contains(',') { "," } else { " " };
        let text = format!("{header}\n0{sep}1{sep}2{sep}{value}\n");
        let p = parse_trajectory(&text, Format::Csv, Path::new("h.csv")).unwrap();
        let q = p.poses[0].orientation.expect(header);
        assert!((q * Vector3::x() - Vector3::y()).norm() < 1e-12, "{header}");
    }
}

#[test]
fn xyz_accepts_two_or_three_columns_with_commas_or_spaces() {
    let p = Path::new("p.xyz");
    let two = parse_trajectory("# path\n1 2\n3,4\n\n5 , 6\n", Format::Xyz, p).unwrap();
    assert_eq!(
        two.positions(),
        vec![
            Vector3::new(1.0, 2.0, 0.0),
            Vector3::new(3.0, 4.0, 0.0),
            Vector3::new(5.0, 6.0, 0.0)
        ]
    );
    let three = parse_trajectory("1 2 3\n4\t5\t6\n", Format::Auto, p).unwrap();
    assert_eq!(three.poses[1].position, Vector3::new(4.0, 5.0, 6.0));
}

#[test]
fn tum_round_trip_write_then_read_is_equal() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "kitti_orbslam2_vio/06_orbslam2_tum.txt",
        "kitti_gt/06.txt",
        "euroc/V102_groundtruth.csv",
        GPX,
    ] {
        let Some(path) = data(dir.path(), name) else {
            continue;
        };
        let original = read_trajectory(&path, Format::Auto).unwrap();
        let out = dir.path().join("out.txt");
        write_tum(&out, &original).unwrap();
        let back = read_trajectory(&out, Format::Auto).unwrap();
        assert_eq!(back.len(), original.len(), "{name}");
        for (i, (a, b)) in original.poses.iter().zip(&back.poses).enumerate() {
            assert_eq!(a.position, b.position, "{name} pose {i}");
            // A pose without a time is written with its index as time.
            assert_eq!(b.t, Some(a.t.unwrap_or(i as f64)), "{name} pose {i}");
            let qa = a.orientation.unwrap_or_default();
            let qb = b.orientation.unwrap();
            assert!(qa.angle_to(&qb) < 1e-9, "{name} pose {i}");
        }
    }
}

#[test]
fn write_tum_to_an_unwritable_path_is_an_io_error() {
    let Some(path) = common::shared("kitti_gt/06.txt") else {
        return;
    };
    let traj = read_trajectory(&path, Format::Kitti).unwrap();
    let err = write_tum(Path::new("/nonexistent-dir/x.txt"), &traj).unwrap_err();
    assert!(matches!(err, turnprint::Error::Io { .. }));
    assert!(err.to_string().starts_with("/nonexistent-dir/x.txt:"));
}

#[test]
fn gpx_track_comes_back_as_the_gps_positions_it_was_made_from() {
    let dir = tempfile::tempdir().unwrap();
    let Some([gpx, gps]) = all(dir.path(), [GPX, "gtsam_data/KittiGps_converted.txt"]) else {
        return;
    };
    let gpx = read_trajectory(&gpx, Format::Auto).unwrap();
    assert_eq!(gpx.len(), 40);
    let first = numbers_of_line(&gps, 2);
    for (i, pose) in gpx.poses.iter().enumerate() {
        let row = numbers_of_line(&gps, i + 2);
        let expected = Vector3::new(row[1] - first[1], row[2] - first[2], row[3] - first[3]);
        let error = (pose.position - expected).norm();
        assert!(error < 1e-3, "point {i}: {error} m");
        // Times keep the file's offsets (written to microseconds).
        let dt = pose.t.unwrap() - gpx.poses[0].t.unwrap();
        assert!((dt - (row[0] - first[0])).abs() < 2e-6, "point {i}");
    }
    // 2011-10-03T12:55:34.478376Z
    assert!((gpx.poses[0].t.unwrap() - 1_317_646_534.478_376).abs() < 1e-5);
}

/// WGS84 meridian and prime-vertical radii of curvature (m) at `lat_deg`:
/// M = a(1-e²)/(1-e² sin²φ)^(3/2), N = a/(1-e² sin²φ)^(1/2).
fn radii(lat_deg: f64) -> (f64, f64) {
    let a = 6_378_137.0;
    let f = 1.0 / 298.257_223_563;
    let e2 = f * (2.0 - f);
    let s2 = lat_deg.to_radians().sin().powi(2);
    let w = 1.0 - e2 * s2;
    (a * (1.0 - e2) / w.powf(1.5), a / w.sqrt())
}

#[test]
fn enu_distances_match_the_radii_of_curvature() {
    let origin = Geodetic {
        lat_deg: 48.0,
        lon_deg: 8.0,
        height: 0.0,
    };
    let (m, n) = radii(48.0);
    let north = geodetic_to_enu(
        &origin,
        &Geodetic {
            lat_deg: 48.001,
            ..origin
        },
    );
    // About 111.2 m north for 0.001 degree of latitude.
    assert!(
        (north.y - m * 0.001f64.to_radians()).abs() < 0.01,
        "{north}"
    );
    assert!((north.y - 111.2).abs() < 0.1, "{north}");
    assert!(north.x.abs() < 1e-6);
    let east = geodetic_to_enu(
        &origin,
        &Geodetic {
            lon_deg: 8.001,
            ..origin
        },
    );
    let expected_east = n * 48.0f64.to_radians().cos() * 0.001f64.to_radians();
    assert!(
        (east.x - expected_east).abs() < 0.01,
        "{east} vs {expected_east}"
    );
    assert!(east.y.abs() < 0.01);
    let up = geodetic_to_enu(
        &origin,
        &Geodetic {
            height: 10.0,
            ..origin
        },
    );
    assert!((up - Vector3::new(0.0, 0.0, 10.0)).norm() < 1e-6);
}

#[test]
fn gpx_origin_includes_the_first_elevation_and_missing_ele_is_zero() {
    let text = r#"<?xml version="1.0"?>
<gpx version="1.0" xmlns="http://www.topografix.com/GPX/1/0"><trk><trkseg>
<trkpt lat="48.0" lon="8.0"><ele>100</ele></trkpt>
<trkpt lat="48.001" lon="8.0"/>
<trkpt lat="48.0" lon="8.0"><ele>105.5</ele><time>2020-01-01T00:00:00</time></trkpt>
</trkseg></trk></gpx>"#;
    let traj = parse_trajectory(text, Format::Auto, Path::new("t.gpx")).unwrap();
    assert_eq!(traj.len(), 3);
    assert_eq!(traj.poses[0].position, Vector3::zeros());
    // No ele: height 0, so 100 m below the origin.
    assert!((traj.poses[1].position.z + 100.0).abs() < 0.01);
    assert!((traj.poses[2].position - Vector3::new(0.0, 0.0, 5.5)).norm() < 1e-6);
    assert_eq!(traj.poses[0].t, None);
    assert_eq!(traj.poses[2].t, Some(1_577_836_800.0));
}

#[test]
fn format_names_parse_and_print_in_lowercase() {
    for f in Format::ALL {
        assert_eq!(f.to_string().parse::<Format>().unwrap(), f);
        assert_eq!(f.to_string(), f.to_string().to_lowercase());
    }
    assert_eq!("TUM".parse::<Format>().unwrap(), Format::Tum);
    assert!("tumx".parse::<Format>().unwrap_err().contains("tum, kitti"));
}

#[test]
fn a_gpx_route_without_a_track_is_read_from_its_route_points() {
    let text = r#"<?xml version="1.0"?>
<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">
<wpt lat="47.0" lon="7.0"/>
<rte><rtept lat="48.0" lon="8.0"><ele>100</ele></rtept><rtept lat="48.001" lon="8.0"><ele>100</ele></rtept>
<rtept lat="48.002" lon="8.001"><ele>100</ele></rtept></rte></gpx>"#;
    let traj = parse_trajectory(text, Format::Auto, Path::new("route.gpx")).unwrap();
    assert_eq!(traj.len(), 3);
    assert_eq!(traj.poses[0].position, Vector3::zeros());
    // 0.001° of latitude is about 111 m north.
    assert!(
        (traj.poses[1].position.y - 111.2).abs() < 0.5,
        "{:?}",
        traj.poses[1]
    );
    // With a track, the route is not the path.
    let both = text.replace(
        "</rte>",
        "</rte><trk><trkseg><trkpt lat=\"48.0\" lon=\"8.0\"/><trkpt lat=\"48.0\" lon=\"8.001\"/></trkseg></trk>",
    );
    let traj = parse_trajectory(&both, Format::Auto, Path::new("both.gpx")).unwrap();
    assert_eq!(traj.len(), 2);
    let bad = text.replace(
        r#"<rtept lat="48.001" lon="8.0">"#,
        r#"<rtept lat="48.001">"#,
    );
    let err = parse_trajectory(&bad, Format::Auto, Path::new("bad.gpx")).unwrap_err();
    assert!(err.to_string().contains("<rtept> without lon"), "{err}");
}
