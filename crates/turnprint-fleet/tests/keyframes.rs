//! Keyframes between robots over real Zenoh sessions on loopback: one
//! served and fetched whole; a robot that serves garbage or a newer payload
//! version has it refused and counted; a robot that is not there leaves
//! the fetch with a reason, after the fetch timeout and no later.

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::{Matrix3, Vector3};
use turnprint::Hypothesis;
use turnprint_fleet::keyframe::Keyframe;
use turnprint_fleet::payload::Refusal;
use turnprint_fleet::payload::VERSION;
use turnprint_fleet::transport::{KeyframeSource, Transport, KEYFRAME_TIMEOUT};
use turnprint_fleet::verify::{fetcher, Request};
use turnprint_fleet::{CrossCandidate, Endpoints};

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Keyframe `pose` of a 4 x 3 camera.
fn keyframe(pose: u64) -> Keyframe {
    Keyframe {
        pose,
        t: pose as f64 * 0.1,
        camera_kind: 0,
        width: 4,
        height: 3,
        params: [2.0, 2.0, 1.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        image: (0..12).map(|v| v as u8 * 20).collect(),
    }
}

/// A cross-robot candidate against `robot` verified at its pose `theirs`.
fn candidate(robot: &str, theirs: usize) -> CrossCandidate {
    CrossCandidate {
        robot: robot.into(),
        epoch: 1,
        at_pose: 50,
        hypothesis: Hypothesis {
            rank: 1,
            score: 0.5,
            zncc: 0.9,
            reversed: false,
            a_range: [10, 30],
            b_range: [theirs - 10, theirs + 10],
            scale: 1.0,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            rmse: 0.1,
            turning: 1.0,
            length: 20.0,
            length_ratio: 1.0,
            correspondences: vec![(20, theirs)],
        },
    }
}

/// Two robots of one fleet: `b` serving keyframes from `source`, `a`
/// connected to it.
fn pair(fleet: &str, source: KeyframeSource) -> (Arc<Transport>, Transport) {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let (tx, _rx) = crossbeam::channel::unbounded();
    let served = Endpoints {
        listen: vec![endpoint.clone()],
        connect: Vec::new(),
    };
    let b = Transport::open(fleet, "b", &served, tx.clone()).expect("B's session");
    b.serve_keyframes(source).expect("serving keyframes");
    let joining = Endpoints {
        listen: Vec::new(),
        connect: vec![endpoint],
    };
    let a = Transport::open(fleet, "a", &joining, tx).expect("A's session");
    (Arc::new(a), b)
}

/// Fetches B's keyframe at pose `theirs` until the session has connected
/// (the first query may go out before it has).
fn fetch_until_connected(a: &Transport, theirs: u64) -> Result<Vec<u8>, String> {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let got = a.fetch_keyframe("b", theirs);
        if got.is_ok() || Instant::now() > deadline {
            return got;
        }
    }
}

#[test]
fn a_keyframe_is_served_and_fetched_whole() {
    let source: KeyframeSource = Arc::new(|pose| Some(keyframe(pose / 5 * 5).encode()));
    let (a, b) = pair(&format!("kf-whole-{}", std::process::id()), source);
    let got = fetch_until_connected(&a, 42).expect("B's keyframe");
    assert_eq!(Keyframe::decode(&got), Ok(keyframe(40)));
    assert_eq!(b.sent.keyframes.load(Ordering::Relaxed), 1);
    assert_eq!(
        b.sent.keyframe_bytes.load(Ordering::Relaxed),
        got.len() as u64
    );
}

#[test]
fn garbage_and_a_newer_version_are_refused_and_counted() {
    // B answers pose 1 with garbage, pose 2 with a newer version, and the
    // rest with a good keyframe.
    let source: KeyframeSource = Arc::new(|pose| match pose {
        1 => Some(b"not a keyframe".to_vec()),
        2 => {
            let mut newer = keyframe(2).encode();
            newer[4..6].copy_from_slice(&(VERSION + 1).to_le_bytes());
            Some(newer)
        }
        _ => Some(keyframe(pose).encode()),
    });
    let (a, _b) = pair(&format!("kf-garbage-{}", std::process::id()), source);
    fetch_until_connected(&a, 30).expect("the session connects");
    let (requests, answers, thread) = fetcher(a.clone());
    for (id, theirs) in [(0, 1), (1, 2), (2, 30)] {
        requests
            .send(Request {
                id,
                candidate: candidate("b", theirs),
            })
            .expect("a request");
    }
    drop(requests);
    let got: Vec<_> = answers.iter().collect();
    thread.join().expect("the fetcher ends");
    assert_eq!(got.len(), 3);
    for f in &got {
        match f.request.id {
            0 => assert!(
                f.keyframe.as_ref().is_err_and(|e| e.contains("garbage")),
                "{:?}",
                f.keyframe.as_ref().err()
            ),
            1 => assert!(
                f.keyframe.as_ref().is_err_and(|e| e.contains("version")),
                "{:?}",
                f.keyframe.as_ref().err()
            ),
            _ => assert_eq!(f.keyframe.as_ref().ok(), Some(&keyframe(30))),
        }
    }
    let refusals: Vec<_> = got.iter().map(|f| f.refused.clone()).collect();
    assert_eq!(refusals.iter().flatten().count(), 2);
    assert!(refusals
        .iter()
        .any(|r| matches!(r, Some(Refusal::Garbage(_)))));
    assert!(refusals.contains(&Some(Refusal::Version(VERSION + 1))));
}

#[test]
fn a_robot_that_is_gone_leaves_the_fetch_with_a_reason_within_the_timeout() {
    let source: KeyframeSource = Arc::new(|pose| Some(keyframe(pose).encode()));
    let (a, b) = pair(&format!("kf-gone-{}", std::process::id()), source);
    fetch_until_connected(&a, 5).expect("the session connects");
    drop(b);
    let t0 = Instant::now();
    let got = a.fetch_keyframe("b", 5);
    let took = t0.elapsed();
    assert!(
        got.as_ref().is_err_and(|e| e.contains("no keyframe")),
        "{got:?}"
    );
    assert!(
        took <= KEYFRAME_TIMEOUT + Duration::from_secs(2),
        "{took:?}"
    );
    // A robot never heard of: the same.
    assert!(a.fetch_keyframe("nobody", 5).is_err());
}
