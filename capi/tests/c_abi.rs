//! The C ABI from real C and C++ programs: `examples/vo_loop.cpp` and
//! `tests/lost_track.c` are compiled against `include/turnprint.h` and the
//! static library cargo built for these tests, then run.

use std::path::{Path, PathBuf};
use std::process::Command;

use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput, Source};

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The crate's static library, which cargo builds beside this test
/// binary in `target/<profile>/deps` (and copies one level up).
fn library() -> PathBuf {
    let exe = std::env::current_exe().expect("test binary path");
    let deps = exe.parent().expect("target/<profile>/deps");
    [deps.to_path_buf(), deps.join("..")]
        .iter()
        .map(|dir| dir.join("libturnprint_c.a"))
        .find(|lib| lib.exists())
        .unwrap_or_else(|| panic!("no libturnprint_c.a in {}", deps.display()))
}

/// Compiles `source` with `compiler` (and `flags`) against the header and
/// the static library; returns the program's path.
fn compile(compiler: &str, flags: &[&str], source: &str, name: &str) -> PathBuf {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let status = Command::new(compiler)
        .args(flags)
        .arg("-I")
        .arg(manifest().join("include"))
        .arg(manifest().join(source))
        .arg(library())
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&out)
        .status()
        .unwrap_or_else(|e| panic!("cannot run {compiler}: {e} (scripts/setup.sh installs it)"));
    assert!(status.success(), "{compiler} failed on {source}");
    out
}

fn run(program: &Path, args: &[&str]) -> String {
    let out = Command::new(program).args(args).output().expect("run");
    assert!(
        out.status.success(),
        "{} failed: {}{}",
        program.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8")
}

const KITTI_00_MONO: &str = "../tests/data/00_orbslam2_tum.txt";

#[test]
fn misuse_and_lost_poses_from_c_get_codes_and_messages_not_crashes() {
    let program = compile(
        "cc",
        &["-std=c99", "-Wall", "-Werror"],
        "tests/lost_track.c",
        "lost_track",
    );
    let out = run(&program, &[]);
    assert!(out.starts_with("ok "), "{out}");
}

/// The candidate lines the examples print, made by the library itself
/// from the same poses and keyframes (every fifth pose a keyframe; push
/// waits for matching).
fn rust_candidates(path: &Path) -> Vec<String> {
    let poses = turnprint::io::read_trajectory(path, turnprint::io::Format::Tum).unwrap();
    let mut detector = Detector::new(OnlineConfig::default(), Overflow::Block);
    let mut events = Vec::new();
    for (i, p) in poses.poses.iter().enumerate() {
        detector.push(&PoseInput {
            t: p.t,
            position: p.position,
            orientation: None,
            keyframe: (i % 5 == 0).then_some(i as u64),
        });
        events.extend(detector.poll());
    }
    events.extend(detector.finish().0);
    events
        .iter()
        .map(|e| {
            let h = &e.hypothesis;
            let (kq, km) = e
                .keyframes
                .map_or((-1, -1), |k| (k.query_keyframe as i64, k.match_keyframe as i64));
            format!(
                "candidate id={} at_pose={} query={}-{} match={}-{} score={:.4} source={} reversed={} keyframes={kq}-{km}",
                e.id,
                e.at_pose,
                h.a_range[0],
                h.a_range[1],
                h.b_range[0],
                h.b_range[1],
                h.score,
                match e.source {
                    Source::Shape => 0,
                    Source::Proximity => 1,
                    Source::DriftProbe => 2,
                },
                h.reversed as i32,
            )
        })
        .collect()
}

fn candidate_lines(out: &str) -> Vec<&str> {
    out.lines().filter(|l| l.starts_with("candidate")).collect()
}

#[test]
fn the_cpp_vo_loop_gets_the_candidates_of_the_rust_detector() {
    let program = compile(
        "c++",
        &["-O2", "-Wall", "-Werror"],
        "examples/vo_loop.cpp",
        "vo_loop",
    );
    let path = manifest().join(KITTI_00_MONO);
    let out = run(&program, &[path.to_str().unwrap(), "--wait"]);
    let expected = rust_candidates(&path);
    assert!(expected.len() > 40, "{} candidates", expected.len());
    assert_eq!(candidate_lines(&out), expected);
}

#[test]
fn the_python_vo_loop_gets_the_candidates_of_the_rust_detector() {
    // ctypes on the shared library: the structures' layout as Python
    // declares them must match the header's, or every field shifts.
    let shared = library().with_extension("so");
    let path = manifest().join(KITTI_00_MONO);
    let out = Command::new("python3")
        .arg(manifest().join("examples/vo_loop.py"))
        .arg(&path)
        .arg("--wait")
        .arg("--lib")
        .arg(&shared)
        .output()
        .expect("python3 (scripts/setup.sh installs it)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = String::from_utf8(out.stdout).unwrap();
    assert_eq!(candidate_lines(&out), rust_candidates(&path));
    assert!(out
        .lines()
        .last()
        .unwrap_or_default()
        .starts_with("summary poses=4541 "));
}

#[test]
fn a_live_cpp_loop_that_never_waits_loses_no_candidate() {
    let program = compile("c++", &["-O2"], "examples/vo_loop.cpp", "vo_loop_live");
    let path = manifest().join(KITTI_00_MONO);
    let out = run(&program, &[path.to_str().unwrap()]);
    let printed = out.lines().filter(|l| l.starts_with("candidate")).count();
    let summary = out.lines().last().unwrap_or_default();
    assert!(summary.starts_with("summary poses=4541 "), "{summary}");
    assert!(
        summary.contains(&format!(" candidates={printed} ")),
        "{printed} printed, {summary}"
    );
    assert!(printed > 0);
}
