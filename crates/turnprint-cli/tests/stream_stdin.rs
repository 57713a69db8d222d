//! `turnprint stream -`: poses piped in as a running odometry process writes
//! them. The events are those of the file's replay, and each goes out as
//! soon as the detector has it, while the input still waits.

mod common;

use common::data;

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Output, Stdio};
use std::sync::mpsc;
use std::time::Duration;

/// The lines of `turnprint stream` that are not the summary (whose
/// timings and path differ between runs).
fn events(stdout: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(stdout)
        .lines()
        .filter(|l| !l.contains("\"event\":\"summary\""))
        .map(str::to_string)
        .collect()
}

fn turnprint() -> Command {
    Command::new(env!("CARGO_BIN_EXE_turnprint"))
}

/// `turnprint stream - EXTRA` with all of `input` piped in, to its end.
fn stream_piped(input: Vec<u8>, extra: &[&str]) -> Output {
    let mut command = turnprint();
    command.args(["stream", "-"]).args(extra);
    common::output_with_stdin(command, input)
}

#[test]
fn piped_poses_give_the_events_of_the_file() {
    let Some(mono00) = data("kitti_orbslam2_vio/00_orbslam2_tum.txt") else {
        return;
    };
    let file = turnprint().args(["stream", &mono00]).output().unwrap();
    assert!(file.status.success());
    let text = std::fs::read(&mono00).unwrap();
    let piped = stream_piped(text, &[]);
    assert!(piped.status.success());
    let (from_file, from_pipe) = (events(&file.stdout), events(&piped.stdout));
    assert!(from_file.len() > 10, "{} events", from_file.len());
    assert_eq!(from_file, from_pipe);
    let summary = String::from_utf8_lossy(&piped.stdout);
    let summary = summary.lines().last().unwrap();
    assert!(summary.contains("\"path\":\"<stdin>\""), "{summary}");
    assert!(summary.contains("\"poses\":4541"), "{summary}");
}

#[test]
fn a_candidate_goes_out_while_the_input_still_waits() {
    let Some(path) = data("kitti_gt/00.txt") else {
        return;
    };
    let lines: Vec<String> = std::fs::read_to_string(&path)
        .unwrap()
        .lines()
        .map(|l| format!("{l}\n"))
        .collect();
    // The replay's first candidate, and the pose that produced it.
    let file = turnprint().args(["stream", &path]).output().unwrap();
    let first = events(&file.stdout).into_iter().next().unwrap();
    let v: serde_json::Value = serde_json::from_str(&first).unwrap();
    let at = v["at_pose"].as_u64().unwrap() as usize;
    assert!(at + 1 < lines.len());

    let mut child = turnprint()
        .args(["stream", "-", "--format", "kitti"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            if tx.send(line.unwrap()).is_err() {
                break;
            }
        }
    });
    // Up to that pose, then nothing (the odometry is busy): only the wait
    // for the next line is left to deliver it.
    for l in &lines[..=at] {
        stdin.write_all(l.as_bytes()).unwrap();
    }
    stdin.flush().unwrap();
    let early = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("a candidate while the input waits");
    assert_eq!(early, first);
    // The rest, then the end of the input: the remaining events and the
    // summary, and the same events as the replay.
    for l in &lines[at + 1..] {
        stdin.write_all(l.as_bytes()).unwrap();
    }
    drop(stdin);
    assert!(child.wait().unwrap().success());
    reader.join().unwrap();
    let mut all = vec![early];
    all.extend(rx.try_iter());
    let summary = all.pop().unwrap();
    assert!(summary.contains("\"event\":\"summary\""), "{summary}");
    assert_eq!(all, events(&file.stdout));
}

#[test]
fn piped_bad_input_names_stdin_and_its_line() {
    let run = |input: &str, extra: &[&str]| {
        let out = stream_piped(input.as_bytes().to_vec(), extra);
        assert!(!out.status.success(), "{input:?} was accepted");
        String::from_utf8_lossy(&out.stderr).trim().to_string()
    };
    let e = run("0 1 2 3 0 0 0 1\n0 1 2 x 0 0 0 1\n", &[]);
    assert_eq!(e, "turnprint: <stdin>:2: not a number: 'x' in column 4");
    let e = run("", &[]);
    assert!(e.contains("<stdin>") && e.contains("0 poses"), "{e}");
    let e = run("1 2\n3 4\n", &[]);
    assert!(e.contains("2 poses"), "{e}");
    let e = run("<gpx>\n", &[]);
    assert!(e.contains("GPX"), "{e}");
    let e = run("", &["--format", "gpx"]);
    assert!(e.contains("GPX"), "{e}");
}

#[test]
fn a_lost_pose_is_dropped_and_counted_and_the_stream_goes_on() {
    // The monocular estimate with the odometry losing track three times.
    let Some(mono00) = data("kitti_orbslam2_vio/00_orbslam2_tum.txt") else {
        return;
    };
    let text = std::fs::read_to_string(mono00).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for at in [1000, 2000, 3000] {
        let t = lines[at].split_whitespace().next().unwrap().to_string();
        lines.insert(at, format!("{t} nan nan nan nan nan nan nan"));
    }
    let out = stream_piped((lines.join("\n") + "\n").into_bytes(), &[]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let summary: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(summary["guards"]["non_finite"], 3, "{summary}");
    assert_eq!(summary["accepted"], 4541, "{summary}");
    assert!(events(&out.stdout).len() > 10);
}
