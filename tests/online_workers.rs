//! `OnlineConfig::workers`: several matching threads, sharing out the
//! matchings of the hand-overs queued at once over one history (each
//! matching reads it as it stood when the matching fell due), give exactly
//! the candidates of one, in the same order with the same ids: what
//! depends on earlier matchings (a registration too soon after the
//! previous one, the ids) is settled in stream order (`worker::Settle`).

use nalgebra::Vector3;
use rand::SeedableRng;
use turnprint::online::{CandidateEvent, OnlineConfig, Source, Summary};
use turnprint_eval::drift::DriftModel;

mod common;

/// KITTI ground truth `name`, or `None` after a line saying it is skipped.
fn kitti(name: &str) -> Option<Vec<Vector3<f64>>> {
    common::kitti_gt(name)
}

/// Every candidate of a replay with `workers` threads, in arrival order,
/// and the summary.
fn replayed(points: &[Vector3<f64>], workers: usize) -> (Vec<CandidateEvent>, Summary) {
    let config = OnlineConfig {
        workers,
        ..Default::default()
    };
    common::replayed(points, config)
}

/// The candidates, every field (`Debug` prints floats exactly).
fn printed(events: &[CandidateEvent]) -> Vec<String> {
    events.iter().map(|e| format!("{e:?}")).collect()
}

fn same_with_any_number_of_workers(points: &[Vector3<f64>]) -> Vec<CandidateEvent> {
    let (one, alone) = replayed(points, 1);
    assert_eq!(alone.worker.candidates, one.len() as u64);
    assert_eq!(alone.worker.parallel_batches, 0);
    assert!(!one.is_empty());
    for workers in [2, 3] {
        let (many, summary) = replayed(points, workers);
        let (a, b) = (printed(&one), printed(&many));
        if let Some(i) = (0..a.len().max(b.len())).find(|&i| a.get(i) != b.get(i)) {
            panic!(
                "{workers} workers: candidate {i} of {} differs from one worker's (of {}):\n{:?}\n{:?}",
                b.len(),
                a.len(),
                b.get(i),
                a.get(i)
            );
        }
        assert_eq!(
            summary.worker.candidates,
            one.len() as u64,
            "{workers} workers' count"
        );
        // The matchings were shared out, over the one history.
        assert!(summary.worker.parallel_batches > 0, "{workers} workers");
        assert_eq!(summary.worker.history_bytes, alone.worker.history_bytes);
    }
    one
}

#[test]
fn two_or_three_workers_give_one_workers_candidates_on_kitti_00() {
    let Some(gt) = kitti("00") else {
        return;
    };
    same_with_any_number_of_workers(&gt);
}

/// Under strong drift the network registration runs at most probes, so
/// the rule that drops one too soon after the previous one is settled
/// across workers.
#[test]
fn two_or_three_workers_give_one_workers_candidates_under_strong_drift() {
    let Some(truth) = kitti("08") else {
        return;
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(2);
    let drifted = DriftModel::strong().apply(&truth, &mut rng);
    let one = same_with_any_number_of_workers(&drifted);
    assert!(
        one.iter().any(|e| e.source == Source::Network),
        "no registration to settle"
    );
}
