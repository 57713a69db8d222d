//! Detector and the real `turnprint-verifier` process over iceoryx2: real KITTI
//! keyframes in, candidates out, verdicts back.

mod ipc_support;

use std::time::Duration;

use ipc_support::{client, collect, kitti06_pair, kitti_camera, unique_prefix, VerifierProcess};
use turnprint_ipc::payload::reason;
use turnprint_ipc::{Candidate, Outcome};

#[test]
fn overlapping_frames_are_confirmed_and_unknown_ones_rejected() {
    let Some((a, b)) = kitti06_pair() else {
        return;
    };
    let prefix = unique_prefix("roundtrip");
    let verifier = VerifierProcess::start(&prefix, &[]);
    let mut c = client(&prefix, Duration::from_secs(20), Duration::from_secs(2));
    assert!(
        c.wait_for_verifier(Duration::from_secs(20)),
        "no heartbeat; stderr:\n{}",
        verifier.stderr()
    );

    for (frame, img) in [(12, a), (13, b)] {
        let camera = kitti_camera(img.width, img.height);
        c.publish_keyframe(frame as u64, frame as f64 * 0.1, &camera, &img.pixels)
            .unwrap();
    }
    let mut hint = Candidate::between(13, 12);
    hint.query_pose = 13;
    hint.match_pose = 12;
    hint.score = 0.9;
    let same_place = c.submit(hint);
    let unknown = c.submit(Candidate::between(13, 999_999));

    let outcomes = collect(&mut c, 2, Duration::from_secs(20));
    assert_eq!(outcomes.len(), 2, "stderr:\n{}", verifier.stderr());
    for o in &outcomes {
        if o.id() == same_place {
            let Outcome::Confirmed {
                candidate,
                match_R_query,
                match_t_query,
                inliers,
                ..
            } = o
            else {
                panic!("frames 12 and 13 must be confirmed: {o:?}");
            };
            assert_eq!(*candidate, hint, "the caller gets its candidate back");
            assert!(*inliers >= 30, "{inliers} inliers");
            // One frame apart at ~12 m/s: almost no rotation, motion along the optical axis.
            let angle = ((match_R_query.trace() - 1.0) / 2.0)
                .clamp(-1.0, 1.0)
                .acos();
            assert!(
                angle.to_degrees() < 3.0,
                "rotation {:.2} deg",
                angle.to_degrees()
            );
            assert!((match_t_query.norm() - 1.0).abs() < 1e-6);
            assert!(match_t_query.z.abs() > 0.9, "direction {match_t_query:?}");
        } else {
            assert_eq!(o.id(), unknown);
            let Outcome::Rejected { reason_code, .. } = o else {
                panic!("a candidate naming an unknown keyframe must be rejected: {o:?}");
            };
            assert_eq!(*reason_code, reason::UNKNOWN_KEYFRAME, "{o:?}");
        }
    }
    assert_eq!(c.outstanding(), 0);
    // The heartbeat carries the verifier's counters.
    std::thread::sleep(Duration::from_millis(100));
    c.poll();
    let status = c.verifier_status().expect("status heartbeat");
    assert_eq!(status.keyframes_received, 2);
    assert_eq!(status.keyframes_added, 2);
    assert_eq!(status.candidates_received, 2);
    assert_eq!(status.verdicts_sent, 2);
    assert!(status.memory_bytes > 0);
}
