//! Pins the batch outputs of track, signature and segments on KITTI 00 and
//! 06 (ground truth), so refactoring the stages into incremental forms
//! cannot change them. `TURNPRINT_WRITE_PIN=1` rewrites the pins (only ever
//! done before a refactor, from the code being replaced). The pins are in
//! `tests/pins`; the ground truth comes from the shared data.

use std::path::Path;

use turnprint::io::{read_trajectory, Format};
use turnprint::pipeline::{Config, PreparedPath};

mod common;

/// Where the pins are.
const PINS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/pins");

fn digest(path: &Path) -> serde_json::Value {
    let t = read_trajectory(path, Format::Auto).expect("ground truth reads");
    let p = PreparedPath::new(&t, &Config::default()).expect("prepares");
    let tr = &p.track;
    let every = |v: &[f64]| v.iter().step_by(97).copied().collect::<Vec<f64>>();
    let xs: Vec<f64> = tr.xy.iter().map(|q| q.x).collect();
    let ys: Vec<f64> = tr.xy.iter().map(|q| q.y).collect();
    serde_json::json!({
        "track_len": tr.len(),
        "step": tr.step,
        "bandwidth": tr.bandwidth,
        "x": every(&xs),
        "y": every(&ys),
        "s": every(&tr.s),
        "heading": every(&tr.heading),
        "curvature": every(&tr.curvature),
        "pose": every(&tr.pose),
        "sig_value": p.signature.value,
        "sig_s": p.signature.s,
        "sig_grid": p.signature.grid,
        "bounds": p.bounds,
    })
}

fn check(name: &str) {
    let Some(path) = common::shared(&format!("kitti_gt/{name}.txt")) else {
        return;
    };
    let pin = format!("{PINS}/batch_{name}.json");
    let now = digest(&path);
    if std::env::var("TURNPRINT_WRITE_PIN").is_ok() {
        // A pin the code under test rewrites checks nothing: never in CI.
        let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
        assert!(!ci, "CI=true: TURNPRINT_WRITE_PIN is refused");
        std::fs::create_dir_all(PINS).unwrap();
        std::fs::write(&pin, serde_json::to_string(&now).unwrap()).unwrap();
        return;
    }
    let text = std::fs::read_to_string(&pin).expect("pin exists");
    let then: serde_json::Value = serde_json::from_str(&text).unwrap();
    compare(name, "", &then, &now);
}

/// Exact equality of integers, 1e-9 relative for floats (JSON round trip).
fn compare(name: &str, at: &str, a: &serde_json::Value, b: &serde_json::Value) {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(x.len(), y.len(), "{name}{at}: keys");
            for (k, v) in x {
                compare(name, &format!("{at}.{k}"), v, &y[k]);
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{name}{at}: length");
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                compare(name, &format!("{at}[{i}]"), u, v);
            }
        }
        (Value::Number(x), Value::Number(y)) if x.is_u64() => assert_eq!(x, y, "{name}{at}"),
        (Value::Number(x), Value::Number(y)) => {
            let (u, v) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (u - v).abs() <= 1e-9 * u.abs().max(1.0),
                "{name}{at}: {u} vs {v}"
            );
        }
        _ => assert_eq!(a, b, "{name}{at}"),
    }
}

#[test]
fn batch_outputs_unchanged_kitti_00() {
    check("00");
}

#[test]
fn batch_outputs_unchanged_kitti_06() {
    check("06");
}
