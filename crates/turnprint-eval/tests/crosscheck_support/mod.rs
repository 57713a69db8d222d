//! Shared by the cross-checks against evo and GTSAM: the Python that has
//! them, the shared data, and running a script of `scripts/crosscheck/` for
//! its JSON.
//!
//! Python is `TURNPRINT_PYTHON`, else the venv `scripts/setup.sh` makes at
//! `target/pyenv`. Without it (or without the module) a check says so and
//! skips, except under `CI=true`, where the set-up installs both and a
//! missing tool is a failure.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The Python that imports `module`, or `None` after a skip message.
pub fn python_with(module: &str) -> Option<PathBuf> {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    let python = std::env::var_os("TURNPRINT_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/pyenv/bin/python")
        });
    let imports = Command::new(&python)
        .args(["-c", &format!("import {module}")])
        .env("HOME", home())
        .output()
        .is_ok_and(|o| o.status.success());
    if imports {
        return Some(python);
    }
    let message = format!(
        "{} cannot import {module} (run scripts/setup.sh or set TURNPRINT_PYTHON)",
        python.display()
    );
    assert!(!ci, "CI=true: {message}");
    eprintln!("skipped: {message}");
    None
}

/// A fresh temporary directory for HOME: evo writes its settings there.
fn home() -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("turnprint-crosscheck-home-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    dir
}

/// `file` where the real data is, or `None` after a skip message.
pub fn shared(file: &str) -> Option<PathBuf> {
    turnprint_eval::data::require(file)
}

/// `scripts/crosscheck/<script>` run by `python` with `args`: its JSON.
pub fn run_json(python: &Path, script: &str, args: &[&str]) -> serde_json::Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scripts/crosscheck")
        .join(script);
    let out = Command::new(python)
        .arg(&path)
        .args(args)
        .env("HOME", home())
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "{script} {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{script}: not JSON ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// `value[key]` as a number.
pub fn num(value: &serde_json::Value, key: &str) -> f64 {
    value[key]
        .as_f64()
        .unwrap_or_else(|| panic!("no number '{key}' in {value}"))
}

/// `|a - b| <= tol · max(|a|, |b|)`.
pub fn within(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs())
}
