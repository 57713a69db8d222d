//! Inputs the fuzz targets in `fuzz/` found to break a promise, minimised
//! and inlined: each test is named after the bug it pins down.
//!
//! `cargo test --no-default-features --test fuzz_regressions`

use std::path::Path;

use nalgebra::Vector3;
use turnprint::io::{parse_trajectory, read_trajectory_from, Format};
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput, Summary};
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

/// Runs `f` on a thread of its own and fails if it takes longer than a
/// minute: a hang is the bug, not a test that never ends.
fn within_a_minute<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(std::time::Duration::from_secs(60))
        .expect("hung (or panicked)")
}

#[test]
fn huge_coordinates_overflow_squared_steps_and_hang_the_track_grid() {
    // 93 poses standing still with a jitter of 1e155 (detector_stream's
    // `Stand { n: 93, jitter: -1e155 }`): steps are finite, their squares
    // are not, so chord lengths were infinite and the grid emitted samples
    // for ever at `finish`.
    let (events, summary) = stand(93, -1e155, OnlineConfig::default().warmup_min_poses);
    assert!(events.is_empty());
    assert_eq!(summary.poses, 93);
    // Refused and counted, not lost: the method squares distances.
    assert_eq!(summary.accepted, 0);
    assert_eq!(summary.guards.non_finite, 93);
}

/// `n` poses standing still with a jitter of `radius` (detector_stream's
/// `Stand`), through a detector warmed up on `warmup` poses.
fn stand(n: usize, radius: f64, warmup: usize) -> (Vec<CandidateEvent>, Summary) {
    stands(vec![(n, radius)], warmup)
}

/// [`stand`] for several stands in turn, each `(n, radius)`.
fn stands(stands: Vec<(usize, f64)>, warmup: usize) -> (Vec<CandidateEvent>, Summary) {
    within_a_minute(move || {
        let config = OnlineConfig {
            warmup_min_poses: warmup,
            drift_probe: false,
            ..OnlineConfig::default()
        };
        let mut detector = Detector::new(config, Overflow::Block);
        for (n, radius) in stands {
            for k in 0..n {
                let phase = k as f64 * 2.399_963;
                detector.push(&PoseInput::at(
                    radius * Vector3::new(phase.cos(), phase.sin(), 0.0),
                ));
            }
        }
        detector.finish()
    })
}

#[test]
fn jump_after_jump_was_taken_as_a_step_and_the_grid_filled_memory() {
    // detector_stream (10 minutes): warmed up jittering by 1e-50, then
    // jittering by a million: every step is a jump. The filter re-anchored
    // at the first and took the second as a step of 1e56 typical steps,
    // and the track grid allocated gigabytes of samples for it.
    let (_, summary) = stands(vec![(220, -1e-50), (127, -1_020_461.283)], 27);
    assert_eq!(summary.workers_lost, 0);
    assert_eq!(summary.poses, 347);
    // Each pose of the second stand is a jump from the one before.
    assert!(summary.guards.jumps >= 120, "{summary:?}");
}

#[test]
fn coordinates_beyond_f32_overflowed_the_history_and_its_cell_keys() {
    // The worker's history keeps positions as f32: at 1e98 they were
    // infinite there, the spatial index's cell keys saturated and the
    // proximity probe's cell range overflowed (a panic on the worker's
    // thread, the worker lost).
    let (_, summary) = stand(250, 1e98, 67);
    assert_eq!(summary.workers_lost, 0);
    assert_eq!((summary.accepted, summary.guards.non_finite), (0, 250));
    // Within the bound the same stream is matched like any other.
    let (_, summary) = stand(250, 1e29, 67);
    assert_eq!(summary.workers_lost, 0);
    assert_eq!(summary.accepted, 250);
    assert!(summary.worker.messages > 0, "{summary:?}");
}

/// `read_auto` (10 minutes of fuzzing): an uncompressed MCAP chunk whose
/// record claims more bytes than the chunk holds underflowed the mcap
/// crate's count of the chunk's remaining bytes (a panic where overflow is
/// checked). It is refused before the crate reads it.
#[cfg(feature = "mcap")]
#[test]
fn an_mcap_chunk_record_longer_than_its_chunk_underflows_the_reader() {
    let bag = b"\x89\x4d\x43\x41\x50\x30\x0d\x0a\x2e\x0a\x00\x00\x00\x00\x00\x00\x00\x30\x22\x20\x65\x20\x00\x06\
        \x06\x06\x06\x06\x06\x06\x06\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\
        \x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x04\x00\x00\x00\x00\x00\x00\x00\x00\x00\x03\x00\x00\x00\
        \x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x06\x00\x00\
        \x00\x00\x00\x00\x64\x2f";
    let err = read(bag, Format::Auto, "f.mcap").unwrap_err().to_string();
    assert!(err.contains("chunk"), "{err}");
}
