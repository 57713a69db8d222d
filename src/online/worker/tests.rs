//! Tests of the matching worker: settling in stream order, and a worker
//! lost to a panic.

use super::*;

fn event(score: f64, source: Source) -> CandidateEvent {
    CandidateEvent {
        id: 0,
        at_pose: 0,
        hypothesis: crate::Hypothesis::scored(score, [0, 1], [0, 1], false),
        source,
        keyframes: None,
        query_keyframes: Vec::new(),
        match_keyframes: Vec::new(),
    }
}

fn scores(events: &[CandidateEvent]) -> Vec<(u64, f64)> {
    events.iter().map(|e| (e.id, e.hypothesis.score)).collect()
}

#[test]
fn settling_drops_a_registration_too_soon_keeps_the_top_k_and_numbers_in_order() {
    let config = OnlineConfig::default();
    let every = config.probe_every;
    let emitted = Arc::new(AtomicU64::new(0));
    let mut settle = Settle::new(&config, emitted.clone());
    let registered = |g1: usize, scores: &[f64]| {
        Some((
            g1,
            scores.iter().map(|&s| event(s, Source::Network)).collect(),
        ))
    };
    // Registered: two searches' candidates and two places, best three
    // kept, best first.
    let first = settle.settle(Matched {
        found: vec![event(0.2, Source::Proximity), event(0.1, Source::Proximity)],
        registered: registered(1000, &[0.3, 0.05]),
    });
    assert_eq!(scores(&first), [(1, 0.3), (2, 0.2), (3, 0.1)]);
    // A few samples later: the registration is dropped, the searches'
    // candidate kept.
    let soon = settle.settle(Matched {
        found: vec![event(0.4, Source::Shape)],
        registered: registered(1000 + every - 1, &[0.9]),
    });
    assert_eq!(scores(&soon), [(4, 0.4)]);
    // A period after the last one that counted: kept.
    let later = settle.settle(Matched {
        found: Vec::new(),
        registered: registered(1000 + every, &[0.6]),
    });
    assert_eq!(scores(&later), [(5, 0.6)]);
    assert_eq!(emitted.load(Ordering::Relaxed), 5);
}

/// KITTI 00's ground truth positions, or `None` when absent.
fn kitti_00() -> Option<Vec<nalgebra::Vector3<f64>>> {
    let path = crate::test_data::shared_data("kitti_gt/00.txt")?;
    let t = crate::io::read_trajectory(&path, crate::io::Format::Kitti).expect("KITTI 00");
    Some(t.positions())
}

/// KITTI 00's ground truth `points` replayed with `workers` matching
/// threads, the worker panicking at matching `fail`: the candidates in
/// arrival order, the summary, and the losses seen before `finish`.
fn replay_failing(
    points: &[nalgebra::Vector3<f64>],
    workers: usize,
    fail: Option<u64>,
) -> (Vec<CandidateEvent>, super::super::Summary, u64) {
    use super::super::{Detector, PoseInput};
    FAIL_AT.set(fail);
    let config = OnlineConfig {
        workers,
        ..Default::default()
    };
    let mut det = Detector::new(config, Overflow::Block);
    FAIL_AT.set(None);
    let mut out = Vec::new();
    for p in points {
        det.push(&PoseInput::at(*p));
        out.extend(det.poll());
    }
    let seen = det.workers_lost();
    let (rest, summary) = det.finish();
    out.extend(rest);
    (out, summary, seen)
}

/// A panic in a matching, on the worker's thread or a helper's, loses
/// the worker: counted, the candidates before it kept, no hang.
#[test]
fn a_lost_worker_is_counted_and_its_candidates_before_the_loss_are_kept() {
    let printed = |events: &[CandidateEvent]| -> Vec<String> {
        events.iter().map(|e| format!("{e:?}")).collect()
    };
    let Some(points) = kitti_00() else {
        return;
    };
    for workers in [1, 2] {
        let (all, healthy, _) = replay_failing(&points, workers, None);
        assert_eq!(healthy.workers_lost, 0);
        // Matching 160 of 219 falls past the first half of the
        // candidates (with two threads its whole batch is lost: up to
        // the replay's queue of hand-overs).
        let (out, summary, seen) = replay_failing(&points, workers, Some(160));
        // Seen live at the first hand-over after it, if the caller had
        // any left by then (the replay's queue is deep).
        assert_eq!(summary.workers_lost, 1, "{workers} threads");
        assert!(seen <= 1);
        assert_eq!(summary.worker.candidates, out.len() as u64);
        let (a, b) = (printed(&all), printed(&out));
        let same = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
        assert!(same < a.len(), "{workers} threads: {same} of {}", a.len());
        if workers == 1 {
            // Every matching before it settled.
            assert!(same >= 20, "{same} of {}", a.len());
        }
        // Nothing after the loss: a batch's matchings settle only once
        // every one of them has run.
        assert_eq!(same, b.len(), "{workers} threads");
    }
}

/// Live use: the caller, which never waits, notices the loss at its
/// next hand-over and lets the worker go, rather than keep samples for
/// a queue no one empties (they would pile up in its outbox for ever).
#[test]
fn a_live_caller_lets_a_lost_worker_go_and_hands_over_no_more() {
    use super::super::{Detector, PoseInput};
    let Some(points) = kitti_00() else {
        return;
    };
    let (first, rest) = points.split_at(1500);
    for workers in [1, 2] {
        // Its first matching: within the first part of the drive.
        FAIL_AT.set(Some(0));
        let config = OnlineConfig {
            workers,
            ..Default::default()
        };
        let mut det = Detector::new(config, Overflow::MergeLatest);
        FAIL_AT.set(None);
        for p in first {
            det.push(&PoseInput::at(*p));
        }
        // Then at a fast odometry's pace (10 poses in 3 ms, about 0.9 s
        // in all): the worker meets its end early in it (its panic's
        // backtrace, the first in the process, takes a few hundred
        // milliseconds to print).
        for chunk in rest.chunks(10) {
            std::thread::sleep(std::time::Duration::from_millis(3));
            for p in chunk {
                det.push(&PoseInput::at(*p));
            }
        }
        assert_eq!(det.workers_lost(), 1, "{workers} threads");
        let (_, summary) = det.finish();
        assert_eq!(summary.workers_lost, 1);
    }
}
