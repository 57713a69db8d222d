//! The drift-prior gate (`OnlineConfig::prior_gate`) skips growing shape
//! candidates whose prior bound cannot reach the score cut, stops those
//! that score far below it after the first grow round, and skips drifting
//! starts whose scale growth cannot bring back. It must never drop a
//! candidate that would have been emitted: streaming real paths with the
//! gate on and off emits the same candidates.

use nalgebra::Vector3;
use rand::SeedableRng;
use turnprint::io::{read_trajectory, Format};
use turnprint::online::OnlineConfig;
use turnprint_eval::drift::DriftModel;

mod common;

/// (at_pose, a_range, b_range, score bits) of every emitted candidate.
fn emitted(points: &[Vector3<f64>], prior_gate: bool) -> Vec<(usize, [usize; 2], [usize; 2], u64)> {
    let config = OnlineConfig {
        prior_gate,
        ..Default::default()
    };
    common::emitted_candidates(points, config)
        .iter()
        .map(|c| {
            let h = &c.hypothesis;
            (c.at_pose, h.a_range, h.b_range, h.score.to_bits())
        })
        .collect()
}

/// The positions of `name` (the shared data's layout), or `None` after a
/// line saying it is skipped.
fn positions(name: &str) -> Option<Vec<Vector3<f64>>> {
    let path = common::shared(name)?;
    Some(
        read_trajectory(&path, Format::Auto)
            .expect("the file reads")
            .positions(),
    )
}

#[test]
fn the_prior_gate_keeps_every_emitted_candidate() {
    let (Some(gt), Some(mono)) = (
        positions("kitti_gt/00.txt"),
        positions("kitti_orbslam2_vio/00_orbslam2_tum.txt"),
    ) else {
        return;
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let inputs = [
        ("00 ground truth", gt.clone()),
        ("00 ORB-SLAM2 mono", mono),
        ("00 strong drift", DriftModel::strong().apply(&gt, &mut rng)),
    ];
    for (name, points) in inputs {
        let (gated, full) = (emitted(&points, true), emitted(&points, false));
        assert!(!full.is_empty(), "{name}: nothing emitted");
        assert_eq!(gated, full, "{name}");
    }
}
