//! How fast the real monocular ORB-SLAM2 estimates of KITTI drift, in the
//! units of the evaluation's drift model (`eval::drift::DriftModel`): the
//! spread of the heading error and of the log-scale error accumulated over
//! L metres of road, divided by sqrt(L). This is what "strong drift" in
//! EVALUATION.md is measured against.
//!
//! Both paths are resampled every 10 m of ground-truth road (KITTI's ground
//! plane is x-z for the ground truth and the camera-frame estimate alike);
//! the heading error of a 10 m chord is the estimate's heading minus the
//! ground truth's, the scale error of a 50 m chord the log of its length
//! ratio; the spread is a robust one (1.4826 x median absolute deviation),
//! so the few places where ORB-SLAM2 closed a loop do not dominate it.
//!
//! `cargo run --release --example mono_drift [-- DATA_DIR]`

use std::path::PathBuf;

use nalgebra::Vector2;
use turnprint_eval::data::{load_sequence, SEQUENCES};
use turnprint_eval::drift::DriftModel;

/// Resampling step along the ground truth (m).
const STEP: f64 = 10.0;
/// Chord of the scale error (m).
const SCALE_CHORD: f64 = 50.0;
/// Road lengths over which the drift is measured (m).
const LENGTHS: [f64; 3] = [100.0, 300.0, 1000.0];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "../shared/data".into()),
    );
    let strong = DriftModel::strong();
    println!(
        "strong drift model: heading {:.3} deg/sqrt(m), log-scale {:.4} /sqrt(m)\n",
        strong.heading_deg_per_sqrt_len, strong.log_scale_per_sqrt_len
    );
    println!("| sequence | heading drift (deg/sqrt(m)) over 100 / 300 / 1000 m | log-scale drift (/sqrt(m)) over 100 / 300 / 1000 m |");
    println!("|---|---|---|");
    for name in SEQUENCES {
        let seq = load_sequence(&dir, name)?;
        if seq.mono.positions.len() < 2 {
            println!("| {name} | no mono estimate | |");
            continue;
        }
        let xz = |p: &nalgebra::Vector3<f64>| Vector2::new(p.x, p.z);
        let truth: Vec<Vector2<f64>> = seq
            .mono
            .frames
            .iter()
            .map(|&f| xz(&seq.true_position(f)))
            .collect();
        let mono: Vec<Vector2<f64>> = seq.mono.positions.iter().map(xz).collect();
        // Both resampled at the same ground-truth arc lengths.
        let arc = arc(&truth);
        let at = |path: &[Vector2<f64>], s: f64| {
            let k = arc.partition_point(|&x| x < s).clamp(1, arc.len() - 1);
            let t = ((s - arc[k - 1]) / (arc[k] - arc[k - 1]).max(1e-9)).clamp(0.0, 1.0);
            path[k - 1] * (1.0 - t) + path[k] * t
        };
        let n = (arc[arc.len() - 1] / STEP) as usize;
        let grid: Vec<f64> = (0..=n).map(|k| k as f64 * STEP).collect();
        let (g, m): (Vec<_>, Vec<_>) = grid.iter().map(|&s| (at(&truth, s), at(&mono, s))).unzip();
        let heading_error = unwrap(
            &(1..g.len())
                .map(|k| {
                    let (dg, dm) = (g[k] - g[k - 1], m[k] - m[k - 1]);
                    dm.y.atan2(dm.x) - dg.y.atan2(dg.x)
                })
                .collect::<Vec<_>>(),
        );
        let c = (SCALE_CHORD / STEP) as usize;
        let log_scale: Vec<f64> = (c..g.len())
            .map(|k| ((m[k] - m[k - c]).norm() / (g[k] - g[k - c]).norm()).ln())
            .collect();
        let per_sqrt = |e: &[f64], degrees: bool| {
            LENGTHS
                .map(|l| {
                    let k = (l / STEP) as usize;
                    let d: Vec<f64> = (k..e.len()).map(|i| e[i] - e[i - k]).collect();
                    let spread = robust_spread(&d);
                    let spread = if degrees { spread.to_degrees() } else { spread };
                    format!("{:.3}", spread / l.sqrt())
                })
                .join(" / ")
        };
        println!(
            "| {name} | {} | {} |",
            per_sqrt(&heading_error, true),
            per_sqrt(&log_scale, false)
        );
    }
    Ok(())
}

fn arc(p: &[Vector2<f64>]) -> Vec<f64> {
    let mut s = vec![0.0; p.len()];
    for k in 1..p.len() {
        s[k] = s[k - 1] + (p[k] - p[k - 1]).norm();
    }
    s
}

/// Angles made continuous (no 2 pi jumps).
fn unwrap(a: &[f64]) -> Vec<f64> {
    let tau = std::f64::consts::TAU;
    let mut out = Vec::with_capacity(a.len());
    let mut offset = 0.0f64;
    for (k, &x) in a.iter().enumerate() {
        if k > 0 {
            let d: f64 = x + offset - out[k - 1];
            offset -= tau * (d / tau).round();
        }
        out.push(x + offset);
    }
    out
}

/// 1.4826 x the median absolute deviation (the standard deviation of a
/// normal sample, robust to outliers).
fn robust_spread(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let median = |mut x: Vec<f64>| {
        x.sort_by(f64::total_cmp);
        x[x.len() / 2]
    };
    let m = median(v.to_vec());
    1.4826 * median(v.iter().map(|x| (x - m).abs()).collect())
}
