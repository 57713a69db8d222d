//! Helpers shared by the command-line tests: the real data, the verifier
//! binary and commands fed on stdin.

// Each test crate compiles this module and uses only some of it.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The absolute path of `file` in the shared data (its layout, e.g.
/// `kitti_gt/00.txt`), or `None` after a line saying the test is skipped
/// ([`turnprint_eval::data::require`]; a failure under `CI=true`).
pub fn data(file: &str) -> Option<String> {
    let path = turnprint_eval::data::require(file)?;
    let path = std::path::absolute(&path).unwrap_or(path);
    Some(path.to_str().expect("a UTF-8 data path").to_string())
}

/// The `turnprint-verifier` binary that `turnprint stream --verify` starts:
/// beside `turnprint` (`target/release/`), built by `cargo build --release
/// --workspace --bins` (it is a binary of the `turnprint-verifier` package,
/// so testing `turnprint-cli` alone does not build it). Missing: `None`
/// after a line saying the test is skipped, and a failure under `CI=true`.
pub fn verifier_binary() -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_BIN_EXE_turnprint")).with_file_name("turnprint-verifier");
    if path.is_file() {
        return Some(path);
    }
    let message = format!(
        "no {} (build it first: cargo build --release --workspace --bins)",
        path.display()
    );
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    assert!(!ci, "CI=true: {message}");
    eprintln!("skipped: {message}");
    None
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
