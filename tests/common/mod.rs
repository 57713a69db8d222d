//! Helpers shared by the integration tests.

// Each test crate compiles this module and uses only some of it.
#![allow(dead_code)]

use std::io::Write;
use std::process::{Command, Output, Stdio};

use nalgebra::Vector3;
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput, Summary};

/// Every candidate the detector emits over `points`, pushed one at a time
/// (`Overflow::Block`: the same output on any machine).
pub fn emitted_candidates(points: &[Vector3<f64>], config: OnlineConfig) -> Vec<CandidateEvent> {
    replayed(points, config).0
}

/// Every candidate the detector emits over `points`, polled as they come
/// (`Overflow::Block`), and the summary.
pub fn replayed(points: &[Vector3<f64>], config: OnlineConfig) -> (Vec<CandidateEvent>, Summary) {
    let mut det = Detector::new(config, Overflow::Block);
    let mut out = Vec::new();
    for p in points {
        det.push(&PoseInput::at(*p));
        out.extend(det.poll());
    }
    let (rest, summary) = det.finish();
    out.extend(rest);
    (out, summary)
}

/// The output of `command` run with all of `input` on its stdin (written
/// from a thread, so a command that writes while it reads cannot block).
pub fn output_with_stdin(mut command: Command, input: Vec<u8>) -> Output {
    let mut child = command
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the command starts");
    let mut stdin = child.stdin.take().expect("piped stdin");
    std::thread::spawn(move || stdin.write_all(&input));
    child.wait_with_output().expect("the command ends")
}

/// Whether candidate `c` is correct against the ground-truth positions
/// `truth` (`eval::checks::loop_correct`, 10 m).
pub fn is_correct(c: &CandidateEvent, truth: &[Vector3<f64>]) -> bool {
    use turnprint_eval::checks::{loop_correct, LoopClaim};
    let h = &c.hypothesis;
    let claim = LoopClaim {
        query: h.a_range,
        matched: h.b_range,
        score: h.score,
    };
    loop_correct(&claim, truth, 10.0)
}

/// `file` (the shared data's layout, e.g. `kitti_gt/00.txt`) where the
/// real data is, or `None` after a line saying it is skipped
/// ([`turnprint_eval::data::require`]).
pub fn shared(file: &str) -> Option<std::path::PathBuf> {
    turnprint_eval::data::require(file)
}

/// The first of the data folders ([`turnprint_eval::data::data_dirs`]) that
/// holds every one of `files` (e.g. for `load_sequence`, which reads what
/// it finds in one folder), or `None` after a line saying it is skipped.
pub fn shared_dir(files: &[&str]) -> Option<std::path::PathBuf> {
    let dirs = turnprint_eval::data::data_dirs();
    if let Some(dir) = dirs
        .iter()
        .find(|d| files.iter().all(|f| d.join(f).is_file()))
    {
        return Some(dir.clone());
    }
    for f in files {
        shared(f)?;
    }
    // Each file is somewhere, but not all in one folder.
    let message = format!("{files:?} are in no single one of {dirs:?}");
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    assert!(!ci, "CI=true: {message}");
    eprintln!("skipped: {message}");
    None
}

/// EuRoC VIO estimate `method` ("VI-SLAM" or "mono VIO") of `session`
/// (e.g. "MH_04") and its session's truth at the estimate's times, or
/// `None` after a line saying it is skipped.
pub fn euroc_vio(
    method: &str,
    session: &str,
) -> Option<(turnprint::Trajectory, Vec<Option<Vector3<f64>>>)> {
    use turnprint::io::{read_trajectory, Format};
    use turnprint_eval::kinds::catalog;
    for dir in turnprint_eval::data::data_dirs() {
        let found = catalog::euroc_vio_estimates(&dir)
            .into_iter()
            .find(|v| v.method == method && v.session == session);
        if let Some(v) = found {
            let est = read_trajectory(&dir.join(&v.estimate), Format::Auto).expect("readable");
            let gt = read_trajectory(&dir.join(v.truth), Format::Auto).expect("readable");
            let truth = catalog::truth_at_times(&est, &gt);
            return Some((est, truth));
        }
    }
    eprintln!("skipped: EuRoC {session}'s {method} estimate is in no data folder");
    None
}

/// The largest distance between corresponding poses of two paths.
pub fn farthest_apart(a: &[turnprint::Pose], b: &[turnprint::Pose]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a.position - b.position).norm())
        .fold(0.0, f64::max)
}

/// APE (RMSE, SE(3)-aligned) of `positions` against `truth` where it is
/// known.
pub fn ape_where_known(positions: &[Vector3<f64>], truth: &[Option<Vector3<f64>>]) -> f64 {
    use turnprint_eval::ape::{ape, Alignment};
    let (p, t): (Vec<_>, Vec<_>) = positions
        .iter()
        .zip(truth)
        .filter_map(|(p, t)| Some((*p, (*t)?)))
        .unzip();
    ape(&p, &t, Alignment::Se3).expect("aligned").rmse
}

/// The positions of KITTI ground truth `name` (`kitti_gt/{name}.txt`), or
/// `None` after a line saying it is skipped.
pub fn kitti_gt(name: &str) -> Option<Vec<Vector3<f64>>> {
    let path = shared(&format!("kitti_gt/{name}.txt"))?;
    let t = turnprint::io::read_trajectory(&path, turnprint::io::Format::Kitti)
        .expect("KITTI ground truth reads");
    Some(t.positions())
}

/// A GPX 1.1 track of the first `rows` fixes of the real GPS of KITTI 00
/// (`gtsam_data/KittiGps_converted.txt`, `Time,X,Y,Z` metres): (X, Y, Z) minus the first row
/// read as east-north-up metres around an origin near Karlsruhe, turned
/// back into WGS84 latitude, longitude and ellipsoidal height (ENU -> ECEF
/// -> geodetic by Bowring's iteration, written apart from the reader's
/// conversion), `Time` a UTC time of day on 2011-10-03. `None` after a line
/// saying it is skipped when the GPS file is absent.
pub fn kitti_gps_gpx(rows: usize) -> Option<String> {
    let text = std::fs::read_to_string(shared("gtsam_data/KittiGps_converted.txt")?)
        .expect("GPS file reads");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .take(rows)
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect();
    Some(gpx_of_rows(&rows))
}

/// The GPX text of `Time,X,Y,Z` rows; see [`kitti_gps_gpx`].
fn gpx_of_rows(rows: &[Vec<f64>]) -> String {
    const A: f64 = 6_378_137.0;
    const F: f64 = 1.0 / 298.257_223_563;
    const ORIGIN: (f64, f64, f64) = (48.982545, 8.390366, 116.38);
    let e2 = F * (2.0 - F);
    let ecef = |lat: f64, lon: f64, h: f64| {
        let (phi, lam) = (lat.to_radians(), lon.to_radians());
        let n = A / (1.0 - e2 * phi.sin().powi(2)).sqrt();
        (
            (n + h) * phi.cos() * lam.cos(),
            (n + h) * phi.cos() * lam.sin(),
            (n * (1.0 - e2) + h) * phi.sin(),
        )
    };
    let geodetic = |x: f64, y: f64, z: f64| {
        let lam = y.atan2(x);
        let p = x.hypot(y);
        let mut phi = z.atan2(p * (1.0 - e2));
        for _ in 0..10 {
            let n = A / (1.0 - e2 * phi.sin().powi(2)).sqrt();
            let h = p / phi.cos() - n;
            phi = z.atan2(p * (1.0 - e2 * n / (n + h)));
        }
        let n = A / (1.0 - e2 * phi.sin().powi(2)).sqrt();
        (phi.to_degrees(), lam.to_degrees(), p / phi.cos() - n)
    };
    let (x0, y0, z0) = ecef(ORIGIN.0, ORIGIN.1, ORIGIN.2);
    let (phi, lam) = (ORIGIN.0.to_radians(), ORIGIN.1.to_radians());
    let (sp, cp, sl, cl) = (phi.sin(), phi.cos(), lam.sin(), lam.cos());
    let mut out = vec![
        r#"<?xml version="1.0" encoding="UTF-8"?>"#.to_string(),
        r#"<gpx version="1.1" creator="turnprint tests" xmlns="http://www.topografix.com/GPX/1/1">"#.to_string(),
        "  <trk>".to_string(),
        format!("    <name>KITTI 00 GPS, first {} fixes</name>", rows.len()),
        "    <trkseg>".to_string(),
    ];
    let first = &rows[0];
    for row in rows {
        let (e, n, u) = (row[1] - first[1], row[2] - first[2], row[3] - first[3]);
        // ECEF offset = R^T (e, n, u), R's rows being the east, north, up axes.
        let dx = -sl * e - sp * cl * n + cp * cl * u;
        let dy = cl * e - sp * sl * n + cp * sl * u;
        let dz = cp * n + sp * u;
        let (lat, lon, h) = geodetic(x0 + dx, y0 + dy, z0 + dz);
        // A time of day on 2011-10-03, to the microsecond.
        let us = (row[0] * 1e6).round() as u64;
        assert!(
            us < 86_400_000_000,
            "GPS time {} is not a time of day",
            row[0]
        );
        let (s, us) = (us / 1_000_000, us % 1_000_000);
        let stamp = format!(
            "2011-10-03T{:02}:{:02}:{:02}.{us:06}Z",
            s / 3600,
            s / 60 % 60,
            s % 60
        );
        out.push(format!(r#"      <trkpt lat="{lat:.10}" lon="{lon:.10}">"#));
        out.push(format!("        <ele>{h:.4}</ele>"));
        out.push(format!("        <time>{stamp}</time>"));
        out.push("      </trkpt>".to_string());
    }
    out.extend(["    </trkseg>", "  </trk>", "</gpx>", ""].map(String::from));
    out.join("\n")
}
