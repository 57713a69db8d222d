//! Embedding the online detector in a visual-odometry loop.
//!
//! `cargo run --release --example vo_loop -- [TRAJECTORY]` replays a pose
//! file (default: KITTI 00 ground truth, `kitti_gt/00.txt` of the shared
//! data: `$TURNPRINT_DATA`, `../shared/data` or the set-up cache) as if each
//! pose came from a VO front end, one keyframe every 5 frames, and prints
//! the candidates as they arrive.

use std::path::PathBuf;

use turnprint::io::{read_trajectory, Format};
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};

fn main() -> turnprint::Result<()> {
    let file = match std::env::args().nth(1) {
        Some(file) => PathBuf::from(file),
        // Says what is missing and where it looked.
        None => match turnprint_eval::data::require("kitti_gt/00.txt") {
            Some(path) => path,
            None => return Ok(()),
        },
    };
    let vo = read_trajectory(&file, Format::Auto)?;

    // --- the embedding: one detector, one push per pose, poll when convenient.
    let mut detector = Detector::new(OnlineConfig::default(), Overflow::MergeLatest);
    for (frame, pose) in vo.poses.iter().enumerate() {
        detector.push(&PoseInput {
            t: pose.t,
            position: pose.position,
            orientation: pose.orientation,
            keyframe: (frame % 5 == 0).then_some(frame as u64 / 5),
        });
        for c in detector.poll() {
            let h = &c.hypothesis;
            println!(
                "frame {frame}: candidate {} score {:.2}: poses {:?} revisit {:?} (keyframes {:?} ~ {:?})",
                c.id, h.score, h.a_range, h.b_range, c.query_keyframes, c.match_keyframes
            );
        }
    }
    let (rest, summary) = detector.finish();
    // --- end of the embedding.

    for c in rest {
        println!("at end: candidate {} score {:.2}", c.id, c.hypothesis.score);
    }
    println!(
        "{} poses, {} segments, {} candidates, {} deferred sends, {} skipped segments",
        summary.poses,
        summary.worker.segments,
        summary.worker.candidates,
        summary.deferred,
        summary.worker.skipped
    );
    Ok(())
}
