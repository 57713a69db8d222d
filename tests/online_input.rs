//! Input that real odometry produces, each with its defined behaviour
//! (see `online::guard`): out-of-order and duplicate timestamps, NaN, a
//! single-pose glitch, a lasting jump, a long stop, and a full queue.

use nalgebra::Vector3;
use turnprint::io::{read_trajectory, Format};
use turnprint::online::frontend::{Frontend, Outbox};
use turnprint::online::{
    Detector, GuardCounts, OnlineConfig, Overflow, PoseInput, Pushed, Rejection,
};

mod common;

/// KITTI ground truth `name`, or `None` after a line saying it is skipped.
fn kitti(name: &str) -> Option<Vec<Vector3<f64>>> {
    common::kitti_gt(name)
}

/// Runs positions through the frontend; returns the outbox and the counts.
fn front(points: &[Vector3<f64>]) -> (Outbox, GuardCounts) {
    let config = OnlineConfig::default();
    let (mut counts, mut out) = (GuardCounts::default(), Outbox::default());
    let mut f = Frontend::Warmup(Vec::new());
    for (i, p) in points.iter().enumerate() {
        f.push(i, *p, &config, &mut counts, &mut out);
    }
    if let Frontend::Running(s) = &mut f {
        s.flush(&mut counts, &mut out);
    }
    (out, counts)
}

/// The summary of streaming `points` with the default settings.
fn streamed(points: &[Vector3<f64>]) -> turnprint::online::Summary {
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    for p in points {
        d.push(&PoseInput::at(*p));
    }
    d.finish().1
}

fn turning(out: &Outbox) -> f64 {
    out.sig.len() as f64 * 2f64.to_radians()
}

/// A pose at `(x, 0, 0)` stamped `t`.
fn at(t: f64, x: f64) -> PoseInput {
    PoseInput {
        t: Some(t),
        ..PoseInput::at(Vector3::new(x, 0.0, 0.0))
    }
}

#[test]
fn timestamps_out_of_order_duplicate_and_nan_are_dropped_and_counted() {
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    assert_eq!(d.push(&at(1.0, 0.0)), Pushed::Accepted(0));
    assert_eq!(d.push(&at(2.0, 1.0)), Pushed::Accepted(1));
    assert_eq!(
        d.push(&at(0.5, 2.0)),
        Pushed::Rejected(2, Rejection::OutOfOrder)
    );
    assert_eq!(
        d.push(&at(2.0, 2.0)),
        Pushed::Rejected(3, Rejection::Duplicate)
    );
    assert_eq!(
        d.push(&at(f64::NAN, 2.0)),
        Pushed::Rejected(4, Rejection::NonFinite)
    );
    assert_eq!(
        d.push(&at(3.0, f64::NAN)),
        Pushed::Rejected(5, Rejection::NonFinite)
    );
    assert_eq!(
        d.push(&at(3.0, f64::INFINITY)),
        Pushed::Rejected(6, Rejection::NonFinite)
    );
    assert_eq!(d.push(&at(3.0, 3.0)), Pushed::Accepted(7));
    let (_, s) = d.finish();
    assert_eq!((s.poses, s.accepted), (8, 3));
    assert_eq!(
        (
            s.guards.out_of_order,
            s.guards.duplicate,
            s.guards.non_finite
        ),
        (1, 1, 3)
    );
}

/// A stamp ahead of both its neighbours, then time as before: the poses
/// after it are taken, not dropped until the clock catches up (CARMEN's
/// Intel lab log stamps lines ahead 305 times: 3 007 of its 26 915 poses
/// were dropped). A pose older than the two before it is still out of
/// order.
#[test]
fn a_lone_stamp_ahead_drops_no_pose_after_it() {
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    assert_eq!(d.push(&at(1.0, 0.0)), Pushed::Accepted(0));
    assert_eq!(d.push(&at(2.0, 1.0)), Pushed::Accepted(1));
    assert_eq!(d.push(&at(3.4, 2.0)), Pushed::Accepted(2));
    assert_eq!(d.push(&at(3.0, 3.0)), Pushed::Accepted(3));
    assert_eq!(d.push(&at(3.1, 4.0)), Pushed::Accepted(4));
    assert_eq!(
        d.push(&at(2.5, 5.0)),
        Pushed::Rejected(5, Rejection::OutOfOrder)
    );
    let (_, s) = d.finish();
    assert_eq!((s.guards.stamps_ahead, s.guards.out_of_order), (1, 1));
    let Some(path) = common::shared("carmen/intel_odom.csv") else {
        return;
    };
    let trajectory = read_trajectory(&path, Format::Auto).unwrap();
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    for pose in &trajectory.poses {
        d.push(&PoseInput::from(pose));
    }
    let (_, s) = d.finish();
    // Its other stamps that go back (single lines, or runs of a few lines
    // 0.1-0.2 s behind) are still dropped: 1 690 poses, all apart.
    assert!(s.guards.stamps_ahead >= 300, "{:?}", s.guards);
    assert!(s.guards.out_of_order < 1700, "{:?}", s.guards);
}

#[test]
fn a_single_far_pose_is_dropped_as_a_glitch() {
    let Some(clean) = kitti("06") else {
        return;
    };
    let mut glitch = clean.clone();
    glitch[600] += Vector3::new(500.0, 0.0, 800.0);
    let (a, _) = front(&clean);
    let (b, counts) = front(&glitch);
    assert_eq!(counts.outliers, 1);
    assert_eq!(counts.jumps, 0);
    assert!(
        (turning(&a) - turning(&b)).abs() < 0.02 * turning(&a),
        "K {} vs {}",
        turning(&a),
        turning(&b)
    );
    assert_eq!(a.bounds.len(), b.bounds.len());
    // The glitch never pulls the smoothed track: every sample stays within
    // a metre (about one typical step) of the clean track's.
    for (i, g) in b.grid.iter().enumerate() {
        let lo = i.saturating_sub(3);
        let hi = (i + 3).min(a.grid.len() - 1);
        let d = (lo..=hi)
            .map(|j| (a.grid[j].xy - g.xy).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(d < 1.0, "sample {i} is {d} off");
    }
}

#[test]
fn a_lasting_jump_is_removed_by_re_anchoring() {
    let Some(clean) = kitti("06") else {
        return;
    };
    let mut jumped = clean.clone();
    for p in jumped.iter_mut().skip(600) {
        *p += Vector3::new(300.0, 0.0, -700.0);
    }
    let (a, _) = front(&clean);
    let (b, counts) = front(&jumped);
    assert_eq!(counts.jumps, 1);
    assert_eq!(counts.outliers, 0);
    // Without the filter the jump would add two sharp turns (> 1 rad); with
    // it, the turning stays within 5 % and the segments within one.
    assert!(
        (turning(&a) - turning(&b)).abs() < 0.05 * turning(&a),
        "K {} vs {}",
        turning(&a),
        turning(&b)
    );
    assert!(a.bounds.len().abs_diff(b.bounds.len()) <= 1);
    let length = |o: &Outbox| o.grid.last().unwrap().s;
    assert!((length(&a) - length(&b)).abs() < 0.01 * length(&a));
}

#[test]
fn standing_still_for_a_long_time_adds_nothing() {
    let Some(clean) = kitti("06") else {
        return;
    };
    let mut stopped = clean[..500].to_vec();
    // 100 000 poses (about 3 hours at 10 Hz) at one place, with jitter of
    // 2 % of a typical step.
    let stop = clean[500];
    for k in 0..100_000u64 {
        let j = ((k.wrapping_mul(2654435761) % 1000) as f64 / 1000.0 - 0.5) * 0.02;
        stopped.push(stop + Vector3::new(j, 0.0, -j));
    }
    stopped.extend_from_slice(&clean[500..]);
    let (a, _) = front(&clean);
    let (b, _) = front(&stopped);
    assert!(
        b.grid.len() <= a.grid.len() + 2,
        "{} vs {} track samples",
        b.grid.len(),
        a.grid.len()
    );
    assert_eq!(a.bounds.len(), b.bounds.len());
    assert!((turning(&a) - turning(&b)).abs() < 0.01 * turning(&a));
}

/// With one matching thread or two (the second shares out the matchings of
/// what the queue held at once).
#[test]
fn a_full_queue_defers_and_skips_but_loses_no_sample() {
    let Some(points) = kitti("00") else {
        return;
    };
    let run = |overflow: Overflow, capacity: usize, workers: usize| {
        let config = OnlineConfig {
            queue_capacity: capacity,
            workers,
            ..OnlineConfig::default()
        };
        let mut d = Detector::new(config, overflow);
        for p in &points {
            d.push(&PoseInput::at(*p));
        }
        d.finish().1
    };
    let blocked = run(Overflow::Block, 4, 1);
    assert_eq!(blocked.deferred, 0);
    assert_eq!(blocked.worker.skipped, 0);
    for workers in [1, 2] {
        let merged = run(Overflow::MergeLatest, 1, workers);
        assert_eq!(blocked.worker.grid_samples, merged.worker.grid_samples);
        assert_eq!(blocked.worker.sig_samples, merged.worker.sig_samples);
        assert_eq!(blocked.worker.segments, merged.worker.segments);
        // Pushing a whole file at memory speed outruns the matching threads.
        assert!(merged.deferred > 0, "no deferral: {merged:?}");
        assert_eq!(
            merged.worker.matched + merged.worker.skipped,
            merged.worker.segments,
            "{workers} workers"
        );
    }
}

/// A replay's caller waits out a full queue until it is half empty: the
/// candidates must not depend on whether it ever did.
#[test]
fn a_replay_gives_the_same_candidates_whether_or_not_its_queue_filled() {
    let Some(points) = kitti("00") else {
        return;
    };
    let run = |pause_every: Option<usize>| {
        let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
        for (i, p) in points.iter().enumerate() {
            if pause_every.is_some_and(|n| i % n == 0) {
                // A caller slower than the worker: the queue never fills.
                std::thread::sleep(std::time::Duration::from_micros(300));
            }
            d.push(&PoseInput::at(*p));
        }
        d.finish()
    };
    let (fast, fast_summary) = run(None);
    let (slow, slow_summary) = run(Some(16));
    assert!(!fast.is_empty());
    // The caller at memory speed did wait out a full queue (the paced one
    // rarely does, on a loaded machine sometimes).
    assert!(fast_summary.waited > 0, "{fast_summary:?}");
    eprintln!(
        "waits on a full queue: {} at memory speed, {} paced",
        fast_summary.waited, slow_summary.waited
    );
    assert_eq!(fast_summary.messages, fast_summary.worker.messages);
    assert_eq!(fast_summary.worker.messages, slow_summary.worker.messages);
    let key = |c: &turnprint::online::CandidateEvent| {
        let h = &c.hypothesis;
        (c.at_pose, h.a_range, h.b_range, h.score.to_bits())
    };
    let (fast, slow): (Vec<_>, Vec<_>) = (
        fast.iter().map(key).collect(),
        slow.iter().map(key).collect(),
    );
    assert_eq!(fast, slow);
}

#[test]
fn kitti_00_revisit_is_found_while_streaming() {
    let Some(points) = kitti("00") else {
        return;
    };
    let (found, summary) = common::replayed(&points, OnlineConfig::default());
    assert_eq!(summary.worker.candidates as usize, found.len());
    // The long revisit (frames 3266-3854 drive over 0-600 again): a
    // candidate inside it whose parts are within 10 m in ground truth,
    // emitted before the revisit ends.
    let hit = found.iter().any(|c| {
        let h = &c.hypothesis;
        let mid_q = (h.a_range[0] + h.a_range[1]) / 2;
        let near = (h.b_range[0]..=h.b_range[1]).any(|j| (points[mid_q] - points[j]).norm() < 10.0);
        (3266..=3854).contains(&mid_q) && c.at_pose <= 3854 && near
    });
    assert!(hit, "{} candidates, none inside the revisit", found.len());
    // Ids are unique and increasing.
    assert!(found.windows(2).all(|w| w[0].id < w[1].id));
}

#[test]
fn candidates_carry_a_keyframe_pair_for_the_verifier() {
    let Some(points) = kitti("00") else {
        return;
    };
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    let mut found = Vec::new();
    for (i, p) in points.iter().enumerate() {
        d.push(&PoseInput {
            keyframe: (i % 10 == 0).then_some(1000 + i as u64),
            ..PoseInput::at(*p)
        });
        found.extend(d.poll());
    }
    found.extend(d.finish().0);
    assert!(!found.is_empty());
    for c in &found {
        let k = c.keyframes.expect("keyframes were given");
        let h = &c.hypothesis;
        assert_eq!(k.query_keyframe, 1000 + k.query_pose as u64);
        assert_eq!(k.match_keyframe, 1000 + k.match_pose as u64);
        assert!((h.a_range[0]..=h.a_range[1]).contains(&k.query_pose));
        assert!((h.b_range[0]..=h.b_range[1]).contains(&k.match_pose));
        // Ground truth: the two keyframes see the same place (within 15 m)
        // whenever the candidate is a true revisit of a consistent map (the
        // drifting-map searches' candidates are other roads on this one, and
        // so are the proximity candidates below the cut held to their rules).
        use turnprint::online::Source;
        let drifting = match c.source {
            Source::DriftProbe | Source::Network => true,
            Source::Proximity => h.score < OnlineConfig::default().min_score,
            Source::Shape => false,
        };
        if !drifting {
            assert!(
                (points[k.query_pose] - points[k.match_pose]).norm() < 15.0,
                "{k:?}"
            );
        }
    }
}

/// CARMEN Intel lab: the robot stands still for 290 poses, drives 15, then
/// turns on the spot for 300, its wheel odometry creeping by a millimetre
/// per pose against 29 mm when it drives. The warm-up ended inside the
/// turn and took that creep as the typical step: the smoothing then spanned
/// a twentieth of a driving step, every later pose became a corner, and
/// the history held 33 kB per pose with the worker at 0.1 s per pose (4000
/// poses: 62 s; the batch path takes 1.4 s for all 26 915).
#[test]
fn turning_on_the_spot_during_warm_up_does_not_set_the_step() {
    // The first 2000 poses of the Intel lab's wheel odometry: standing, a
    // short drive, a turn on the spot, then driving.
    let Some(path) = common::shared("carmen/intel_odom.csv") else {
        return;
    };
    let mut points = read_trajectory(&path, Format::Auto).unwrap().positions();
    points.truncate(2000);
    assert_eq!(points.len(), 2000);
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    for p in &points {
        d.push(&PoseInput::at(*p));
    }
    let step = d.params().expect("warm-up done").typical_step;
    let (_, summary) = d.finish();
    // The path's own typical step, from all of it, as the batch path sees it.
    let plane = turnprint::geometry::Plane::fit(&points);
    let xy: Vec<_> = points.iter().map(|p| plane.to_2d(p)).collect();
    let batch = turnprint::track::ChordParam::new(&xy).unwrap().typical_step;
    assert!(
        step > batch / 3.0 && step < 3.0 * batch,
        "warm-up step {step} against the path's {batch}"
    );
    let per_pose = summary.worker.history_bytes as f64 / summary.poses as f64;
    assert!(per_pose < 128.0, "{per_pose} bytes of history per pose");
}

/// KITTI 00 entered at a tenth of its speed: its first 250 frames ten
/// times as dense, then the drive as recorded. The warm-up chose the
/// smoothing on the slow start, a tenth of the later steps; each later step
/// then left its grid samples piled on one pose, and the rounding noise
/// between them counted as turning: 120° per pose, 31 kB of history per
/// pose, 141 s for 6 791 poses. The turning must stay that of the road.
#[test]
fn speeding_up_tenfold_after_the_warm_up_adds_no_turning() {
    let Some(gt) = kitti("00") else {
        return;
    };
    let frames = 1200;
    let mut slow: Vec<Vector3<f64>> = Vec::new();
    for w in gt[..251].windows(2) {
        slow.extend((0..10).map(|k| w[0] + (w[1] - w[0]) * (k as f64 / 10.0)));
    }
    slow.extend_from_slice(&gt[250..frames]);
    let (plain, slow) = (streamed(&gt[..frames]), streamed(&slow));
    let turning = |s: &turnprint::online::Summary| s.worker.sig_samples as f64;
    assert!(
        turning(&slow) < 1.5 * turning(&plain),
        "{} signature samples against {} at the recorded speed",
        turning(&slow),
        turning(&plain)
    );
}

/// A robot idling for minutes with 2 mm of jitter (5 000 poses), then KITTI
/// 00 as recorded. The warm-up ended on the jitter at `warmup_max_poses`,
/// its stationary threshold a millimetre: every jitter step was kept and
/// turned, 3.4 kB of history per pose, 1 400 poses/s. The warm-up now waits
/// for motion, and the threshold is taken by distance covered.
#[test]
fn idling_with_jitter_for_minutes_before_driving_adds_no_turning() {
    let Some(gt) = kitti("00") else {
        return;
    };
    let frames = 1200;
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut jitter = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.004
    };
    let mut idle: Vec<Vector3<f64>> = (0..5000)
        .map(|_| gt[0] + Vector3::new(jitter(), jitter(), jitter()))
        .collect();
    idle.extend_from_slice(&gt[..frames]);
    let (plain, idle) = (streamed(&gt[..frames]), streamed(&idle));
    assert!(
        (idle.worker.sig_samples as f64) < 1.5 * plain.worker.sig_samples as f64,
        "{} signature samples against {} without the idling",
        idle.worker.sig_samples,
        plain.worker.sig_samples
    );
    let per_pose = idle.worker.history_bytes as f64 / idle.poses as f64;
    assert!(per_pose < 128.0, "{per_pose} bytes of history per pose");
}

/// A stadium-shaped lap of 40 by 20 units (two straights, two half
/// circles), as a point at arc length `s` (any length: it goes round).
fn stadium(s: f64) -> Vector3<f64> {
    let (straight, r) = (20.0, 10.0);
    let half = std::f64::consts::PI * r;
    let s = s.rem_euclid(2.0 * (straight + half));
    let (x, y) = if s < straight {
        (s, -r)
    } else if s < straight + half {
        let a = (s - straight) / r;
        (straight + r * a.sin(), -r * a.cos())
    } else if s < 2.0 * straight + half {
        (2.0 * straight + half - s, r)
    } else {
        let a = (s - 2.0 * straight - half) / r;
        (-r * a.sin(), r * a.cos())
    };
    Vector3::new(x, y, 0.0)
}

/// A drone that sits on the ground creeping a 200th of its flying step per
/// pose through the warm-up, takes off (its step growing 200 times over
/// 1 000 poses), then flies three laps: UZH-FPV's flights. The warm-up took
/// the creep as the typical step, every flying step was a jump (92-96 % of
/// UZH-FPV's poses re-anchored, 0-2 candidates per flight) and the grid was
/// hundreds of times finer than the poses.
#[test]
fn taking_off_from_a_creep_makes_no_jumps() {
    let (fly, creep) = (0.1, 0.1 / 200.0);
    // The creep goes once round a small circle, so that the warm-up ends
    // on it (it spans a plane).
    let r = 400.0 * creep / std::f64::consts::TAU;
    let mut took_off: Vec<Vector3<f64>> = (0..400)
        .map(|i| {
            let a = i as f64 * creep / r;
            stadium(0.0) + r * Vector3::new(a.sin(), 1.0 - a.cos(), 0.0)
        })
        .collect();
    let mut s = 0.0;
    for d in (0..1000).map(|i| creep * 200f64.powf(i as f64 / 1000.0)) {
        took_off.push(stadium(s));
        s += d;
    }
    let laps = s + 3.0 * 2.0 * (20.0 + std::f64::consts::PI * 10.0);
    while s < laps {
        took_off.push(stadium(s));
        s += fly;
    }
    let flown: Vec<Vector3<f64>> = (0..(laps / fly) as usize)
        .map(|i| stadium(i as f64 * fly))
        .collect();
    let (flown, took_off) = (streamed(&flown), streamed(&took_off));
    assert_eq!(took_off.guards.jumps, 0);
    assert!(
        (took_off.worker.sig_samples as f64) < 1.5 * flown.worker.sig_samples as f64,
        "{} signature samples against {} flown throughout",
        took_off.worker.sig_samples,
        flown.worker.sig_samples
    );
    assert!(
        (took_off.worker.grid_samples as f64) < 4.0 * flown.worker.grid_samples as f64,
        "{} grid samples against {} flown throughout",
        took_off.worker.grid_samples,
        flown.worker.grid_samples
    );
}

/// UZH-FPV indoor forward 9 (motion capture, 500 Hz): the drone creeps on
/// the ground through the warm-up, then flies laps of a hall at 200 times
/// that step. 12 914 of its 14 400 poses were taken for jumps and one
/// candidate came, wrong. Its laps must now be found, most candidates
/// right (within a twentieth of the flight's extent, truth being the input).
#[test]
fn a_flight_that_starts_on_the_ground_is_not_taken_for_jumps() {
    let Some(path) = common::shared(
        "multisession/openvins_gt/uzhfpv_indoor/indoor_forward_9_snapdragon_with_gt.txt",
    ) else {
        return;
    };
    let points = read_trajectory(&path, Format::Auto).unwrap().positions();
    let (found, summary) = common::replayed(&points, OnlineConfig::default());
    assert!(
        summary.guards.jumps * 100 < summary.poses,
        "{} of {} poses taken for jumps",
        summary.guards.jumps,
        summary.poses
    );
    let radius = turnprint::geometry::extent(&points) / 20.0;
    let right = found
        .iter()
        .filter(|c| {
            let h = &c.hypothesis;
            let claim = turnprint_eval::checks::LoopClaim {
                query: h.a_range,
                matched: h.b_range,
                score: h.score,
            };
            turnprint_eval::checks::loop_correct(&claim, &points, radius)
        })
        .count();
    assert!(
        right >= 10 && 2 * right >= found.len(),
        "{right} of {} candidates right",
        found.len()
    );
}
