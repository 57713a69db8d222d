//! The detector's side with no verifier running at all: it must keep working
//! and end every candidate as expired with the reason "verifier absent".

mod ipc_support;

use std::collections::HashSet;
use std::time::{Duration, Instant};

use ipc_support::{client, collect, unique_prefix};
use turnprint_ipc::{CameraParams, Candidate, ExpiryReason, Outcome};

#[test]
fn without_a_verifier_every_candidate_expires_as_absent() {
    let prefix = unique_prefix("absent");
    let mut c = client(&prefix, Duration::from_secs(10), Duration::from_millis(200));
    // Keyframes still go out (nobody reads them) without error or blocking.
    let camera = CameraParams::pinhole(64, 48, 50.0, 50.0, 32.0, 24.0);
    let image = vec![128u8; 64 * 48];
    for k in 0..20 {
        c.publish_keyframe(k, k as f64 * 0.1, &camera, &image)
            .unwrap();
    }
    assert_eq!(c.stats().keyframes_sent, 20);

    let ids: Vec<u64> = (0..10)
        .map(|k| c.submit(Candidate::between(k + 1, k)))
        .collect();
    let unique: HashSet<u64> = ids.iter().copied().collect();
    assert_eq!(unique.len(), ids.len(), "candidate ids must be unique");

    let started = Instant::now();
    let outcomes = collect(&mut c, ids.len(), Duration::from_secs(3));
    // Decided by the liveness timeout (200 ms), long before the 10 s deadline.
    assert!(
        started.elapsed() < Duration::from_secs(2),
        "took {:?}",
        started.elapsed()
    );
    assert_eq!(outcomes.len(), ids.len());
    for o in &outcomes {
        match o {
            Outcome::Expired { reason, .. } => assert_eq!(*reason, ExpiryReason::VerifierAbsent),
            other => panic!("expected expiry, got {other:?}"),
        }
    }
    let got: HashSet<u64> = outcomes.iter().map(|o| o.id()).collect();
    assert_eq!(got, unique, "each candidate ends exactly once");

    // Once known absent, a new candidate is answered at once.
    let id = c.submit(Candidate::between(100, 101));
    let now = c.poll();
    assert_eq!(now.len(), 1);
    assert_eq!(now[0].id(), id);
    assert!(matches!(
        now[0],
        Outcome::Expired {
            reason: ExpiryReason::VerifierAbsent,
            ..
        }
    ));
    assert_eq!(c.outstanding(), 0);
    assert_eq!(c.stats().expired, 11);
}

#[test]
fn wait_never_blocks_longer_than_asked() {
    let prefix = unique_prefix("wait");
    let mut c = client(&prefix, Duration::from_secs(10), Duration::from_secs(10));
    c.submit(Candidate::between(1, 2));
    let started = Instant::now();
    let out = c.wait(Duration::from_millis(100));
    let took = started.elapsed();
    assert!(out.is_empty());
    assert!(
        took >= Duration::from_millis(100) && took < Duration::from_millis(400),
        "{took:?}"
    );
    assert!(!c.wait_for_verifier(Duration::from_millis(50)));
    assert_eq!(c.outstanding(), 1);
}
