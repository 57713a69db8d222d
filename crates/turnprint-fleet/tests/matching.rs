//! The fleet's matching: robots' chunks handed over in memory, in the
//! order a live fleet interleaves them, and a late joiner's catch-up over
//! real Zenoh sessions on loopback.

use nalgebra::Vector3;
use turnprint::geometry::Similarity3;
use turnprint::online::frontend::Outbox;
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
use turnprint_fleet::fixture::{curvy_drive, random_similarity, Lcg};
use turnprint_fleet::history::{Encoder, RobotHistory};
use turnprint_fleet::payload::{Chunk, FrameInfo};
use turnprint_fleet::{CrossCandidate, Fleet};

/// The chunks of a robot driving `points`, one per hand-over with a new
/// segment, and the last.
fn chunks(points: &[Vector3<f64>], epoch: u64) -> Vec<Chunk> {
    let config = OnlineConfig::default();
    let mut d = Detector::new(config.clone(), Overflow::Block);
    let tap = d.tap_finalised();
    let mut enc = Encoder::new(epoch);
    let mut pending = Outbox::default();
    let mut out = Vec::new();
    let frame = |d: &Detector| {
        d.params().map(|p| FrameInfo {
            plane: p.plane,
            step: p.grid_step,
            bandwidth: p.smoother.bandwidth,
            dk: config.pipeline.signature.dk,
        })
    };
    let take = |pending: &mut Outbox| {
        for o in tap.try_iter() {
            pending.grid.extend(o.grid);
            pending.sig.extend(o.sig);
            pending.bounds.extend(o.bounds);
        }
    };
    for (i, p) in points.iter().enumerate() {
        d.push(&PoseInput {
            t: Some(i as f64),
            position: *p,
            orientation: None,
            keyframe: None,
        });
        take(&mut pending);
        if !pending.bounds.is_empty() {
            let f = frame(&d).expect("a frame once segments come");
            out.push(enc.chunk(&std::mem::take(&mut pending), d.poses(), f, false));
        }
    }
    let (f, n) = (frame(&d).expect("frame"), d.poses());
    let _ = d.finish();
    take(&mut pending);
    out.push(enc.chunk(&pending, n, f, true));
    out
}

/// Median distance, over `truth`'s points, between the estimate and the
/// true `own_T_other`, as a fraction of `common` (the common length).
fn error(est: &Similarity3, truth: &Similarity3, points: &[Vector3<f64>], common: f64) -> f64 {
    let mut d: Vec<f64> = points
        .iter()
        .map(|p| (est.apply(p) - truth.apply(p)).norm())
        .collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2] / common
}

/// Robot A driving the whole of a curvy drive and B its part from pose
/// `from` on, each under its own random similarity (`rng_seed`): the drive,
/// A's and B's frames, their paths.
#[allow(clippy::type_complexity)]
fn whole_and_tail(
    drive_seed: u64,
    rng_seed: u64,
    from: usize,
) -> (
    Vec<Vector3<f64>>,
    Similarity3,
    Similarity3,
    Vec<Vector3<f64>>,
    Vec<Vector3<f64>>,
) {
    let drive = curvy_drive(drive_seed, 2400);
    let mut rng = Lcg::new(rng_seed);
    let (ta, tb) = (random_similarity(&mut rng), random_similarity(&mut rng));
    let a: Vec<_> = drive.iter().map(|p| ta.apply(p)).collect();
    let b: Vec<_> = drive[from..].iter().map(|p| tb.apply(p)).collect();
    (drive, ta, tb, a, b)
}

/// A's own chunks `ca` and robot B's `cb` handed to `fleet` (robot A) as
/// a live fleet interleaves them, matched after each; every candidate.
fn interleaved(fleet: &mut Fleet, ca: &[Chunk], cb: &[Chunk]) -> Vec<CrossCandidate> {
    let mut found = Vec::new();
    let n = ca.len().max(cb.len());
    for i in 0..n {
        if let Some(c) = ca.get(i) {
            fleet.own_chunk(c).expect("own chunk");
        }
        if let Some(c) = cb.get(i) {
            fleet.receive("b", &c.encode());
        }
        found.extend(fleet.match_new(i + 1 == n));
    }
    found
}

/// How far `fleet` places robot B off its truth (`a_T_b = ta * tb⁻¹`), on
/// the drive's poses from `from` on, as a fraction of their length `common`
/// (drive units); panics when B is not placed.
fn b_error(
    fleet: &Fleet,
    drive: &[Vector3<f64>],
    ta: &Similarity3,
    tb: &Similarity3,
    from: usize,
    common: f64,
) -> f64 {
    let est = fleet.estimates();
    let b_est = est["b"].as_ref().expect("b merged");
    let truth = ta.compose(&tb.inverse());
    let points: Vec<_> = drive[from..].iter().map(|p| tb.apply(p)).collect();
    let e = error(&b_est.similarity, &truth, &points, common * ta.scale);
    eprintln!("b placed within {:.2} % of the common length", 100.0 * e);
    e
}

#[test]
fn two_robots_that_share_road_place_each_other_and_a_stranger_is_left_out() {
    let drive = curvy_drive(1, 2400);
    let stranger = curvy_drive(2, 1400);
    let mut rng = Lcg::new(7);
    let (ta, tb, ts) = (
        random_similarity(&mut rng),
        random_similarity(&mut rng),
        random_similarity(&mut rng),
    );
    let a: Vec<_> = drive[..1400].iter().map(|p| ta.apply(p)).collect();
    // B drives its part the other way.
    let b: Vec<_> = drive[1000..].iter().rev().map(|p| tb.apply(p)).collect();
    let s: Vec<_> = stranger.iter().map(|p| ts.apply(p)).collect();
    let (ca, cb, cs) = (chunks(&a, 1), chunks(&b, 2), chunks(&s, 3));
    let mut fleet = Fleet::new("a", 1);
    let t0 = std::time::Instant::now();
    let n = ca.len().max(cb.len()).max(cs.len());
    let mut candidates = 0;
    for i in 0..n {
        if let Some(c) = ca.get(i) {
            fleet.own_chunk(c).expect("own chunk");
        }
        for (robot, cs) in [("b", &cb), ("s", &cs)] {
            if let Some(c) = cs.get(i) {
                fleet.receive(robot, &c.encode());
            }
        }
        candidates += fleet.match_new(i + 1 == n).len();
    }
    eprintln!(
        "{} + {} + {} chunks, {candidates} candidates, {:.2} s",
        ca.len(),
        cb.len(),
        cs.len(),
        t0.elapsed().as_secs_f64()
    );
    let est = fleet.estimates();
    eprintln!("{}", fleet.robots_json());
    let b_est = est["b"].as_ref().expect("b merged");
    // a_T_b = ta * tb^-1 on B's points; common road: poses 1000..1400.
    let truth = ta.compose(&tb.inverse());
    let common: Vec<_> = drive[1000..1400].iter().map(|p| tb.apply(p)).collect();
    let e = error(&b_est.similarity, &truth, &common, 400.0 * ta.scale);
    eprintln!("b placed within {:.2} % of the common length", 100.0 * e);
    assert!(e < 0.03, "b misplaced by {e}");
    assert!(est["s"].is_none(), "the stranger was merged");
}

/// Windows of KITTI 00 (when the data is at hand): every hypothesis each
/// robot finds of the others, with its error. A diagnostic, not a check.
#[test]
#[ignore]
fn kitti_hypotheses() {
    let Ok(dir) = std::env::var("KITTI_GT") else {
        eprintln!("skipped: set KITTI_GT to the folder of KITTI's ground truth (00.txt)");
        return;
    };
    let t = turnprint::io::read_trajectory(
        std::path::Path::new(&dir).join("00.txt").as_ref(),
        turnprint::io::Format::Kitti,
    )
    .expect("KITTI 00");
    let p = t.positions();
    let (mut wrong, mut right): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for seed in 1..=4u64 {
        let mut rng = Lcg::new(seed);
        let windows = match seed % 2 {
            1 => [(0usize, 1600usize), (1200, 2800), (2800, 4500)],
            _ => [(500, 2000), (1800, 3300), (3000, 4540)],
        };
        let frames: Vec<Similarity3> = windows
            .iter()
            .map(|_| random_similarity(&mut rng))
            .collect();
        let paths: Vec<Vec<Vector3<f64>>> = windows
            .iter()
            .zip(&frames)
            .map(|(w, f)| p[w.0..w.1].iter().map(|q| f.apply(q)).collect())
            .collect();
        let chunks: Vec<Vec<Chunk>> = paths
            .iter()
            .enumerate()
            .map(|(i, x)| chunks(x, i as u64))
            .collect();
        for own in 0..3 {
            let mut fleet = Fleet::new(&own.to_string(), own as u64);
            let n = chunks.iter().map(Vec::len).max().unwrap_or(0);
            for i in 0..n {
                if let Some(c) = chunks[own].get(i) {
                    fleet.own_chunk(c).expect("own");
                }
                for other in (0..3).filter(|&o| o != own) {
                    if let Some(c) = chunks[other].get(i) {
                        fleet.receive(&other.to_string(), &c.encode());
                    }
                }
                for c in fleet.match_new(i + 1 == n) {
                    let other: usize = c.robot.parse().expect("index");
                    let truth = frames[own].compose(&frames[other].inverse());
                    let h = &c.hypothesis;
                    let pts: Vec<_> = (h.b_range[0]..=h.b_range[1])
                        .map(|j| paths[other][j])
                        .collect();
                    let e = error(&h.similarity(), &truth, &pts, 1.0) / frames[own].scale;
                    eprintln!(
                    "{own} <- {other}: score {:.3} a {:?} b {:?} rev {} median error {:.1} m, length {:.0}",
                    h.score, h.a_range, h.b_range, h.reversed, e, h.length
                );
                }
            }
            for other in (0..3).filter(|&o| o != own) {
                let truth = frames[own].compose(&frames[other].inverse());
                let mut hs = fleet.hypotheses(&other.to_string()).to_vec();
                hs.sort_by(|x, y| y.score.total_cmp(&x.score));
                for h in hs.iter() {
                    let pts: Vec<_> = (h.b_range[0]..=h.b_range[1])
                        .map(|j| paths[other][j])
                        .collect();
                    let e = error(&h.similarity(), &truth, &pts, 1.0) / frames[own].scale;
                    match e < 20.0 {
                        true => right.push(h.score),
                        false => wrong.push(h.score),
                    }
                    eprintln!(
                        "  found {own} <- {other}: score {:.3} a {:?} b {:?} error {e:.1} m",
                        h.score, h.a_range, h.b_range
                    );
                }
                if let Some(Some(est)) = fleet.estimates().get(&other.to_string()) {
                    let pts = &paths[other];
                    let e = error(&est.similarity, &truth, pts, 1.0) / frames[own].scale;
                    eprintln!(
                        "  estimate {own} <- {other}: score {:.3} error {e:.1} m",
                        est.score
                    );
                }
            }
            eprintln!("{own}: {}", fleet.robots_json());
        }
    }
    wrong.sort_by(|x, y| y.total_cmp(x));
    right.sort_by(|x, y| y.total_cmp(x));
    eprintln!("wrong: {:?}", &wrong[..wrong.len().min(12)]);
    eprintln!("right: {:?}", &right[..right.len().min(40)]);
}

/// Asserts that `part` holds exactly `whole` from where it starts
/// (`part.dropped()`), its indices shifted; returns the boundaries of
/// `whole` before it.
fn tail_of(part: &RobotHistory, whole: &RobotHistory) -> usize {
    let d = part.dropped();
    let (w, h) = (&whole.history, &part.history);
    assert_eq!(h.xy, w.xy[d.grid..]);
    assert_eq!(h.s, w.s[d.grid..]);
    assert_eq!(h.pose, w.pose[d.grid..]);
    assert_eq!(h.curvature, w.curvature[d.grid..]);
    assert_eq!(h.sig_value, w.sig_value[d.sig..]);
    let shifted: Vec<f64> = w.sig_grid[d.sig..]
        .iter()
        .map(|g| g - d.grid as f64)
        .collect();
    assert_eq!(h.sig_grid, shifted);
    let from = w.bounds.partition_point(|&b| b < d.sig);
    let bounds: Vec<usize> = w.bounds[from..].iter().map(|b| b - d.sig).collect();
    assert_eq!(h.bounds, bounds);
    from
}

/// A history past its budget holds exactly the newer part of the history
/// it would hold without one: the same samples, its indices shifted by
/// what it dropped, and the robot's own segment count.
#[test]
fn a_history_past_its_budget_holds_the_tail_of_the_whole() {
    let drive = curvy_drive(3, 2400);
    let cs = chunks(&drive, 1);
    let budget = 96 << 10;
    let (mut whole, mut held) = (RobotHistory::default(), RobotHistory::with_budget(budget));
    let mut most = 0;
    for c in &cs {
        whole.apply(c).expect("whole");
        held.apply(c).expect("held");
        most = most.max(held.history.bytes());
    }
    let d = held.dropped();
    eprintln!(
        "whole {} B, held {} B (at most {most} B), dropped {d:?}",
        whole.history.bytes(),
        held.history.bytes()
    );
    assert!(
        whole.history.bytes() > 2 * budget,
        "the drive fits the budget"
    );
    assert!(most <= budget, "{most} B held over a budget of {budget} B");
    assert!(d.bounds > 0 && d.grid > 0 && d.sig > 0, "nothing dropped");
    assert_eq!(tail_of(&held, &whole), d.bounds);
    assert_eq!(held.segments(), whole.segments());
    assert_eq!(held.length(), whole.length());
    // A window of held segments is the whole's window of the same segments.
    let k = whole.segments() - 6;
    let (a, b) = (
        held.window_from(k).expect("held window"),
        whole.window_from(k).expect("whole window"),
    );
    assert_eq!(a.track.s, b.track.s);
    assert_eq!(a.signature.value, b.signature.value);
}

/// A robot whose history outgrows the budget still places another that
/// shares the part it holds, and its memory stays within the budget.
#[test]
fn a_robot_past_its_history_budget_still_places_the_other() {
    // A drives the whole; B its last 1000 poses: A's first half is dropped.
    let (drive, ta, tb, a, b) = whole_and_tail(1, 11, 1400);
    let (ca, cb) = (chunks(&a, 1), chunks(&b, 2));
    let budget = 96 << 10;
    let mut fleet = Fleet::with_budget("a", 1, budget);
    let mut most = 0;
    for i in 0..ca.len().max(cb.len()) {
        if let Some(c) = ca.get(i) {
            fleet.own_chunk(c).expect("own chunk");
        }
        if let Some(c) = cb.get(i) {
            fleet.receive("b", &c.encode());
        }
        fleet.match_new(i + 1 == ca.len().max(cb.len()));
        most = most.max(fleet.own().history.bytes());
    }
    eprintln!("{}", fleet.stats_json());
    assert!(fleet.own().dropped().bounds > 0, "A dropped nothing");
    assert!(most <= budget, "{most} B held over a budget of {budget} B");
    let e = b_error(&fleet, &drive, &ta, &tb, 1400, 1000.0);
    assert!(e < 0.03, "b misplaced by {e}");
}

/// A confirmation of a candidate found in an earlier session of a robot
/// (before it restarted) is ignored; one of its current session counts,
/// and vouches for the placement that lays its place together, not for its
/// own similarity (here moved far off).
#[test]
fn a_confirmation_from_a_robots_earlier_session_is_ignored() {
    let (drive, ta, tb, a, b) = whole_and_tail(1, 11, 1400);
    let (ca, cb) = (chunks(&a, 1), chunks(&b, 2));
    let mut fleet = Fleet::new("a", 1);
    let found = interleaved(&mut fleet, &ca, &cb);
    let right = b_error(&fleet, &drive, &ta, &tb, 1400, 1000.0);
    assert!(right < 0.03, "b misplaced by {right}");
    let confirmed = |fleet: &Fleet| fleet.estimates()["b"].as_ref().map(|e| e.confirmed);
    assert_eq!(confirmed(&fleet), Some(0));
    // A true candidate (its middle correspondence one place of the drive:
    // B's pose m is the drive's 1400 + m), moved far off.
    let mut off = found
        .iter()
        .find(|c| {
            let h = &c.hypothesis;
            let (q, m) = h.correspondences[h.correspondences.len() / 2];
            q.abs_diff(m + 1400) <= 5
        })
        .expect("a true cross candidate")
        .clone();
    off.hypothesis.translation += Vector3::new(1e4, 0.0, 0.0);
    off.epoch = 1;
    fleet.confirm(&off);
    assert_eq!(confirmed(&fleet), Some(0), "a stale confirmation counted");
    assert_eq!(b_error(&fleet, &drive, &ta, &tb, 1400, 1000.0), right);
    off.epoch = 2;
    fleet.confirm(&off);
    assert_eq!(confirmed(&fleet), Some(1));
    let e = b_error(&fleet, &drive, &ta, &tb, 1400, 1000.0);
    assert!(e < 0.03, "b misplaced by {e} after the confirmation");
}

/// A peer whose payloads arrive corrupted (bytes flipped, cut short, a
/// chunk repeated or skipped) after an intact start of its session, to a
/// robot whose histories are past their budget: every payload is taken in,
/// ignored or refused with a reason, never a panic, and the robot still
/// places the other once an intact session of it arrives.
#[test]
fn corrupted_payloads_past_the_budget_are_refused_not_a_panic() {
    let (drive, ta, tb, a, b) = whole_and_tail(5, 17, 1000);
    let mut rng = Lcg::new(19);
    let ca = chunks(&a, 1);
    let mut fleet = Fleet::with_budget("a", 1, 64 << 10);
    for c in &ca {
        fleet.own_chunk(c).expect("own chunk");
    }
    let mut outcomes = std::collections::BTreeMap::<&str, usize>::new();
    let mut dropped = 0;
    for round in 0..200u64 {
        // A new session of B each round: its chunks intact up to `k`.
        let cb = chunks(&b, 100 + round);
        let k = (rng.next_f64() * cb.len() as f64) as usize % cb.len();
        for c in &cb[..k] {
            fleet.receive("b", &c.encode());
        }
        // The next chunk, the last one again, or one ahead.
        let at = match round % 3 {
            0 => k,
            1 => k.saturating_sub(1),
            _ => k + 2,
        }
        .min(cb.len() - 1);
        let mut bytes = cb[at].encode();
        match round % 5 {
            0 | 1 => {
                for _ in 0..1 + round % 3 {
                    let i = (rng.next_f64() * bytes.len() as f64) as usize % bytes.len();
                    bytes[i] ^= 1 << (round % 8);
                }
            }
            2 => bytes.truncate((rng.next_f64() * bytes.len() as f64) as usize),
            // Intact: repeated, next or ahead.
            _ => {}
        }
        let outcome = match fleet.receive("b", &bytes) {
            turnprint_fleet::Received::Applied => "applied",
            turnprint_fleet::Received::Ignored => "ignored",
            turnprint_fleet::Received::CatchUp => "catch-up",
            turnprint_fleet::Received::Refused(_) => "refused",
        };
        *outcomes.entry(outcome).or_default() += 1;
        let stats = fleet.stats_json();
        dropped += stats["peers"]["b"]["dropped_segments"]
            .as_u64()
            .unwrap_or(0)
            .min(1);
        if round % 10 == 0 {
            fleet.match_new(true);
        }
    }
    eprintln!(
        "{outcomes:?}, refused {:?}, B's history past the budget in {dropped} rounds",
        fleet.refused()
    );
    for o in ["applied", "ignored", "refused"] {
        assert!(
            outcomes.get(o).is_some_and(|&n| n > 0),
            "no payload {o}: {outcomes:?}"
        );
    }
    assert!(dropped > 0, "B's history never passed the budget");
    assert!(fleet.own().dropped().bounds > 0, "A dropped nothing");
    // An intact new session of B, in order.
    let cb = chunks(&b, 1000);
    for (i, c) in cb.iter().enumerate() {
        fleet.receive("b", &c.encode());
        fleet.match_new(i + 1 == cb.len());
    }
    let e = b_error(&fleet, &drive, &ta, &tb, 1000, 1400.0);
    assert!(e < 0.03, "b misplaced by {e}");
}

/// A history joined late (the robot no longer serves its first chunks)
/// holds exactly the whole history from the first kept track sample of
/// the first chunk it was given: the same samples, its indices shifted.
#[test]
fn a_history_joined_late_holds_the_whole_from_its_first_chunk() {
    let cs = chunks(&curvy_drive(3, 2400), 1);
    let mut whole = RobotHistory::default();
    for c in &cs {
        whole.apply(c).expect("whole");
    }
    for k in [1, cs.len() / 3, cs.len() / 2] {
        let mut late = RobotHistory::joining_late(turnprint_fleet::history::HISTORY_BUDGET);
        for c in &cs[k..] {
            late.apply(c).expect("late");
        }
        assert_eq!(
            late.dropped().grid,
            cs[k].kept[0].index as usize,
            "chunk {k}"
        );
        let from = tail_of(&late, &whole);
        assert_eq!(late.segments(), whole.segments() - from);
        assert!(late.window_from(0).is_some());
    }
}

/// A robot that needs chunks the other no longer serves (its store is
/// bounded) starts the other's history at the first chunk served, the
/// status telling where, and still places it by the road they share.
#[test]
fn a_robot_missing_chunks_no_longer_served_starts_at_the_first_served() {
    let (drive, ta, tb, a, b) = whole_and_tail(1, 11, 1000);
    let (ca, cb) = (chunks(&a, 1), chunks(&b, 2));
    let first = cb.len() / 3;
    let mut fleet = Fleet::new("a", 1);
    for c in &ca {
        fleet.own_chunk(c).expect("own chunk");
    }
    fleet.own_ended();
    // A live chunk arrives before the status: it waits for the earlier.
    let live = cb.len() - 2;
    assert_eq!(
        fleet.receive("b", &cb[live].encode()),
        turnprint_fleet::Received::CatchUp
    );
    // The catch-up's answer: the status, then the chunks served.
    let status = turnprint_fleet::payload::encode_status(2, cb.len() as u32, first as u32);
    assert_eq!(
        fleet.receive("b", &status),
        turnprint_fleet::Received::CatchUp
    );
    for c in &cb[first..] {
        fleet.receive("b", &c.encode());
    }
    fleet.match_new(true);
    let stats = fleet.stats_json();
    eprintln!("{stats}");
    let peer = &stats["peers"]["b"];
    assert_eq!(peer["started_at_chunk"], first);
    assert_eq!(peer["chunks"], cb.len());
    assert_eq!(peer["ended"], true);
    // Placed by the part of B it holds (B's poses of its later part).
    let held_from = 1000 + b.len() / 3;
    let common = (drive.len() - held_from) as f64;
    let e = b_error(&fleet, &drive, &ta, &tb, held_from, common);
    assert!(e < 0.03, "b misplaced by {e}");
    // A status that says nothing new changes nothing.
    assert_eq!(
        fleet.receive("b", &status),
        turnprint_fleet::Received::Ignored
    );
}

/// A free TCP port on loopback.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Over real Zenoh sessions: robot B publishes its whole drive with its
/// served history bounded to a third of its chunks' bytes; robot A joins
/// after B's drive, asks for B's history and gets the status and the
/// chunks served: it starts B's history at the first chunk served and
/// places B by the road they share. B's store stays within its budget.
#[test]
fn a_late_joiner_catches_up_from_a_bounded_store_over_zenoh() {
    use turnprint_fleet::transport::Transport;
    use turnprint_fleet::Endpoints;
    let (drive, ta, tb, a, b) = whole_and_tail(1, 11, 1000);
    let (ca, cb) = (chunks(&a, 1), chunks(&b, 2));
    let total: usize = cb.iter().map(|c| c.encode().len()).sum();
    let budget = total / 3;
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let fleet_name = format!("late-{}", std::process::id());
    let (tx_b, _rx_b) = crossbeam::channel::unbounded();
    let served = Endpoints {
        listen: vec![endpoint.clone()],
        connect: Vec::new(),
    };
    let robot_b = Transport::open(&fleet_name, "b", &served, tx_b).expect("B's session");
    robot_b.set_store_budget(budget);
    for c in &cb {
        robot_b.publish_chunk(c.encode()).expect("publishing");
        assert!(robot_b.stored_bytes() <= budget.max(c.encode().len()));
    }
    robot_b.publish_status(2).expect("status");
    let (tx_a, rx_a) = crossbeam::channel::unbounded();
    let joining = Endpoints {
        listen: Vec::new(),
        connect: vec![endpoint],
    };
    let robot_a = Transport::open(&fleet_name, "a", &joining, tx_a).expect("A's session");
    let mut fleet = Fleet::new("a", 1);
    for c in &ca {
        fleet.own_chunk(c).expect("own chunk");
    }
    fleet.own_ended();
    // Ask until B's history is in (the first query may go out before the
    // session has connected).
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let mut received = 0;
    while fleet.stats_json()["peers"]["b"]["ended"] != true {
        assert!(
            std::time::Instant::now() < deadline,
            "B's history never came"
        );
        robot_a.catch_up("b");
        while let Ok(m) = rx_a.recv_timeout(std::time::Duration::from_millis(500)) {
            assert_eq!(m.robot, "b");
            fleet.receive(&m.robot, &m.bytes);
            received += 1;
        }
    }
    fleet.match_new(true);
    let stats = fleet.stats_json();
    let first = stats["peers"]["b"]["started_at_chunk"]
        .as_u64()
        .expect("first");
    eprintln!(
        "B: {} chunks, {total} B, served {} B from chunk {first}; A received {received} payloads",
        cb.len(),
        robot_b.stored_bytes()
    );
    assert!(
        first > 0,
        "B served every chunk within a third of their bytes"
    );
    assert_eq!(stats["peers"]["b"]["chunks"], cb.len());
    let held_from = 1000 + (b.len() as u64 * first / cb.len() as u64) as usize;
    let common = (drive.len() - held_from) as f64;
    let e = b_error(&fleet, &drive, &ta, &tb, held_from, common);
    assert!(e < 0.03, "b misplaced by {e}");
}

/// A robot that creeps through its warm-up and then drives at twenty times
/// that step: its detector scales its grid step and bandwidth with the
/// speed, so its chunks' frames change within the session. The peer
/// refused every chunk after the change ("the robot's frame changed") and
/// never placed it.
#[test]
fn a_robot_that_speeds_up_after_its_warm_up_is_still_placed() {
    let (drive, ta, tb, a, b) = whole_and_tail(1, 7, 1000);
    // B first creeps once round a small circle (steps of a twentieth),
    // then drives its part.
    let creep = 0.05;
    let r = 400.0 * creep / std::f64::consts::TAU;
    let mut crept: Vec<Vector3<f64>> = (0..400)
        .map(|i| {
            let t = i as f64 * creep / r;
            tb.apply(&(drive[1000] + r * Vector3::new(t.sin(), 1.0 - t.cos(), 0.0)))
        })
        .collect();
    crept.extend(b);
    let (ca, cb) = (chunks(&a, 1), chunks(&crept, 2));
    let (first, last) = (cb[0].frame.step, cb[cb.len() - 1].frame.step);
    assert!(last > 8.0 * first, "B's grid step {first} -> {last}");
    let mut fleet = Fleet::new("a", 1);
    interleaved(&mut fleet, &ca, &cb);
    // B's road shared with A: poses 1000-2400 of the drive.
    assert!(b_error(&fleet, &drive, &ta, &tb, 1000, 1400.0) < 0.03);
}
