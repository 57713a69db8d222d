//! Speed of the verifier link over iceoryx2 with the real `turnprint-verifier`
//! process, excluding vision work:
//! * candidate -> verdict round trip: the candidate names keyframes the
//!   verifier never received, so it answers "unknown keyframe" at once and the
//!   time is the transport (publish, wake-up, verdict, wake-up) alone;
//! * keyframe publish: loan, one write of a 1226x370 grey image into shared
//!   memory, send and notify.

use std::process::{Child, Command, Stdio};
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use turnprint_ipc::{CameraParams, Candidate, ClientConfig, VerifierClient};

struct Verifier(Child);

impl Drop for Verifier {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn roundtrip(c: &mut Criterion) {
    let prefix = format!("bench-roundtrip-{}", std::process::id());
    let _verifier = Verifier(
        Command::new(env!("CARGO_BIN_EXE_turnprint-verifier"))
            .args(["--prefix", &prefix, "--report-secs", "0"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .expect("start turnprint-verifier"),
    );
    let mut config = ClientConfig::new(&prefix);
    config.liveness_timeout = Duration::from_secs(5);
    let mut client = VerifierClient::new(config).expect("client");
    assert!(
        client.wait_for_verifier(Duration::from_secs(20)),
        "verifier did not start"
    );

    c.bench_function("ipc/candidate_to_verdict", |b| {
        b.iter(|| {
            let id = client.submit(Candidate::between(u64::MAX - 1, u64::MAX));
            loop {
                let out = client.wait(Duration::from_secs(1));
                assert!(!out.is_empty(), "no verdict within 1 s");
                if out.iter().any(|o| o.id() == id) {
                    break;
                }
            }
        })
    });

    let (width, height) = (1226u32, 370u32);
    let camera = CameraParams::pinhole(width, height, 707.0912, 707.0912, 601.8873, 183.1104);
    let image: Vec<u8> = (0..width * height).map(|i| (i % 251) as u8).collect();
    let mut id = 0u64;
    c.bench_function("ipc/keyframe_publish_1226x370", |b| {
        b.iter(|| {
            id += 1;
            client
                .publish_keyframe(id, id as f64, &camera, &image)
                .unwrap();
        })
    });
    let status = client.verifier_status().copied();
    eprintln!("verifier status after the benches: {status:?}");
}

// Plots need a system font the build machines lack; the numbers are what count.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = roundtrip
}
criterion_main!(benches);
