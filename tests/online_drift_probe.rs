//! `OnlineConfig::drift_probe`: where the consistent map's proximity probe
//! finds nothing near, a second probe whose radius grows with the path
//! between the two parts. On KITTI 08 under strong drift (seed 2) the
//! default detector emits no correct candidate; the drift probe does.

#![cfg(feature = "eval")]

use std::path::Path;

use nalgebra::Vector3;
use rand::SeedableRng;
use turnprint::eval::checks::{loop_correct, LoopClaim};
use turnprint::eval::drift::DriftModel;
use turnprint::io::{read_trajectory, Format};
use turnprint::online::OnlineConfig;

mod common;

/// Emitted candidates that are correct against `truth`, and all emitted.
fn correct_of(
    points: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    drift_probe: bool,
) -> (usize, usize) {
    let config = OnlineConfig {
        drift_probe,
        ..Default::default()
    };
    let out = common::emitted_candidates(points, config);
    let correct = out
        .iter()
        .filter(|c| {
            let claim = LoopClaim {
                query: c.hypothesis.a_range,
                matched: c.hypothesis.b_range,
                score: c.hypothesis.score,
            };
            loop_correct(&claim, truth, 10.0)
        })
        .count();
    (correct, out.len())
}

#[test]
fn drift_probe_finds_revisits_of_a_strongly_drifting_map() {
    let truth = read_trajectory(Path::new("tests/data/08.txt"), Format::Kitti)
        .expect("tests/data/08.txt")
        .positions();
    let mut rng = rand::rngs::StdRng::seed_from_u64(2);
    let drifted = DriftModel::strong().apply(&truth, &mut rng);
    let (without, _) = correct_of(&drifted, &truth, false);
    let (with, emitted) = correct_of(&drifted, &truth, true);
    assert_eq!(without, 0);
    assert!(with >= 2, "{with} correct of {emitted}");
    assert!(with * 2 >= emitted, "{with} correct of {emitted}");
}

#[test]
fn drift_probe_is_off_by_default() {
    assert!(!OnlineConfig::default().drift_probe);
    assert_eq!(OnlineConfig::default().drift_radius(), 0.0);
}
