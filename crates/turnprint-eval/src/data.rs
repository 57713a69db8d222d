//! The real paths of the evaluation and their ground truth: KITTI ground
//! truth, the monocular ORB-SLAM2 estimates paired to ground-truth frames by
//! timestamp, and the real 1 Hz GPS of KITTI 00 aligned to the ground truth
//! in time (scanned offset) and space (Umeyama similarity).

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::Serialize;

use super::revisits::arc_lengths;
use turnprint::geometry::Similarity3;
use turnprint::{Error, Result};

/// The KITTI sequences with loops that the evaluation uses.
pub const SEQUENCES: [&str; 5] = ["00", "02", "05", "06", "08"];

/// A path from one source with, for each pose, its ground-truth frame
/// (fractional for GPS, whose times fall between camera frames).
#[derive(Debug, Clone, Default)]
pub struct Sourced {
    /// Positions in the source's own frame and scale.
    pub positions: Vec<Vector3<f64>>,
    /// Ground-truth frame index of each pose.
    pub frames: Vec<f64>,
}

/// Where the GPS of KITTI 00 sits relative to the ground truth.
#[derive(Debug, Clone, Serialize)]
pub struct GpsAlignment {
    /// `t_kitti = t_gps - offset_s`.
    pub offset_s: f64,
    /// Scale of the GPS-to-ground-truth similarity.
    pub scale: f64,
    /// RMS distance (m) of aligned GPS to ground truth at GPS times.
    pub rmse_m: f64,
    /// GPS rows inside the ground truth's time span.
    pub rows_used: usize,
    /// GPS rows in the file.
    pub rows: usize,
}

/// One KITTI sequence with its sources.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// Sequence name, e.g. `"00"`.
    pub name: String,
    /// Ground-truth camera positions (m), one per frame.
    pub gt: Vec<Vector3<f64>>,
    /// Frame times (s).
    pub times: Vec<f64>,
    /// Cumulative ground-truth arc length (m) per frame.
    pub arc: Vec<f64>,
    /// Monocular ORB-SLAM2 estimate, paired to frames by timestamp.
    pub mono: Sourced,
    /// Real GPS (00 only), paired to frames by the aligned time.
    pub gps: Option<(Sourced, GpsAlignment)>,
    /// Stereo VO without loop closure (S-PTAM, 00 only), one pose per frame.
    pub stereo: Sourced,
}

impl Sequence {
    /// Ground-truth position at a fractional frame (linear interpolation).
    pub fn true_position(&self, frame: f64) -> Vector3<f64> {
        interpolate(&self.gt, frame)
    }

    /// Ground-truth arc length at a fractional frame.
    pub fn arc_at(&self, frame: f64) -> f64 {
        let f = frame.clamp(0.0, (self.arc.len() - 1) as f64);
        let k = (f.floor() as usize).min(self.arc.len().saturating_sub(2));
        self.arc[k] + (f - k as f64) * (self.arc[k + 1] - self.arc[k])
    }

    /// First frame whose arc length reaches `s` (the last frame past the end).
    pub fn frame_at_arc(&self, s: f64) -> usize {
        self.arc.partition_point(|a| *a < s).min(self.arc.len() - 1)
    }

    /// Total road length (m).
    pub fn length(&self) -> f64 {
        *self.arc.last().unwrap_or(&0.0)
    }
}

/// Linear interpolation of a sampled path at a fractional index.
pub fn interpolate(points: &[Vector3<f64>], index: f64) -> Vector3<f64> {
    let f = index.clamp(0.0, (points.len() - 1) as f64);
    let k = (f.floor() as usize).min(points.len().saturating_sub(2));
    let w = f - k as f64;
    points[k] * (1.0 - w) + points[(k + 1).min(points.len() - 1)] * w
}

/// Fractional frame index of time `t` in sorted frame times (`None` outside).
pub fn frame_at_time(times: &[f64], t: f64) -> Option<f64> {
    if times.len() < 2 || t < times[0] || t > *times.last()? {
        return None;
    }
    let k = times.partition_point(|x| *x <= t).clamp(1, times.len() - 1);
    let (t0, t1) = (times[k - 1], times[k]);
    Some((k - 1) as f64 + if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 })
}

/// The folders searched for real data, in order: `$TURNPRINT_DATA` alone
/// when it is set; else the project's shared data `../shared/data` beside
/// the repository, then the cache `target/data` that `scripts/setup.sh`
/// fills from the package registries (evo's source distribution, the
/// gtsam wheel). All use the shared data's layout (`kitti_gt/00.txt`).
pub fn data_dirs() -> Vec<PathBuf> {
    if let Some(dir) = std::env::var_os("TURNPRINT_DATA") {
        return vec![PathBuf::from(dir)];
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    vec![root.join("../shared/data"), root.join("target/data")]
}

/// `rel` (e.g. `kitti_gt/00.txt`) in the first of [`data_dirs`] that has it.
pub fn find(rel: &str) -> Option<PathBuf> {
    data_dirs()
        .into_iter()
        .map(|d| d.join(rel))
        .find(|p| p.is_file())
}

/// For tests, benches and examples: [`find`], or `None` after a line saying
/// what is skipped. Under `CI=true`, where set-up provides the data, a
/// missing file is a failure rather than a silent skip.
pub fn require(rel: &str) -> Option<PathBuf> {
    if let Some(p) = find(rel) {
        return Some(p);
    }
    let dirs: Vec<String> = data_dirs()
        .iter()
        .map(|d| d.display().to_string())
        .collect();
    let message = format!(
        "{rel} is in none of {} (set TURNPRINT_DATA, or run scripts/setup.sh)",
        dirs.join(", ")
    );
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    assert!(!ci, "CI=true: {message}");
    eprintln!("skipped: {message}");
    None
}

/// Where a data file is: `dir/sub/file` (the shared data's layout).
pub fn locate(dir: &Path, sub: &str, file: &str) -> Option<PathBuf> {
    Some(dir.join(sub).join(file)).filter(|p| p.is_file())
}

/// Resolves the data directory: `dir` if it holds KITTI 00's ground truth,
/// else the first of [`data_dirs`] that does.
pub fn resolve_data_dir(dir: &Path) -> Result<PathBuf> {
    let mut tried = vec![dir.to_path_buf()];
    tried.extend(data_dirs());
    for d in &tried {
        if locate(d, "kitti_gt", "00.txt").is_some() {
            return Ok(d.clone());
        }
    }
    Err(Error::input(
        dir.display().to_string(),
        "no kitti_gt/00.txt here nor in the shared data or the set-up cache (pass --data DIR, set TURNPRINT_DATA, or run scripts/setup.sh)",
    ))
}

/// Loads one sequence: ground truth (required), and where their files are
/// present, frame times with the mono estimate paired by time, and for 00
/// the GPS. A source whose files are missing stays empty / `None`.
pub fn load_sequence(dir: &Path, name: &str) -> Result<Sequence> {
    let gt_path = locate(dir, "kitti_gt", &format!("{name}.txt")).ok_or_else(|| {
        Error::input(dir.display().to_string(), format!("no kitti_gt/{name}.txt"))
    })?;
    let gt = reader::kitti_positions(&gt_path)?;
    let times = match locate(dir, "kitti_gt", &format!("{name}_times.txt")) {
        Some(times_path) => {
            let times = reader::times(&times_path)?;
            if times.len() != gt.len() {
                return Err(Error::input(
                    times_path.display().to_string(),
                    format!("{} times for {} poses", times.len(), gt.len()),
                ));
            }
            times
        }
        None => Vec::new(),
    };
    let mono_path = locate(
        dir,
        "kitti_orbslam2_vio",
        &format!("{name}_orbslam2_tum.txt"),
    );
    let mut mono = Sourced::default();
    if let (Some(mono_path), false) = (mono_path, times.is_empty()) {
        for (t, p) in reader::timed(&mono_path, turnprint::io::Format::Tum)? {
            // Mono times are the frame times rounded to microseconds.
            let k = times.partition_point(|x| *x < t);
            let best = [k.saturating_sub(1), k.min(times.len() - 1)]
                .into_iter()
                .min_by(|a, b| (times[*a] - t).abs().total_cmp(&(times[*b] - t).abs()))
                .filter(|j| (times[*j] - t).abs() < 0.02);
            if let Some(j) = best {
                mono.positions.push(p);
                mono.frames.push(j as f64);
            }
        }
    }
    let arc = arc_lengths(&gt);
    let mut seq = Sequence {
        name: name.to_string(),
        gt,
        times,
        arc,
        mono,
        gps: None,
        stereo: Sourced::default(),
    };
    let stereo_path = locate(dir, "evo", &format!("KITTI_{name}_SPTAM.txt"));
    if let Some(stereo_path) = stereo_path {
        let positions = reader::kitti_positions(&stereo_path)?;
        if positions.len() != seq.gt.len() {
            return Err(Error::input(
                stereo_path.display().to_string(),
                format!("{} poses for {} frames", positions.len(), seq.gt.len()),
            ));
        }
        seq.stereo.frames = (0..positions.len()).map(|f| f as f64).collect();
        seq.stereo.positions = positions;
    }
    let gps_path = locate(dir, "gtsam_data", "KittiGps_converted.txt");
    if let (Some(gps_path), "00", false) = (gps_path, name, seq.times.is_empty()) {
        let rows = reader::timed(&gps_path, turnprint::io::Format::Csv)?;
        seq.gps = Some(align_gps(&seq, &rows).ok_or_else(|| {
            Error::input(
                gps_path.display().to_string(),
                "GPS does not align with KITTI 00",
            )
        })?);
    }
    Ok(seq)
}

/// Finds the GPS time offset by scanning: for each candidate offset, the
/// GPS rows inside the ground truth's time span are paired with the ground
/// truth interpolated at their times, a similarity is fitted (Umeyama) and
/// the offset with the smallest RMS residual wins (coarse 0.1 s steps over
/// +-60 s around "first GPS row = first frame", then 0.005 s steps).
pub fn align_gps(seq: &Sequence, rows: &[(f64, Vector3<f64>)]) -> Option<(Sourced, GpsAlignment)> {
    let fit = |offset: f64| -> Option<(f64, f64, usize)> {
        let (mut src, mut dst) = (Vec::new(), Vec::new());
        for (t, p) in rows {
            if let Some(f) = frame_at_time(&seq.times, t - offset) {
                src.push(*p);
                dst.push(seq.true_position(f));
            }
        }
        if src.len() * 10 < rows.len() * 8 {
            return None;
        }
        let sim = Similarity3::fit(&src, &dst)?;
        let sq: f64 = src
            .iter()
            .zip(&dst)
            .map(|(s, d)| (sim.apply(s) - d).norm_squared())
            .sum();
        Some(((sq / src.len() as f64).sqrt(), sim.scale, src.len()))
    };
    let base = rows.first()?.0 - seq.times[0];
    let scan = |center: f64, half: f64, step: f64| {
        let n = (half / step).round() as i64;
        (-n..=n)
            .filter_map(|k| {
                let o = center + k as f64 * step;
                fit(o).map(|r| (o, r))
            })
            .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
    };
    let (coarse, _) = scan(base, 60.0, 0.1)?;
    let (offset, (rmse_m, scale, rows_used)) = scan(coarse, 0.2, 0.005)?;
    let mut gps = Sourced::default();
    for (t, p) in rows {
        if let Some(f) = frame_at_time(&seq.times, t - offset) {
            gps.positions.push(*p);
            gps.frames.push(f);
        }
    }
    let alignment = GpsAlignment {
        offset_s: offset,
        scale,
        rmse_m,
        rows_used,
        rows: rows.len(),
    };
    Some((gps, alignment))
}

/// File reading: trajectories through `turnprint::io`, frame times (one number
/// per line, no trajectory format) here.
mod reader {
    use super::*;
    use turnprint::io::{read_trajectory, Format};

    /// Positions of a KITTI pose file.
    pub fn kitti_positions(path: &Path) -> Result<Vec<Vector3<f64>>> {
        Ok(read_trajectory(path, Format::Kitti)?.positions())
    }

    /// `(t, position)` of a timed trajectory (TUM, or CSV with a time column).
    pub fn timed(path: &Path, format: Format) -> Result<Vec<(f64, Vector3<f64>)>> {
        let traj = read_trajectory(path, format)?;
        traj.poses
            .iter()
            .enumerate()
            .map(|(i, p)| match p.t {
                Some(t) => Ok((t, p.position)),
                None => Err(Error::input(
                    path.display().to_string(),
                    format!("pose {i} has no timestamp"),
                )),
            })
            .collect()
    }

    /// One time (s) per line; blank lines and `#` comments skipped.
    pub fn times(path: &Path) -> Result<Vec<f64>> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        text.lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
            .map(|(line, l)| match l.parse::<f64>() {
                Ok(t) if t.is_finite() => Ok(t),
                _ => Err(Error::Parse {
                    path: path.to_path_buf(),
                    line,
                    message: format!("expected one time in seconds, found {l:?}"),
                }),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_at_time_interpolates_and_bounds() {
        let times = [0.0, 0.1, 0.2, 0.4];
        assert_eq!(frame_at_time(&times, 0.0), Some(0.0));
        assert!((frame_at_time(&times, 0.3).unwrap() - 2.5).abs() < 1e-12);
        assert_eq!(frame_at_time(&times, 0.4), Some(3.0));
        assert_eq!(frame_at_time(&times, 0.41), None);
        assert_eq!(frame_at_time(&times, -0.1), None);
    }

    #[test]
    fn gps_offset_and_similarity_are_recovered() {
        // A winding 200 s drive at 10 Hz; GPS at 1 Hz on another clock
        // (t_gps = t + 1003.37) and in another frame, starting 6.6 s late.
        let times: Vec<f64> = (0..2000).map(|k| k as f64 * 0.1).collect();
        let at = |t: f64| Vector3::new(300.0 * (t / 30.0).sin(), 0.0, 300.0 * (t / 17.0).sin());
        let gt: Vec<_> = times.iter().map(|t| at(*t)).collect();
        let seq = Sequence {
            name: "synthetic".into(),
            arc: arc_lengths(&gt),
            gt,
            times,
            mono: Sourced::default(),
            gps: None,
            stereo: Default::default(),
        };
        let frame = turnprint::geometry::Similarity3 {
            scale: 1.0,
            rotation: *nalgebra::Rotation3::from_euler_angles(1.2, -0.3, 0.5).matrix(),
            translation: Vector3::new(10.0, -20.0, 5.0),
        };
        let rows: Vec<_> = (0..200)
            .map(|j| {
                let t_gps = 1010.0 + j as f64;
                (t_gps, frame.apply(&at(t_gps - 1003.37)))
            })
            .collect();
        let (gps, fit) = align_gps(&seq, &rows).unwrap();
        assert!((fit.offset_s - 1003.37).abs() < 0.006, "{fit:?}");
        assert!(
            (fit.scale - 1.0).abs() < 1e-3 && fit.rmse_m < 0.1,
            "{fit:?}"
        );
        // Rows after the drive's end (t > 199.9 s) are dropped.
        assert_eq!(gps.positions.len(), fit.rows_used);
        assert_eq!(fit.rows_used, 194);
        assert!((gps.frames[0] - 66.3).abs() < 0.1, "{}", gps.frames[0]);
    }

    #[test]
    fn interpolate_between_samples() {
        let p = [Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0)];
        assert_eq!(interpolate(&p, 0.25), Vector3::new(0.5, 0.0, 0.0));
        assert_eq!(interpolate(&p, 5.0), p[1]);
    }
}
