//! The network registration (`online::register`): where the drifting-map
//! probe's seed finds the earlier road but no candidate, the newest stretch
//! is placed on everything driven before, not only on the one earlier pass.

#![cfg(feature = "eval")]

use std::path::Path;

use nalgebra::Vector3;
use rand::SeedableRng;
use turnprint::eval::drift::DriftModel;
use turnprint::io::{read_trajectory, Format};
use turnprint::online::{OnlineConfig, Source};

mod common;

/// KITTI 00 under the strong drift model (seed 3). At its first revisit
/// (frames 1553-1645 over 112-207) the later pass comes down a cross
/// street, drives 70 m of a road the earlier pass drove straight through,
/// and leaves by another cross street; the drift has moved it about 60 m.
/// Pairwise, any slide along the common straight fits (under seed 1 the
/// candidates slid 40-55 m) and the event was missed; on the whole network
/// only one placement lays both junctions onto earlier roads.
#[test]
fn kitti00s_first_revisit_under_strong_drift_is_placed_on_the_network() {
    let truth = read_trajectory(Path::new("tests/data/00.txt"), Format::Kitti)
        .expect("tests/data/00.txt")
        .positions();
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let drifted: Vec<Vector3<f64>> = DriftModel::strong().apply(&truth, &mut rng);
    let out = common::emitted_candidates(&drifted[..1800], OnlineConfig::default());
    let placed = out.iter().find(|c| {
        let h = &c.hypothesis;
        c.source == Source::Network
            && h.a_range[0] <= 1645
            && h.a_range[1] >= 1553
            && common::is_correct(c, &truth)
    });
    assert!(
        placed.is_some(),
        "{} candidates, none from the network registration correct at frames 1553-1645",
        out.len()
    );
}
