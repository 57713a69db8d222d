//! Faults between the detector and the real `turnprint-verifier` process:
//! `kill -9` mid-run, restart under the same prefix, and a keyframe flood
//! through the memory cap.

mod ipc_support;

use std::collections::{HashMap, HashSet};
use std::time::{Duration, Instant};

use ipc_support::{
    client, collect, kitti06_pair, kitti_camera, unique_prefix, Gray, VerifierProcess,
};
use turnprint_ipc::{Candidate, ExpiryReason, Outcome, VerifierClient, VerifierStatus};

fn publish_pair(c: &mut VerifierClient, a: &Gray, b: &Gray) {
    let camera = kitti_camera(a.width, a.height);
    c.publish_keyframe(12, 1.2, &camera, &a.pixels).unwrap();
    c.publish_keyframe(13, 1.3, &camera, &b.pixels).unwrap();
}

/// Counts outcomes by kind and checks each id ended exactly once.
fn tally(ids: &[u64], outcomes: &[Outcome]) -> HashMap<String, usize> {
    let mut seen = HashSet::new();
    let mut kinds = HashMap::new();
    for o in outcomes {
        assert!(seen.insert(o.id()), "candidate {} ended twice", o.id());
        let kind = match o {
            Outcome::Confirmed { .. } => "confirmed".to_string(),
            Outcome::Rejected { reason, .. } => format!("rejected: {reason}"),
            Outcome::Expired { reason, .. } => format!("expired: {reason}"),
        };
        *kinds.entry(kind).or_insert(0) += 1;
    }
    let expected: HashSet<u64> = ids.iter().copied().collect();
    assert_eq!(seen, expected, "every candidate ends, none vanishes");
    kinds
}

#[test]
fn kill_9_expires_outstanding_and_a_restarted_verifier_resumes() {
    let prefix = unique_prefix("kill9");
    let Some((a, b)) = kitti06_pair() else {
        return;
    };
    let mut verifier = VerifierProcess::start(&prefix, &[]);
    // Long candidate timeout: what expires here expires because the verifier died.
    let mut c = client(&prefix, Duration::from_secs(60), Duration::from_millis(300));
    assert!(
        c.wait_for_verifier(Duration::from_secs(20)),
        "stderr:\n{}",
        verifier.stderr()
    );
    publish_pair(&mut c, &a, &b);

    let ids: Vec<u64> = (0..300)
        .map(|_| c.submit(Candidate::between(13, 12)))
        .collect();
    // Mid-run: some verdicts are in, most candidates are still queued.
    let mut outcomes = collect(&mut c, 1, Duration::from_secs(20));
    assert!(
        !outcomes.is_empty(),
        "no verdict; stderr:\n{}",
        verifier.stderr()
    );
    verifier.kill9();
    let killed_at = Instant::now();
    outcomes.extend(collect(
        &mut c,
        ids.len() - outcomes.len(),
        Duration::from_secs(5),
    ));
    assert!(
        killed_at.elapsed() < Duration::from_secs(2),
        "expiry took {:?}",
        killed_at.elapsed()
    );
    let kinds = tally(&ids, &outcomes);
    eprintln!("kill -9 after the first verdict: {kinds:?}");
    let gone = kinds.get("expired: verifier gone").copied().unwrap_or(0);
    assert!(gone > 0, "{kinds:?}");
    assert!(
        kinds.get("confirmed").copied().unwrap_or(0) > 0,
        "{kinds:?}"
    );
    assert_eq!(c.outstanding(), 0);

    // The detector keeps working with the verifier down.
    let lone = c.submit(Candidate::between(13, 12));
    let now = c.poll();
    assert!(
        matches!(now.as_slice(), [Outcome::Expired { id, reason: ExpiryReason::VerifierAbsent, .. }] if *id == lone)
    );

    // A new verifier under the same prefix comes up over the dead one's
    // leftovers and answers, without restarting the detector.
    let verifier2 = VerifierProcess::start(&prefix, &[]);
    assert!(
        c.wait_for_verifier(Duration::from_secs(20)),
        "restart; stderr:\n{}",
        verifier2.stderr()
    );
    publish_pair(&mut c, &a, &b);
    let fresh: Vec<u64> = (0..3)
        .map(|_| c.submit(Candidate::between(13, 12)))
        .collect();
    let after = collect(&mut c, fresh.len(), Duration::from_secs(20));
    let kinds = tally(&fresh, &after);
    assert_eq!(
        kinds.get("confirmed"),
        Some(&3),
        "{kinds:?}; stderr:\n{}",
        verifier2.stderr()
    );
}

#[test]
fn a_quick_restart_expires_the_old_instances_candidates_as_restarted() {
    let prefix = unique_prefix("restart");
    let Some((a, b)) = kitti06_pair() else {
        return;
    };
    let mut verifier = VerifierProcess::start(&prefix, &[]);
    // Liveness longer than the restart: the client sees a new instance, not silence.
    let mut c = client(&prefix, Duration::from_secs(60), Duration::from_secs(10));
    assert!(c.wait_for_verifier(Duration::from_secs(20)));
    let first = c.verifier_instance().unwrap();
    publish_pair(&mut c, &a, &b);
    let ids: Vec<u64> = (0..300)
        .map(|_| c.submit(Candidate::between(13, 12)))
        .collect();
    let mut outcomes = collect(&mut c, 1, Duration::from_secs(20));
    verifier.kill9();
    let _verifier2 = VerifierProcess::start(&prefix, &[]);
    outcomes.extend(collect(
        &mut c,
        ids.len() - outcomes.len(),
        Duration::from_secs(20),
    ));
    let kinds = tally(&ids, &outcomes);
    eprintln!("quick restart: {kinds:?}");
    assert!(
        kinds
            .get("expired: verifier restarted")
            .copied()
            .unwrap_or(0)
            > 0,
        "{kinds:?}"
    );
    let second = c.verifier_instance().expect("new instance heard");
    assert_ne!(first, second);
}

/// Waits until the verifier's heartbeat accounts for `n` keyframes.
fn settle(c: &mut VerifierClient, n: u64, limit: Duration) -> VerifierStatus {
    let end = Instant::now() + limit;
    loop {
        c.wait(Duration::from_millis(50));
        let s = *c.verifier_status().expect("status heartbeat");
        if s.keyframes_received + s.keyframes_dropped_queue >= n || Instant::now() > end {
            return s;
        }
    }
}

#[test]
fn a_keyframe_flood_keeps_memory_bounded_and_counts_drops() {
    let prefix = unique_prefix("flood");
    let Some((a, b)) = kitti06_pair() else {
        return;
    };
    let frames = [a, b];
    let camera = kitti_camera(frames[0].width, frames[0].height);
    let cap = 1u64 << 20;
    let verifier = VerifierProcess::start(&prefix, &["--max-memory-mb", "1"]);
    let mut c = client(&prefix, Duration::from_secs(30), Duration::from_secs(2));
    assert!(
        c.wait_for_verifier(Duration::from_secs(20)),
        "stderr:\n{}",
        verifier.stderr()
    );
    let rss_before = verifier.rss_bytes().unwrap();
    let mut rss_peak = rss_before;

    // A flood: 1000 real images (450 MB) as fast as the publisher writes them.
    let flood = 1000u64;
    for k in 0..flood {
        let img = &frames[(k % 2) as usize];
        c.publish_keyframe(k, k as f64 * 0.1, &camera, &img.pixels)
            .unwrap();
        if k % 50 == 0 {
            rss_peak = rss_peak.max(verifier.rss_bytes().unwrap());
        }
    }
    let after_flood = settle(&mut c, flood, Duration::from_secs(30));
    eprintln!("after the flood: {after_flood:?}");
    // Everything published is accounted for: processed or counted as dropped.
    assert_eq!(
        after_flood.keyframes_received + after_flood.keyframes_dropped_queue,
        flood
    );
    assert!(
        after_flood.keyframes_dropped_queue > flood / 2,
        "{after_flood:?}"
    );

    // Paced: each keyframe processed, 100 x about 23 kB of features through
    // a 1 MB cap.
    let paced = 100u64;
    for k in flood..flood + paced {
        let img = &frames[(k % 2) as usize];
        c.publish_keyframe(k, k as f64 * 0.1, &camera, &img.pixels)
            .unwrap();
        let s = settle(&mut c, k + 1, Duration::from_secs(10));
        assert!(s.memory_bytes <= cap, "{s:?}");
        rss_peak = rss_peak.max(verifier.rss_bytes().unwrap());
    }
    let status = *c.verifier_status().unwrap();
    eprintln!("after pacing: {status:?}, rss before {rss_before} peak {rss_peak}");
    assert_eq!(
        status.keyframes_received + status.keyframes_dropped_queue,
        flood + paced
    );
    assert!(status.keyframes_added >= paced, "{status:?}");
    // The features filled the cap and stayed under it: the paced
    // keyframes' features do not fit in 1 MB, so the least recently used
    // ones were evicted, and counted.
    assert!(
        status.memory_bytes > cap / 2 && status.memory_bytes <= cap,
        "{status:?}"
    );
    assert!(status.keyframes_evicted >= paced / 4, "{status:?}");
    // A candidate naming an evicted keyframe (the first paced one) ends
    // with that reason; the last one is still held.
    let id = c.submit(Candidate::between(flood + paced - 1, flood));
    let outcome = collect(&mut c, 1, Duration::from_secs(10));
    match outcome.as_slice() {
        [Outcome::Rejected {
            id: got,
            reason_code,
            reason,
            ..
        }] => {
            assert_eq!(*got, id);
            assert_eq!(
                *reason_code,
                turnprint_ipc::payload::reason::UNKNOWN_KEYFRAME
            );
            assert!(
                reason.contains(&format!("keyframe {flood} unknown")),
                "{reason}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(c.stats().keyframes_sent, flood + paced);
    assert_eq!(c.stats().keyframes_failed, 0);
    // Resident memory grows by the bounded queue and the capped features,
    // not with the 470 MB that went through.
    assert!(
        rss_peak < rss_before + (64 << 20),
        "rss {rss_before} -> {rss_peak}"
    );
    // The counts are reported on stderr too.
    std::thread::sleep(Duration::from_millis(1200));
    assert!(
        verifier.stderr().contains("dropped (queue)"),
        "{}",
        verifier.stderr()
    );
}

#[test]
fn sigterm_answers_queued_candidates_before_exit() {
    let prefix = unique_prefix("sigterm");
    let Some((a, b)) = kitti06_pair() else {
        return;
    };
    let mut verifier = VerifierProcess::start(&prefix, &[]);
    let mut c = client(&prefix, Duration::from_secs(60), Duration::from_secs(10));
    assert!(c.wait_for_verifier(Duration::from_secs(20)));
    publish_pair(&mut c, &a, &b);
    let ids: Vec<u64> = (0..300)
        .map(|_| c.submit(Candidate::between(13, 12)))
        .collect();
    let mut outcomes = collect(&mut c, 1, Duration::from_secs(20));
    let status = std::process::Command::new("kill")
        .args(["-TERM", &verifier.child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let exit = verifier.child.wait().unwrap();
    assert!(exit.success(), "{exit:?}; stderr:\n{}", verifier.stderr());
    outcomes.extend(collect(
        &mut c,
        ids.len() - outcomes.len(),
        Duration::from_secs(5),
    ));
    let kinds = tally(&ids, &outcomes);
    eprintln!("SIGTERM: {kinds:?}");
    // A clean exit answers what it will not verify instead of leaving it to expire.
    assert!(
        kinds
            .get("rejected: verifier shutting down")
            .copied()
            .unwrap_or(0)
            > 0,
        "{kinds:?}"
    );
    assert!(!kinds.keys().any(|k| k.starts_with("expired")), "{kinds:?}");
    assert!(
        verifier.stderr().contains("final:"),
        "{}",
        verifier.stderr()
    );
}

#[test]
fn a_slow_answer_expires_as_timeout_and_its_late_verdict_is_counted() {
    let prefix = unique_prefix("timeout");
    let Some((a, b)) = kitti06_pair() else {
        return;
    };
    let verifier = VerifierProcess::start(&prefix, &[]);
    // 50 ms per candidate: a backlog of real verifications cannot all make it.
    let mut c = client(&prefix, Duration::from_millis(50), Duration::from_secs(10));
    assert!(
        c.wait_for_verifier(Duration::from_secs(20)),
        "stderr:\n{}",
        verifier.stderr()
    );
    publish_pair(&mut c, &a, &b);
    let ids: Vec<u64> = (0..200)
        .map(|_| c.submit(Candidate::between(13, 12)))
        .collect();
    let outcomes = collect(&mut c, ids.len(), Duration::from_secs(5));
    let kinds = tally(&ids, &outcomes);
    eprintln!("50 ms timeout: {kinds:?}");
    assert!(
        kinds.get("expired: timeout").copied().unwrap_or(0) > 0,
        "{kinds:?}"
    );
    assert!(!kinds.keys().any(|k| k.contains("verifier")), "{kinds:?}");
    // The verifier still answers every candidate; answers after the deadline
    // are counted, not delivered twice.
    let end = Instant::now() + Duration::from_secs(60);
    while c.verifier_status().map_or(0, |s| s.verdicts_sent) < ids.len() as u64
        && Instant::now() < end
    {
        assert!(c.wait(Duration::from_millis(100)).is_empty());
    }
    c.wait(Duration::from_millis(100));
    let expired = kinds.get("expired: timeout").copied().unwrap_or(0) as u64;
    assert_eq!(c.stats().late_verdicts, expired, "{:?}", c.stats());
}
