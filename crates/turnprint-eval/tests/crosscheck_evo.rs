//! APE and RPE of `turnprint_eval::ape` against evo 1.38.1's Python API
//! (`scripts/crosscheck/evo_ape.py`) on real KITTI 00 estimates: S-PTAM
//! (drifting stereo) and ORB-SLAM (loop-closed stereo) against the ground
//! truth, SE(3)- and Sim(3)-aligned. Skips without a Python that has evo
//! (`scripts/setup.sh` makes one) except under `CI=true`.
//!
//! KITTI files pair pose i with pose i on both sides. The TUM fr2/desk
//! case is not checked: `eval::ape` takes paired positions and turnprint
//! has no timestamp association of evo's kind (`evo.core.sync`).
//!
//! RPE: turnprint's `rpe_positions` is the length of the difference of each
//! step's displacement after the estimate is rotated (and scaled) by the APE
//! alignment; evo's RPE expresses each step in its own pose frame, another
//! measure. The script therefore computes turnprint's definition with numpy
//! on evo's aligned trajectory, which checks the alignment and statistics;
//! evo's own RPE is only reported.

mod crosscheck_support;

use crosscheck_support::{num, python_with, run_json, shared, within};
use turnprint::io::{read_trajectory, Format};
use turnprint_eval::ape::{ape, rpe_positions, Alignment, ErrorStats};

/// Agreement asked of every figure: both sides compute the same Umeyama fit
/// and statistics in double precision.
const TOLERANCE: f64 = 1e-6;

fn check(name: &str, ours: &ErrorStats, evo: &serde_json::Value) {
    let mut worst: f64 = 0.0;
    for (key, value) in [
        ("rmse", ours.rmse),
        ("mean", ours.mean),
        ("median", ours.median),
        ("max", ours.max),
    ] {
        let theirs = num(evo, key);
        assert!(
            within(value, theirs, TOLERANCE),
            "{name} {key}: turnprint {value} vs evo {theirs}"
        );
        worst = worst.max((value - theirs).abs() / theirs.abs());
    }
    eprintln!(
        "{name}: rmse {:.6} mean {:.6} median {:.6} max {:.6} (evo {:.6} {:.6} {:.6} {:.6}; \
         largest relative difference {worst:.1e})",
        ours.rmse,
        ours.mean,
        ours.median,
        ours.max,
        num(evo, "rmse"),
        num(evo, "mean"),
        num(evo, "median"),
        num(evo, "max")
    );
}

#[test]
fn ape_and_rpe_agree_with_evo_on_kitti_00() {
    let Some(python) = python_with("evo.core.metrics") else {
        return;
    };
    let Some(gt_path) = shared("kitti_gt/00.txt") else {
        return;
    };
    let truth = read_trajectory(&gt_path, Format::Kitti)
        .expect("readable")
        .positions();
    for estimate in ["evo/KITTI_00_SPTAM.txt", "evo/KITTI_00_ORB.txt"] {
        let Some(path) = shared(estimate) else {
            return;
        };
        let est = read_trajectory(&path, Format::Kitti)
            .expect("readable")
            .positions();
        let delta = 1;
        let evo = run_json(
            &python,
            "evo_ape.py",
            &[
                path.to_str().unwrap(),
                gt_path.to_str().unwrap(),
                "--delta",
                &delta.to_string(),
            ],
        );
        assert_eq!(
            evo["poses"].as_u64(),
            Some(est.len().min(truth.len()) as u64)
        );
        for (key, alignment) in [("se3", Alignment::Se3), ("sim3", Alignment::Sim3)] {
            let ours = ape(&est, &truth, alignment).expect("APE");
            check(&format!("{estimate} APE {key}"), &ours, &evo[key]["ape"]);
            let ours = rpe_positions(&est, &truth, delta, alignment).expect("RPE");
            check(
                &format!("{estimate} RPE {key} (positions, delta {delta})"),
                &ours,
                &evo[key]["rpe_positions"],
            );
            eprintln!("  evo's own RPE (pose frames): {}", evo[key]["rpe_evo"]);
        }
    }
}
