//! `turnprint stream A --json`: replays a trajectory through the detector
//! and writes JSON Lines (`cli.md`). The replay uses [`Overflow::Block`]
//! so the output does not depend on machine speed.
//!
//! `turnprint stream -` reads the poses from stdin as a running odometry
//! process writes them, and writes each event as soon as the detector has
//! it, also while the input waits: the same events, in the same order, as
//! the replay of the same lines from a file.

use std::io::{BufRead, Write};
use std::path::Path;
use std::time::Duration;

use crossbeam::channel::{bounded, RecvTimeoutError};
use serde_json::json;

use turnprint::io::{read_trajectory, Format, PoseLines};
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput, Summary};
use turnprint::pipeline::prepare::MIN_POSES;
use turnprint::{Error, Pose, Result, Trajectory};

/// How often events are collected while stdin has no new line.
const IDLE_POLL: Duration = Duration::from_millis(20);

/// Streams the trajectory at `path` and writes one JSON object per line
/// to `out`: candidates as they come, then the summary. With `correct`,
/// the candidates at the shape cut also enter the drift correction (with
/// the verifier, `sidecar`, the confirmed ones), each re-optimisation
/// is a `corrected` event, and the corrected path is written there as TUM
/// at the end.
pub fn stream(
    path: &Path,
    format: Format,
    config: &OnlineConfig,
    correct: Option<&Path>,
    out: &mut dyn Write,
) -> Result<Summary> {
    let trajectory = read_trajectory(path, format)?;
    stream_trajectory(
        &trajectory,
        &path.display().to_string(),
        config,
        correct,
        out,
    )
}

/// [`stream`] of a trajectory already read (named `name` in messages).
pub fn stream_trajectory(
    trajectory: &Trajectory,
    name: &str,
    config: &OnlineConfig,
    correct: Option<&Path>,
    out: &mut dyn Write,
) -> Result<Summary> {
    if trajectory.len() < MIN_POSES {
        return Err(too_few(name, trajectory.len()));
    }
    let mut detector = detector(config, correct)?;
    for pose in &trajectory.poses {
        push(&mut detector, pose);
        write_events(&mut detector, out)?;
    }
    finish(detector, name, correct, out)
}

/// Streams the poses of `input`'s lines (named `name` in messages) as they
/// arrive, in `format` (`auto`: detected from the first data line), and
/// writes each event as soon as the detector has it; at the end of the
/// input, the rest and the summary (`correct` as for [`stream`]).
pub fn stream_lines(
    input: impl BufRead + Send + 'static,
    name: &str,
    format: Format,
    config: &OnlineConfig,
    correct: Option<&Path>,
    out: &mut dyn Write,
) -> Result<Summary> {
    // A running odometry that loses track may write `nan`: the detector's
    // guard drops and counts such a pose (the summary's
    // `guards.non_finite`) instead of the stream ending.
    let mut lines = PoseLines::new(format, Path::new(name))?.with_lost_poses();
    // A reader thread, so that events still go out while a line is awaited.
    let (tx, rx) = bounded::<std::io::Result<String>>(1024);
    std::thread::spawn(move || {
        for line in input.lines() {
            let stop = line.is_err();
            if tx.send(line).is_err() || stop {
                break;
            }
        }
    });
    let mut detector = detector(config, correct)?;
    let mut poses = 0;
    loop {
        match rx.recv_timeout(IDLE_POLL) {
            Ok(Ok(line)) => {
                if let Some(pose) = lines.push(&line)? {
                    push(&mut detector, &pose);
                    poses += 1;
                }
            }
            Ok(Err(source)) => {
                return Err(Error::Io {
                    path: name.into(),
                    source,
                })
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        write_events(&mut detector, out)?;
    }
    if poses < MIN_POSES {
        return Err(too_few(name, poses));
    }
    finish(detector, name, correct, out)
}

/// The replay's detector, correcting drift when asked to.
fn detector(config: &OnlineConfig, correct: Option<&Path>) -> Result<Detector> {
    let detector = Detector::new(config.clone(), Overflow::Block);
    match correct {
        None => Ok(detector),
        Some(_) => Ok(detector.with_correction(
            turnprint::correct::CorrectConfig::default(),
            turnprint::online::correction::LoopInput::Candidates,
        )),
    }
}

/// One pose into the detector (no keyframes: nothing is rendered).
fn push(detector: &mut Detector, pose: &Pose) {
    detector.push(&PoseInput::from(pose));
}

/// The error for a stream of `n` poses, too few for the method.
fn too_few(name: &str, n: usize) -> Error {
    Error::input(
        name,
        format!("{n} poses; the method needs at least {MIN_POSES}"),
    )
}

fn stdout_error(source: std::io::Error) -> Error {
    Error::Io {
        path: "<stdout>".into(),
        source,
    }
}

/// Writes the events the detector has ready, one JSON object per line.
fn write_events(detector: &mut Detector, out: &mut dyn Write) -> Result<()> {
    for e in detector.poll() {
        writeln!(out, "{}", e.to_json()).map_err(stdout_error)?;
    }
    for c in detector.poll_corrections() {
        writeln!(out, "{}", c.to_json(false)).map_err(stdout_error)?;
    }
    Ok(())
}

/// Drains the detector, writes the rest, the corrected path and the
/// summary line.
fn finish(
    detector: Detector,
    name: &str,
    correct: Option<&Path>,
    out: &mut dyn Write,
) -> Result<Summary> {
    let t0 = std::time::Instant::now();
    let (rest, summary, corrected) = detector.finish_corrected();
    for e in rest {
        writeln!(out, "{}", e.to_json()).map_err(stdout_error)?;
    }
    if let (Some(file), Some(finished)) = (correct, corrected) {
        finished.write(name, file, t0, out)?;
    }
    let mut s = serde_json::to_value(summary).unwrap_or_default();
    if let Some(o) = s.as_object_mut() {
        o.insert("event".into(), json!("summary"));
        o.insert("path".into(), json!(name));
        o.insert("candidates".into(), json!(summary.worker.candidates));
    }
    writeln!(out, "{s}").map_err(stdout_error)?;
    out.flush().map_err(stdout_error)?;
    if summary.workers_lost > 0 {
        // A bug, not the input: the candidates written are right, but
        // those of the samples after the loss are missing, so the run must
        // not pass for a complete one.
        return Err(Error::input(
            name,
            "the matching worker stopped on an internal error (the panic message is above); the candidates of the poses after it are missing",
        ));
    }
    Ok(summary)
}
