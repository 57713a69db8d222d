//! The C ABI from real C and C++ programs: `examples/vo_loop.cpp`,
//! `tests/lost_track.c`, `tests/verify_keyframes.c` and
//! `tests/merge_paths.c` are compiled against `include/turnprint.h` and the
//! static library cargo built for these tests, then each runs. (Python has
//! a package of its own, `crates/turnprint-python`, tested by
//! `scripts/test_python.sh`.)
//! Run them as a C caller builds the library, `cargo test --release -p
//! turnprint-capi` (`scripts/test.sh` does), after the sidecar is built.

use std::path::{Path, PathBuf};
use std::process::Command;

use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput, Source};

fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The absolute path of `rel` in the shared data (e.g. `kitti_gt/00.txt`),
/// or `None` after a line saying the test is skipped (a failure under
/// `CI=true`: [`turnprint_eval::data::require`]).
fn data(rel: &str) -> Option<PathBuf> {
    let path = turnprint_eval::data::require(rel)?;
    Some(std::path::absolute(&path).unwrap_or(path))
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
    assert!(
        status.success(),
        "{compiler} failed on {source} (under the workspace's --all-features, turnprint \
         carries OpenCV into the library: run `cargo test --release -p turnprint-capi`)"
    );
    out
}

/// A C test program, as C99 with every warning an error.
fn compile_c(source: &str, name: &str) -> PathBuf {
    compile("cc", &["-std=c99", "-Wall", "-Werror"], source, name)
}

/// A C++ program, optimised, with every warning an error.
fn compile_cpp(source: &str, name: &str) -> PathBuf {
    compile("c++", &["-O2", "-Wall", "-Werror"], source, name)
}

fn run(program: &Path, args: &[&str]) -> String {
    let out = Command::new(program)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", program.display()));
    assert!(
        out.status.success(),
        "{} failed: {}{}",
        program.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8")
}

/// KITTI 00 as monocular ORB-SLAM2 saw it (TUM format, its own scale).
const KITTI_00_MONO: &str = "kitti_orbslam2_vio/00_orbslam2_tum.txt";

#[test]
fn misuse_and_lost_poses_from_c_get_codes_and_messages_not_crashes() {
    let program = compile_c("tests/lost_track.c", "lost_track");
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
                    Source::Network => 3,
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
    let program = compile_cpp("examples/vo_loop.cpp", "vo_loop");
    let Some(path) = data(KITTI_00_MONO) else {
        return;
    };
    let out = run(&program, &[path.to_str().unwrap(), "--wait"]);
    let expected = rust_candidates(&path);
    assert!(expected.len() > 40, "{} candidates", expected.len());
    assert_eq!(candidate_lines(&out), expected);
}

#[test]
fn a_live_cpp_loop_that_never_waits_loses_no_candidate() {
    let program = compile_cpp("examples/vo_loop.cpp", "vo_loop_live");
    let Some(path) = data(KITTI_00_MONO) else {
        return;
    };
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

/// A process killed when dropped, so a failing test leaves no verifier.
struct Killed(std::process::Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A real KITTI 06 frame (`images/kitti06_pyslam` of the shared data) as
/// raw 8-bit grey rows; returns the file and the image's width and height,
/// or `None` when the data is absent.
fn raw_kitti06(frame: u32) -> Option<(PathBuf, u32, u32)> {
    let png = data(&format!("images/kitti06_pyslam/kitti06-{frame}.png"))?;
    let decoder = png::Decoder::new(std::fs::File::open(&png).expect("KITTI frame"));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut pixels = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut pixels).expect("PNG pixels");
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Grayscale, png::BitDepth::Eight)
    );
    pixels.truncate(info.buffer_size());
    let raw = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("kitti06-{frame}.gray"));
    std::fs::write(&raw, &pixels).unwrap();
    Some((raw, info.width, info.height))
}

#[test]
fn the_verifier_from_c_confirms_rejects_and_outlives_its_own_death() {
    use std::io::{BufRead, BufReader, Write};
    use std::process::Stdio;

    // The sidecar cargo builds with the workspace (`--features verifier`).
    let deps = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf();
    let binary = deps.join("../turnprint-verifier");
    assert!(
        binary.exists(),
        "no {}: build it with `cargo build --release --features verifier`",
        binary.display()
    );
    let program = compile_c("tests/verify_keyframes.c", "verify_keyframes");
    let prefix = format!("capi-{}", std::process::id());
    let stderr = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verifier-stderr.txt");
    let mut verifier = Killed(
        Command::new(&binary)
            .args(["--prefix", &prefix, "--heartbeat-ms", "20"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&stderr).unwrap())
            .spawn()
            .expect("start turnprint-verifier"),
    );
    let (Some((f12, width, height)), Some((f13, ..))) = (raw_kitti06(12), raw_kitti06(13)) else {
        return;
    };
    let mut c = Killed(
        Command::new(&program)
            .arg(&prefix)
            .arg(width.to_string())
            .arg(height.to_string())
            .arg(&f12)
            .arg(&f13)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut lines = BufReader::new(c.0.stdout.take().unwrap()).lines();
    let first = lines.next().and_then(|l| l.ok()).unwrap_or_default();
    assert_eq!(
        first,
        "kill",
        "verifier stderr: {}",
        std::fs::read_to_string(&stderr).unwrap_or_default()
    );
    // kill -9: no goodbye, the client notices the missing heartbeats.
    verifier.0.kill().unwrap();
    verifier.0.wait().unwrap();
    writeln!(c.0.stdin.take().unwrap(), "go").unwrap();
    let last = lines.next().and_then(|l| l.ok()).unwrap_or_default();
    assert!(c.0.wait().unwrap().success(), "{last}");
    assert!(last.starts_with("ok confirmed with "), "{last}");
    assert!(last.contains("expired (verifier"), "{last}");
}

#[test]
fn a_candidate_with_no_verifier_running_expires_from_c() {
    let program = compile_c("tests/verify_keyframes.c", "verify_keyframes_absent");
    let out = run(
        &program,
        &[&format!("capi-absent-{}", std::process::id()), "absent"],
    );
    assert_eq!(out.trim(), "ok expired: verifier absent");
}

/// The lines `merge_paths.c` prints for KITTI 00 mono
/// onto its ground truth and the mono estimate's loops, made by the
/// library itself (top 5 of each).
fn library_merges_and_loops(gt: &Path, mono: &Path) -> Vec<String> {
    use turnprint::io::{read_trajectory, Format};
    use turnprint::{find_loops, match_paths, Config, Hypothesis};

    let a = read_trajectory(gt, Format::Kitti).unwrap();
    let b = read_trajectory(mono, Format::Tum).unwrap();
    let line = |what: &str, h: &Hypothesis| {
        format!(
            "{what} a={}-{} b={}-{} score={:.4} scale={:.4} reversed={}",
            h.a_range[0],
            h.a_range[1],
            h.b_range[0],
            h.b_range[1],
            h.score,
            h.scale,
            h.reversed as i32
        )
    };
    let top5 = |c: Config| Config { top_k: 5, ..c };
    let merges = match_paths(&a, &b, &top5(Config::for_matching())).unwrap();
    let loops = find_loops(&b, &top5(Config::for_loops())).unwrap();
    // The monocular estimate onto the ground truth at its true scale (about
    // 16) as rank 1, and its big revisit (poses 380-953 again at 3384-3848)
    // among the loops. Ranges are held to a few poses, not exactly, so that
    // a change of smoothing that moves a boundary by one sample is no failure
    // here: the comparison with C below is exact.
    let near = |r: [usize; 2], want: [usize; 2]| {
        r[0].abs_diff(want[0]) <= 10 && r[1].abs_diff(want[1]) <= 10
    };
    let first = &merges[0];
    assert!(
        near(first.a_range, [7, 4535])
            && near(first.b_range, [0, 4536])
            && (15.0..17.5).contains(&first.scale)
            && !first.reversed,
        "{}",
        line("match", first)
    );
    assert!(
        loops
            .iter()
            .any(|h| near(h.a_range, [3384, 3848]) && near(h.b_range, [380, 953])),
        "{:?}",
        loops.iter().map(|h| line("loop", h)).collect::<Vec<_>>()
    );
    let mut lines: Vec<String> = merges.iter().map(|h| line("match", h)).collect();
    lines.extend(loops.iter().map(|h| line("loop", h)));
    lines
}

#[test]
fn whole_paths_from_c_give_the_librarys_merges_and_loops() {
    let program = compile_c("tests/merge_paths.c", "merge_paths");
    let (Some(gt), Some(mono)) = (data("kitti_gt/00.txt"), data(KITTI_00_MONO)) else {
        return;
    };
    let out = run(&program, &[gt.to_str().unwrap(), mono.to_str().unwrap()]);
    assert_eq!(
        out.lines().collect::<Vec<_>>(),
        library_merges_and_loops(&gt, &mono)
    );
}

/// Runs `cmake` with `args` (`scripts/setup.sh` installs it).
fn cmake(args: &[&str]) {
    let out = Command::new("cmake")
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run cmake: {e} (scripts/setup.sh installs it)"));
    assert!(
        out.status.success(),
        "cmake {args:?} failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A C++ project finds the installed library with `find_package`, a C
/// program with `pkg-config`: `capi/CMakeLists.txt` installs the header,
/// both libraries, the CMake package and the `.pc` file into a prefix,
/// then `examples/CMakeLists.txt` builds the VO loop against it. (The
/// library is the one cargo built for this test, through
/// `TURNPRINT_LIBRARY_DIR`: a cargo run inside `cargo test` would wait on
/// the build directory's lock.)
#[test]
fn cmake_and_pkg_config_projects_build_against_the_installed_library() {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cmake");
    let _ = std::fs::remove_dir_all(&tmp);
    let (build, prefix, app) = (tmp.join("build"), tmp.join("prefix"), tmp.join("app"));
    let lib_dir = library().parent().unwrap().to_path_buf();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let capi = manifest();
    cmake(&[
        "-S",
        &s(&capi),
        "-B",
        &s(&build),
        &format!("-DTURNPRINT_LIBRARY_DIR={}", s(&lib_dir)),
    ]);
    cmake(&["--build", &s(&build)]);
    cmake(&["--install", &s(&build), "--prefix", &s(&prefix)]);
    for installed in [
        "include/turnprint.h",
        "lib/libturnprint_c.a",
        "lib/libturnprint_c.so",
        "lib/cmake/turnprint/turnprintConfig.cmake",
        "lib/pkgconfig/turnprint.pc",
    ] {
        assert!(prefix.join(installed).exists(), "{installed} not installed");
    }

    // find_package(turnprint) and turnprint::turnprint (static).
    cmake(&[
        "-S",
        &s(&capi.join("examples")),
        "-B",
        &s(&app),
        &format!("-DCMAKE_PREFIX_PATH={}", s(&prefix)),
        "-DCMAKE_BUILD_TYPE=Release",
    ]);
    cmake(&["--build", &s(&app)]);
    let Some(path) = data(KITTI_00_MONO) else {
        return;
    };
    let out = run(&app.join("vo_loop"), &[path.to_str().unwrap(), "--wait"]);
    assert_eq!(candidate_lines(&out), rust_candidates(&path));

    // pkg-config (the shared library, found at run time by its rpath).
    let flags = Command::new("pkg-config")
        .args(["--cflags", "--libs", "turnprint"])
        .env("PKG_CONFIG_PATH", prefix.join("lib/pkgconfig"))
        .output()
        .expect("pkg-config (scripts/setup.sh installs it)");
    assert!(flags.status.success(), "pkg-config found no turnprint.pc");
    let flags = String::from_utf8(flags.stdout).unwrap();
    let program = tmp.join("lost_track");
    let status = Command::new("cc")
        .args(["-std=c99", "-Wall", "-Werror"])
        .arg(manifest().join("tests/lost_track.c"))
        .args(flags.split_whitespace())
        .arg("-lm")
        .arg(format!("-Wl,-rpath,{}", s(&prefix.join("lib"))))
        .arg("-o")
        .arg(&program)
        .status()
        .expect("cc");
    assert!(
        status.success(),
        "cc with pkg-config's flags ({flags}) failed"
    );
    // The installed library, found by the rpath: cargo's LD_LIBRARY_PATH
    // (target/<profile>, which may hold an older build) would come first.
    let out = Command::new(&program)
        .env_remove("LD_LIBRARY_PATH")
        .output()
        .expect("run lost_track");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.starts_with("ok "),
        "{stdout}"
    );
    let ldd = Command::new("ldd")
        .arg(&program)
        .env_remove("LD_LIBRARY_PATH")
        .output()
        .expect("ldd");
    let ldd = String::from_utf8_lossy(&ldd.stdout);
    assert!(
        ldd.contains(&s(&prefix.join("lib/libturnprint_c.so"))),
        "not linked with the installed library: {ldd}"
    );
}
