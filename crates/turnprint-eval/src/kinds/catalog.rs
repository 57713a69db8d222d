//! Every session of every kind in the data folder, each with the true
//! position of every pose: its own where it is a reference (motion capture,
//! RTK, GPS), the reference's at the same time or frame where it is an
//! estimate. Files that are absent or unreadable are listed, not fatal.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Vector3;

use super::{Kind, MAX_POSES};
use crate::data::{load_sequence, Sourced};
use turnprint::io::{self, geodetic_to_enu, Format, Geodetic};
use turnprint::{Pose, Trajectory};

/// One recorded path and its truth.
#[derive(Debug, Clone)]
pub struct Session {
    /// Its kind.
    pub kind: Kind,
    /// Name in the tables, e.g. `"VI-SLAM MH_02"`.
    pub name: String,
    /// The recording it comes from, e.g. `"euroc MH_02"`: an estimate and
    /// its truth share one.
    pub recording: String,
    /// Sessions naming the same frame have truths in common coordinates.
    pub frame: Option<String>,
    /// The path as the matcher sees it (an estimate in its own frame, or
    /// the reference itself).
    pub input: Vec<Vector3<f64>>,
    /// The true position of each input pose.
    pub truth: Vec<Vector3<f64>>,
    /// The truth is an independent reference: loops can be judged. Dead
    /// reckoning is its own "truth" (windows of one log share its frame),
    /// which judges merges of its windows but not its loops.
    pub judged: bool,
    /// Measured relations that judge the loops of a session without a true
    /// path (`<log>.relations` beside a CARMEN log's `<log>_odom.csv`).
    pub relations: Option<Arc<Measured>>,
}

/// A log's measured relations and the poses they are read against.
#[derive(Debug)]
pub struct Measured {
    /// The log's poses, thinned as its input (pose i is input pose i), with
    /// their times and headings.
    pub poses: Vec<Pose>,
    /// The relations (`crate::relations`).
    pub relations: Vec<crate::relations::Relation>,
}

impl Session {
    fn new(
        kind: Kind,
        name: impl Into<String>,
        frame: Option<&str>,
        input: Vec<Vector3<f64>>,
    ) -> Self {
        let name = name.into();
        Session {
            kind,
            recording: name.clone(),
            name,
            frame: frame.map(str::to_string),
            truth: input.clone(),
            input,
            judged: true,
            relations: None,
        }
        .thinned()
    }

    fn estimate(
        kind: Kind,
        name: impl Into<String>,
        recording: &str,
        frame: Option<&str>,
        pairs: Vec<(Vector3<f64>, Vector3<f64>)>,
    ) -> Self {
        let (input, truth) = pairs.into_iter().unzip();
        Session {
            kind,
            name: name.into(),
            recording: recording.to_string(),
            frame: frame.map(str::to_string),
            input,
            truth,
            judged: true,
            relations: None,
        }
        .thinned()
    }

    /// Its loops can be judged: by a true path or by measured relations.
    pub fn loops_judged(&self) -> bool {
        self.judged || self.relations.is_some()
    }

    /// Every k-th pose, so that at most [`MAX_POSES`] remain.
    fn thinned(mut self) -> Self {
        let k = thinning(self.input.len());
        if k > 1 {
            self.input = self.input.iter().step_by(k).copied().collect();
            self.truth = self.truth.iter().step_by(k).copied().collect();
        }
        self
    }
}

/// Every how many poses a session of `n` keeps one: at most [`MAX_POSES`]
/// remain.
fn thinning(n: usize) -> usize {
    n.div_ceil(MAX_POSES).max(1)
}

/// What the catalog found: the sessions, and the files it could not use
/// with the reason.
#[derive(Debug, Default)]
pub struct Catalog {
    /// Every session read, in reading order.
    pub sessions: Vec<Session>,
    /// Files left out: path relative to the data folder, and the reason.
    pub skipped: Vec<(String, String)>,
}

impl Catalog {
    fn read(&mut self, dir: &Path, rel: &str) -> Option<Trajectory> {
        let path = dir.join(rel);
        if !path.exists() {
            self.skipped.push((rel.to_string(), "absent".into()));
            return None;
        }
        match io::read_trajectory(&path, Format::Auto) {
            Ok(t) if t.len() >= 20 => Some(t),
            Ok(t) => {
                self.skipped
                    .push((rel.to_string(), format!("{} poses", t.len())));
                None
            }
            Err(e) => {
                self.skipped.push((rel.to_string(), e.to_string()));
                None
            }
        }
    }

    /// The relations measured for the log `rel` (`<log>_odom.csv`), read
    /// from `<log>.relations` beside it; `None` where there is none (or it
    /// is unreadable: listed as skipped).
    fn relations_beside(&mut self, dir: &Path, rel: &str, t: &Trajectory) -> Option<Arc<Measured>> {
        let rel_relations = rel.strip_suffix("_odom.csv")?.to_string() + ".relations";
        let file = dir.join(&rel_relations);
        if !file.exists() {
            return None;
        }
        match crate::relations::read(&file) {
            Ok(relations) => Some(Arc::new(Measured {
                poses: t.poses.iter().step_by(thinning(t.len())).cloned().collect(),
                relations,
            })),
            Err(e) => {
                self.skipped.push((rel_relations, e));
                None
            }
        }
    }

    fn add(&mut self, dir: &Path, kind: Kind, name: &str, frame: Option<&str>, rel: &str) {
        if let Some(t) = self.read(dir, rel) {
            self.sessions
                .push(Session::new(kind, name, frame, t.positions()));
        }
    }
}

/// The KITTI sequences of the catalog (every one; 01, 03, 04 and 10 do not
/// revisit and add merge cases and negatives only).
const KITTI: [&str; 11] = [
    "00", "01", "02", "03", "04", "05", "06", "07", "08", "09", "10",
];

/// LiDAR and monocular odometry of KITTI without loop closure, one pose per
/// frame: (name, folder, file prefix).
const KITTI_ODOMETRY: [(&str, &str, &str); 5] = [
    ("MULLS", "odometry/kitti_mulls_dso/mulls_no_loop", ""),
    ("A-LOAM", "odometry/kitti_aloam", ""),
    ("GICP", "odometry/kitti_cvo_lidar/lidar_gicp", ""),
    ("NDT", "odometry/kitti_cvo_lidar/lidar_ndt", ""),
    ("DSO", "odometry/kitti_mulls_dso/dso", ""),
];

/// EuRoC sessions: name, frame, ground-truth file.
const EUROC: [(&str, &str, &str); 11] = [
    ("MH_01", "euroc-mh", "euroc/MH_01_easy.txt"),
    (
        "MH_02",
        "euroc-mh",
        "multisession/euroc_vio/gt_open_vins/MH_02_easy.txt",
    ),
    (
        "MH_03",
        "euroc-mh",
        "multisession/euroc_vio/gt_open_vins/MH_03_medium.txt",
    ),
    (
        "MH_04",
        "euroc-mh",
        "multisession/euroc_vio/gt_open_vins/MH_04_difficult.txt",
    ),
    (
        "MH_05",
        "euroc-mh",
        "multisession/euroc_vio/gt_open_vins/MH_05_difficult.txt",
    ),
    ("V1_01", "euroc-v1", "euroc/V1_01_easy_original.txt"),
    (
        "V1_02",
        "euroc-v1",
        "multisession/euroc_vio/gt_open_vins/V1_02_medium.txt",
    ),
    (
        "V1_03",
        "euroc-v1",
        "multisession/euroc_vio/gt_open_vins/V1_03_difficult.txt",
    ),
    (
        "V2_01",
        "euroc-v2",
        "multisession/euroc_vio/gt_open_vins/V2_01_easy.txt",
    ),
    (
        "V2_02",
        "euroc-v2",
        "multisession/euroc_vio/gt_open_vins/V2_02_medium.txt",
    ),
    (
        "V2_03",
        "euroc-v2",
        "multisession/euroc_vio/gt_open_vins/V2_03_difficult.txt",
    ),
];

/// Reads every session under `dir` (the shared data layout).
pub fn catalog(dir: &Path) -> Catalog {
    let mut c = Catalog::default();
    kitti(dir, &mut c);
    for (name, frame, rel) in EUROC {
        c.add(dir, Kind::Drone, &format!("euroc {name}"), Some(frame), rel);
    }
    for n in [3, 6, 9] {
        let rel = format!(
            "multisession/openvins_gt/uzhfpv_indoor/indoor_forward_{n}_snapdragon_with_gt.txt"
        );
        c.add(
            dir,
            Kind::Drone,
            &format!("uzh-fpv forward {n}"),
            Some("uzh-fpv"),
            &rel,
        );
    }
    for s in [
        "square",
        "square_fast",
        "square_head",
        "circle",
        "circle_fast",
        "circle_head",
    ] {
        let rel = format!("multisession/openvins_gt/kaist_vio/{s}.txt");
        c.add(dir, Kind::Drone, &format!("kaist-vio {s}"), None, &rel);
    }
    euroc_vio(dir, &mut c);
    for n in 1..=6 {
        let rel = format!("multisession/openvins_gt/tum_vi/dataset-room{n}_512_16.txt");
        c.add(
            dir,
            Kind::Handheld,
            &format!("tum-vi room{n}"),
            Some("tum-vi"),
            &rel,
        );
    }
    c.add(
        dir,
        Kind::Handheld,
        "tum fr2/desk",
        None,
        "evo/fr2_desk_groundtruth.txt",
    );
    for (name, rel) in [
        ("intel", "carmen/intel_odom.csv"),
        ("fr079", "carmen/fr079_odom.csv"),
        ("aces", "carmen/more/aces_odom.csv"),
        ("mit-csail", "carmen/more/mit-csail_odom.csv"),
        ("fr-clinic", "carmen/more/fr-clinic_robotlaser_odom.csv"),
    ] {
        if let Some(t) = c.read(dir, rel) {
            let mut s = Session::new(Kind::Wheeled, format!("carmen {name}"), None, t.positions());
            s.judged = false;
            s.relations = c.relations_beside(dir, rel, &t);
            c.sessions.push(s);
        }
    }
    c.add(
        dir,
        Kind::CarGps,
        "evo georeferenced drive",
        None,
        "evo/georeferenced.tum",
    );
    walkers(dir, &mut c);
    c
}

fn kitti(dir: &Path, c: &mut Catalog) {
    for name in KITTI {
        if !dir.join(format!("kitti_gt/{name}.txt")).is_file() {
            c.skipped
                .push((format!("kitti_gt/{name}.txt"), "absent".into()));
            continue;
        }
        let seq = match load_sequence(dir, name) {
            Ok(seq) => seq,
            Err(e) => {
                c.skipped.push((format!("kitti {name}"), e.to_string()));
                continue;
            }
        };
        let sourced = |s: &Sourced| -> Vec<(Vector3<f64>, Vector3<f64>)> {
            s.positions
                .iter()
                .zip(&s.frames)
                .map(|(p, f)| (*p, seq.true_position(*f)))
                .collect()
        };
        let frame = format!("kitti {name}");
        c.sessions.push(Session::new(
            Kind::Car,
            frame.clone(),
            Some(&frame),
            seq.gt.clone(),
        ));
        for (method, estimate) in [("ORB-SLAM2 mono", &seq.mono), ("S-PTAM", &seq.stereo)] {
            if estimate.positions.len() >= 20 {
                let name = format!("{method} {name}");
                let pairs = sourced(estimate);
                let s = Session::estimate(Kind::CarOdometry, name, &frame, Some(&frame), pairs);
                c.sessions.push(s);
            }
        }
        if let Some((gps, _)) = &seq.gps {
            c.sessions.push(Session::estimate(
                Kind::CarGps,
                format!("KITTI GPS {name}"),
                &frame,
                Some(&frame),
                sourced(gps),
            ));
        }
        for (method, folder, prefix) in KITTI_ODOMETRY {
            let rel = format!("{folder}/{prefix}{name}.txt");
            if !dir.join(&rel).exists() {
                continue;
            }
            let Some(t) = c.read(dir, &rel) else { continue };
            if t.len() != seq.gt.len() {
                c.skipped.push((
                    rel,
                    format!("{} poses for {} frames", t.len(), seq.gt.len()),
                ));
                continue;
            }
            let pairs = t
                .positions()
                .into_iter()
                .zip(seq.gt.iter().copied())
                .collect();
            c.sessions.push(Session::estimate(
                Kind::CarOdometry,
                format!("{method} {name}"),
                &frame,
                Some(&frame),
                pairs,
            ));
        }
    }
}

/// One EuRoC VIO estimate of the data folder, paths relative to it.
#[derive(Debug, Clone)]
pub struct VioEstimate {
    /// "VI-SLAM" or "mono VIO".
    pub method: &'static str,
    /// The EuRoC session, e.g. "MH_01".
    pub session: &'static str,
    /// The frame its session's truth shares with the others' (the hall or a room).
    pub frame: &'static str,
    /// The estimate's file.
    pub estimate: String,
    /// The session's ground-truth file.
    pub truth: &'static str,
}

/// The EuRoC VIO estimates present in the data folder `dir`.
pub fn euroc_vio_estimates(dir: &Path) -> Vec<VioEstimate> {
    let mut out = Vec::new();
    for (session, frame, truth) in EUROC {
        for (method, estimate) in [
            ("VI-SLAM", format!("multisession/euroc_vio/vislam_rp/laptop_vislam_rp_{session}/stamped_traj_estimate0.txt")),
            ("mono VIO", format!("multisession/euroc_vio/vio_mono/laptop_vio_mono_{session}/stamped_traj_estimate.txt")),
        ] {
            if dir.join(&estimate).exists() {
                out.push(VioEstimate {
                    method,
                    session,
                    frame,
                    estimate,
                    truth,
                });
            }
        }
    }
    out
}

/// EuRoC VIO estimates, each paired by time with its session's truth.
fn euroc_vio(dir: &Path, c: &mut Catalog) {
    for v in euroc_vio_estimates(dir) {
        let (Some(est), Some(gt)) = (c.read(dir, &v.estimate), c.read(dir, v.truth)) else {
            continue;
        };
        let pairs = pair_by_time(&est, &gt);
        if pairs.len() < 20 {
            c.skipped
                .push((v.estimate, "no poses inside the truth's time span".into()));
            continue;
        }
        c.sessions.push(Session::estimate(
            Kind::DroneVio,
            format!("{} {}", v.method, v.session),
            &format!("euroc {}", v.session),
            Some(v.frame),
            pairs,
        ));
    }
}

/// Each estimate pose with the truth interpolated at its time; poses
/// outside the truth's span, or where the truth has a gap longer than ten
/// of its median steps in time, are left out.
pub fn pair_by_time(est: &Trajectory, truth: &Trajectory) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    est.poses
        .iter()
        .zip(truth_at_times(est, truth))
        .filter_map(|(p, t)| Some((p.position, t?)))
        .collect()
}

/// The truth interpolated at each estimate pose's time: `None` outside the
/// truth's span, where the truth has a gap longer than ten of its median
/// steps in time, or for a pose without a time.
pub fn truth_at_times(est: &Trajectory, truth: &Trajectory) -> Vec<Option<Vector3<f64>>> {
    let timed: Vec<(f64, Vector3<f64>)> = truth
        .poses
        .iter()
        .filter_map(|p| Some((p.t?, p.position)))
        .collect();
    let mut dts: Vec<f64> = timed.windows(2).map(|w| w[1].0 - w[0].0).collect();
    dts.sort_by(f64::total_cmp);
    let Some(&dt) = dts.get(dts.len() / 2) else {
        return vec![None; est.len()];
    };
    est.poses
        .iter()
        .map(|p| {
            let t = p.t?;
            let k = timed.partition_point(|(s, _)| *s <= t);
            let (a, b) = (timed.get(k.checked_sub(1)?)?, timed.get(k)?);
            if b.0 - a.0 > 10.0 * dt {
                return None;
            }
            let f = (t - a.0) / (b.0 - a.0);
            Some(a.1 + (b.1 - a.1) * f)
        })
        .collect()
}

/// Pedestrian GPX tracks, one frame per folder: every track is moved from
/// the east-north-up frame at its own first point into the frame at the
/// folder's first track's first point (a translation: the two frames' axes
/// differ by the angle the origins subtend at the earth's centre, under a
/// milliradian for a walk's few kilometres).
fn walkers(dir: &Path, c: &mut Catalog) {
    let root = dir.join("multisession/gpx_same_route");
    let Ok(folders) = std::fs::read_dir(&root) else {
        c.skipped
            .push(("multisession/gpx_same_route".into(), "absent".into()));
        return;
    };
    let mut folders: Vec<PathBuf> = folders
        .filter_map(|e| Some(e.ok()?.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    for folder in folders {
        let group = folder
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
            .into_iter()
            .flatten()
            .filter_map(|e| Some(e.ok()?.path()))
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("gpx")))
            .collect();
        files.sort();
        let mut origin: Option<Geodetic> = None;
        for file in files {
            let rel = file
                .strip_prefix(dir)
                .unwrap_or(&file)
                .to_string_lossy()
                .into_owned();
            let Some(t) = c.read(dir, &rel) else { continue };
            let Some(first) = std::fs::read_to_string(&file)
                .ok()
                .as_deref()
                .and_then(first_track_point)
            else {
                c.skipped
                    .push((rel, "no track point with lat and lon".into()));
                continue;
            };
            let shift = geodetic_to_enu(origin.get_or_insert(first), &first);
            let stem = file
                .file_stem()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let positions = t.positions().into_iter().map(|p| p + shift).collect();
            c.sessions.push(Session::new(
                Kind::Walker,
                format!("{group} {stem}"),
                Some(&group),
                positions,
            ));
        }
    }
}

/// The first `trkpt`'s (or, without one, `rtept`'s) latitude, longitude
/// and elevation (0 when absent, as the reader takes it).
fn first_track_point(text: &str) -> Option<Geodetic> {
    // The reader takes the route's points when there is no track point.
    let tag = if text.contains("trkpt") {
        "trkpt"
    } else {
        "rtept"
    };
    let start = text.find(tag)?;
    let tag_end = start + text[start..].find('>')?;
    let body_end = match text[..tag_end].ends_with('/') {
        true => tag_end,
        false => text[tag_end..]
            .find("trkpt>")
            .map_or(text.len(), |e| tag_end + e),
    };
    let element = &text[start..body_end];
    let attribute = |name: &str| -> Option<f64> {
        let at = element.find(&format!("{name}="))? + name.len() + 1;
        let quote = element[at..].chars().next()?;
        let rest = &element[at + 1..];
        rest[..rest.find(quote)?].trim().parse().ok()
    };
    let height = element
        .find("<ele>")
        .and_then(|at| {
            let rest = &element[at + 5..];
            rest[..rest.find('<')?].trim().parse().ok()
        })
        .unwrap_or(0.0);
    Some(Geodetic {
        lat_deg: attribute("lat")?,
        lon_deg: attribute("lon")?,
        height,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_logs_relations_are_read_thinned_with_it_and_a_bad_file_is_listed_not_fatal() {
        let dir = tempfile::tempdir().unwrap();
        let more = dir.path().join("carmen/more");
        std::fs::create_dir_all(&more).unwrap();
        // A circle driven at 1 Hz for 7000 s: thinned to every second pose.
        let odom: String = std::iter::once("t,x,y,theta\n".to_string())
            .chain((0..7000).map(|i| {
                let a = i as f64 * 0.01;
                format!("{i},{},{},{}\n", a.cos(), a.sin(), a + 1.5)
            }))
            .collect();
        std::fs::write(more.join("aces_odom.csv"), odom).unwrap();
        std::fs::write(more.join("aces.relations"), "10 20 0.1 0 0 0 0 0.1\n").unwrap();
        let c = catalog(dir.path());
        let aces = c.sessions.iter().find(|s| s.name == "carmen aces").unwrap();
        let measured = aces.relations.as_ref().expect("relations read");
        assert_eq!(measured.poses.len(), aces.input.len());
        assert_eq!(measured.poses[1].t, Some(2.0));
        assert_eq!(measured.relations.len(), 1);
        assert!(aces.loops_judged() && !aces.judged);

        std::fs::write(more.join("aces.relations"), "10 20 nan 0 0 0 0 0.1\n").unwrap();
        let c = catalog(dir.path());
        let aces = c.sessions.iter().find(|s| s.name == "carmen aces").unwrap();
        assert!(aces.relations.is_none() && !aces.loops_judged());
        let (file, why) = c
            .skipped
            .iter()
            .find(|(f, _)| f.ends_with("aces.relations"))
            .expect("the bad file listed");
        assert!(why.contains(":1:"), "{file}: {why}");
    }

    #[test]
    fn the_first_track_point_is_read_whatever_the_quotes_and_order() {
        let g = first_track_point(
            "<gpx><wpt lat='1' lon='2'/><trk><trkseg><trkpt lon='7.5' lat=\"48.25\"><ele> 310.5 </ele></trkpt><trkpt lat='0' lon='0'/>",
        )
        .unwrap();
        assert_eq!((g.lat_deg, g.lon_deg, g.height), (48.25, 7.5, 310.5));
        let g = first_track_point(
            "<trkpt lat=\"1\" lon=\"2\"/><trkpt lat=\"3\" lon=\"4\"><ele>9</ele></trkpt>",
        )
        .unwrap();
        assert_eq!((g.lat_deg, g.lon_deg, g.height), (1.0, 2.0, 0.0));
        let g =
            first_track_point("<rte><rtept lat='1' lon='2'><ele>3</ele></rtept></rte>").unwrap();
        assert_eq!((g.lat_deg, g.lon_deg, g.height), (1.0, 2.0, 3.0));
        assert!(first_track_point("<wpt lat='1' lon='2'/>").is_none());
    }

    #[test]
    fn pairing_by_time_interpolates_and_leaves_out_what_the_truth_does_not_span() {
        let timed = |ts: &[f64], x: f64| Trajectory {
            source: String::new(),
            poses: ts
                .iter()
                .map(|t| turnprint::Pose {
                    t: Some(*t),
                    position: Vector3::new(x * t, 0.0, 0.0),
                    orientation: None,
                })
                .collect(),
        };
        let truth = timed(&[0.0, 1.0, 2.0, 3.0, 50.0, 51.0], 1.0);
        let est = timed(&[-1.0, 0.5, 2.25, 20.0, 50.5, 60.0], 2.0);
        let pairs = pair_by_time(&est, &truth);
        let got: Vec<f64> = pairs.iter().map(|(_, t)| t.x).collect();
        assert_eq!(got, vec![0.5, 2.25, 50.5]);
    }
}
