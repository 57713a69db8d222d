//! What every fuzz target checks, shared so that a target is one call.
//!
//! Readers: any bytes end in the crate's `Error` or in a trajectory of
//! finite poses (what `tests/io_bad_input.rs` holds them to), never in a
//! panic; a line format read line by line ([`PoseLines`], `turnprint
//! stream -`) agrees with the whole-file read.
//!
//! The detector: see [`stream`].

use std::path::Path;

use turnprint::io::{detect_format, parse_trajectory, read_trajectory_from, Format, PoseLines};
use turnprint::{Pose, Trajectory};

pub mod stream;

/// Reads `data` as a file named `name` in `format` and checks what the
/// readers promise. A new reader's target is this call with its format.
pub fn read(data: &[u8], format: Format, name: &str) {
    let path = Path::new(name);
    let whole = read_trajectory_from(data, path, format);
    if let Ok(trajectory) = &whole {
        check_trajectory(trajectory);
    }
    // The rest compares text readers with each other (a binary format's
    // bytes need not be UTF-8).
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if format == Format::Auto {
        same_as_detected(text, path, whole.as_ref().ok());
    }
    streamed_like_whole(text, path, format, whole.as_ref().ok());
}

/// A trajectory a reader may return: some poses, every number finite.
pub fn check_trajectory(trajectory: &Trajectory) {
    assert!(!trajectory.poses.is_empty(), "a trajectory without poses");
    for (i, pose) in trajectory.poses.iter().enumerate() {
        check_pose(i, pose);
    }
}

fn check_pose(i: usize, pose: &Pose) {
    assert!(
        pose.position.iter().all(|v| v.is_finite()),
        "pose {i}: position {:?} is not finite",
        pose.position
    );
    assert!(
        pose.t.is_none_or(f64::is_finite),
        "pose {i}: time {:?} is not finite",
        pose.t
    );
    if let Some(q) = pose.orientation {
        assert!(
            q.coords.iter().all(|c| c.is_finite()),
            "pose {i}: orientation {q:?} is not finite"
        );
        assert!(
            (q.coords.norm() - 1.0).abs() < 1e-6,
            "pose {i}: orientation {q:?} is not a unit quaternion"
        );
    }
}

/// `Format::Auto` reads what the format it detects reads.
fn same_as_detected(text: &str, path: &Path, auto: Option<&Trajectory>) {
    let Ok(detected) = detect_format(text, path) else {
        assert!(auto.is_none(), "read although detection failed");
        return;
    };
    assert_ne!(detected, Format::Auto, "detection answered auto");
    let explicit = parse_trajectory(text, detected, path).ok();
    assert_eq!(
        auto.map(|t| &t.poses),
        explicit.as_ref().map(|t| &t.poses),
        "auto and {detected} read differently"
    );
}

/// The poses of `text` pushed line by line, as `turnprint stream -` reads
/// them, are the poses of the whole file.
fn streamed_like_whole(text: &str, path: &Path, format: Format, whole: Option<&Trajectory>) {
    // GPX (and any format that is not lines) cannot be streamed.
    let Ok(mut lines) = PoseLines::new(format, path) else {
        return;
    };
    // A stream refuses GPX at its first data line, as it should.
    if format == Format::Auto && detect_format(text, path).is_ok_and(|f| f == Format::Gpx) {
        return;
    }
    let mut poses = Vec::new();
    for line in text.lines() {
        match lines.push(line) {
            Ok(pose) => poses.extend(pose),
            Err(_) => {
                assert!(whole.is_none(), "a line refused streamed was read whole");
                return;
            }
        }
    }
    match whole {
        Some(t) => assert_eq!(t.poses, poses, "streamed and whole reads differ"),
        // The whole read refuses a file without poses, where a stream has
        // none yet; any other refusal must have been a streamed one too.
        None => assert!(
            poses.is_empty(),
            "the whole file was refused but every line streamed ({} poses)",
            poses.len()
        ),
    }
}
