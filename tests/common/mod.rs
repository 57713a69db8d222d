//! Helpers shared by the integration tests.

// Each test crate compiles this module and uses only some of it.
#![allow(dead_code)]

use std::io::Write;
use std::process::{Command, Output, Stdio};

use nalgebra::Vector3;
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput};

/// Every candidate the detector emits over `points`, pushed one at a time
/// (`Overflow::Block`: the same output on any machine).
pub fn emitted_candidates(points: &[Vector3<f64>], config: OnlineConfig) -> Vec<CandidateEvent> {
    let mut det = Detector::new(config, Overflow::Block);
    let mut out = Vec::new();
    for p in points {
        det.push(&PoseInput::at(*p));
        out.extend(det.poll());
    }
    out.extend(det.finish().0);
    out
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
