//! Drift-correction speed: `correct` on KITTI 00's drifting MULLS estimate
//! end to end (loop search included) and the graph solve alone, `correct`
//! on KITTI 09's truth (a Sim(3) graph of look-alikes, all turned away) and
//! on KITTI 08's monocular estimate (a Sim(3) graph keeping a loop), the
//! online detector's re-optimisation after one new loop on a 10 000-pose
//! drive whose earlier loops were tried before, from the correction before
//! it (`correct_again_from`), each also with 2000 even nodes (the graph's
//! former size) for comparison; the re-optimisation of a drone that laps a
//! hall, whose streamed candidates are loops by the dozen; and the latency
//! of `push` on the caller's thread while the correction's thread solves
//! (printed as a histogram).
//! Real data from `TURNPRINT_DATA` (default `../shared/data`); those benches
//! are skipped with a message when it is absent.

use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use turnprint::correct::{
    correct, correct_again_from, correct_with_loops, CorrectConfig, LoopClosure,
};
use turnprint::io::{read_trajectory, Format};
use turnprint::online::correction::LoopInput;
use turnprint::online::synthetic::CityDrive;
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
use turnprint::{find_loops, Pose, Trajectory};

fn kitti(file: &str) -> Option<Trajectory> {
    read(file, Format::Kitti)
}

fn read(file: &str, format: Format) -> Option<Trajectory> {
    let dir = std::env::var("TURNPRINT_DATA").unwrap_or_else(|_| "../shared/data".into());
    let p = PathBuf::from(dir).join(file);
    match read_trajectory(&p, format) {
        Ok(t) => Some(t),
        Err(_) => {
            eprintln!("skipped: {} is absent (set TURNPRINT_DATA)", p.display());
            None
        }
    }
}

fn loops_of(path: &Trajectory, config: &CorrectConfig) -> Vec<LoopClosure> {
    find_loops(path, &config.loops)
        .unwrap()
        .iter()
        .map(|h| LoopClosure::from_hypothesis(path, h).unwrap())
        .collect()
}

fn bench_batch(c: &mut Criterion) {
    let config = CorrectConfig::default();
    // A Sim(3) graph whose loops are all look-alikes, turned away.
    if let Some(truth) = kitti("kitti_gt/09.txt") {
        c.bench_function(
            "correct KITTI 09 truth (1591 poses, every loop wrong)",
            |b| b.iter(|| correct(black_box(&truth), &config).unwrap()),
        );
    }
    // A Sim(3) graph that keeps a loop: monocular scale drift.
    if let Some(mono) = read("kitti_orbslam2_vio/08_orbslam2_tum.txt", Format::Tum) {
        c.bench_function(
            "correct monocular ORB-SLAM2 08 (4069 poses, Sim(3), end to end)",
            |b| b.iter(|| correct(black_box(&mono), &config).unwrap()),
        );
    }
    let Some(est) = kitti("odometry/kitti_mulls_dso/mulls_no_loop/00.txt") else {
        return;
    };
    c.bench_function("correct MULLS 00 (4541 poses, end to end)", |b| {
        b.iter(|| correct(black_box(&est), &config).unwrap())
    });
    let loops = loops_of(&est, &config);
    for nodes in [config.max_nodes, 2000] {
        let config = CorrectConfig {
            max_nodes: nodes,
            ..config.clone()
        };
        c.bench_function(
            &format!("correct MULLS 00, graph only (10 loops, {nodes} even nodes)"),
            |b| b.iter(|| correct_with_loops(black_box(&est), &loops, &config).unwrap()),
        );
    }
}

/// A 10 000-pose synthetic city drive whose heading drifts by `rate`
/// radians a pose, so that its revisits are loops.
fn drifting_drive(rate: f64) -> Trajectory {
    let mut heading = 0.0f64;
    let mut prev = None;
    let mut at = nalgebra::Vector3::zeros();
    let poses = CityDrive::new(11)
        .take(10_000)
        .map(|p| {
            if let Some(q) = prev {
                let step: nalgebra::Vector3<f64> = p - q;
                heading += rate;
                let (s, c) = heading.sin_cos();
                at += nalgebra::Vector3::new(c * step.x - s * step.y, s * step.x + c * step.y, 0.0);
            }
            prev = Some(p);
            Pose::at(at)
        })
        .collect();
    Trajectory {
        source: "drive".into(),
        poses,
    }
}

/// Heading drift a pose of the re-optimisation's drives: 2e-4 rad (2 rad
/// over the drive), whose loops all end up turned away, and 2e-5 rad,
/// whose loops are kept.
const DRIFT_RATES: [f64; 2] = [2e-4, 2e-5];

fn bench_online(c: &mut Criterion) {
    for rate in DRIFT_RATES {
        bench_reoptimisation(c, rate);
    }
    bench_laps(c);
}

/// The last re-optimisation of UZH-FPV indoor forward 9 (motion capture,
/// 14 400 poses) streamed with correction: the candidates at the shape cut
/// of its second half (most of them the same laps found again) arrive
/// together after a correction with those of its first half, as in a
/// replay.
fn bench_laps(c: &mut Criterion) {
    let file = "multisession/openvins_gt/uzhfpv_indoor/indoor_forward_9_snapdragon_with_gt.txt";
    let Some(path) = read(file, Format::Tum) else {
        return;
    };
    let online = OnlineConfig::default();
    let mut detector = Detector::new(online.clone(), Overflow::Block);
    let mut events = Vec::new();
    for p in &path.poses {
        detector.push(&PoseInput::at(p.position));
        events.extend(detector.poll());
    }
    events.extend(detector.finish().0);
    let loops: Vec<LoopClosure> = events
        .iter()
        .filter(|e| e.hypothesis.score >= online.min_score)
        .filter_map(|e| LoopClosure::from_hypothesis(&path, &e.hypothesis).ok())
        .collect();
    let config = CorrectConfig {
        check_drift: false,
        ..CorrectConfig::default()
    };
    let half = loops.len() / 2;
    let before = correct_with_loops(&path, &loops[..half], &config).unwrap();
    let kept: Vec<bool> = before.loops.iter().map(|l| l.kept).collect();
    let name = format!(
        "reopt UZH-FPV forward 9, {} new loops, {} of {half} kept",
        loops.len() - half,
        kept.iter().filter(|k| **k).count()
    );
    c.bench_function(&name, |b| {
        b.iter(|| {
            correct_again_from(black_box(&path), &loops, &kept, Some(&before), &config).unwrap()
        })
    });
}

/// The re-optimisation after the newest loop of a drive drifting at `rate`.
fn bench_reoptimisation(c: &mut Criterion, rate: f64) {
    let path = drifting_drive(rate);
    let config = CorrectConfig::default();
    let loops = loops_of(&path, &config);
    if loops.is_empty() {
        eprintln!("skipped: the drive has no loop");
        return;
    }
    for nodes in [config.max_nodes, 2000] {
        let config = CorrectConfig {
            max_nodes: nodes,
            ..config.clone()
        };
        // The state before the newest loop arrived.
        let before = correct_with_loops(&path, &loops[..loops.len() - 1], &config).unwrap();
        let kept: Vec<bool> = before.loops.iter().map(|l| l.kept).collect();
        let name = format!(
            "reopt drift {rate:e}, {} of {} kept, {nodes} nodes",
            kept.iter().filter(|k| **k).count(),
            kept.len()
        );
        c.bench_function(&name, |b| {
            b.iter(|| {
                correct_again_from(black_box(&path), &loops, &kept, Some(&before), &config).unwrap()
            })
        });
    }
}

/// Pose period of the paced replay: 200 µs, 5000 poses a second (KITTI's
/// 10 Hz five hundred times over), so that the correction's thread, whose
/// solves take tens to hundreds of milliseconds, runs through most of the
/// drive.
const PACE: Duration = Duration::from_micros(200);

/// `push` latencies over MULLS 00 streamed with drift correction from its
/// candidates (the live policy, `Overflow::MergeLatest`), paced at [`PACE`]:
/// those of the pushes between the first candidate and the last
/// correction event, when the correction's thread has a solve running or
/// queued, and the count of corrections. Printed, not timed by criterion:
/// a p99 is the figure.
fn bench_push_while_correcting(_c: &mut Criterion) {
    let Some(est) = kitti("odometry/kitti_mulls_dso/mulls_no_loop/00.txt") else {
        return;
    };
    let points = est.positions();
    let (mut during, mut corrections) = (Vec::new(), 0usize);
    for _ in 0..5 {
        let mut d = Detector::new(OnlineConfig::default(), Overflow::MergeLatest)
            .with_correction(CorrectConfig::default(), LoopInput::Candidates);
        let mut lat = Vec::with_capacity(points.len());
        let (mut first_candidate, mut last_candidate, mut last_correction) = (None, 0, 0);
        let start = Instant::now();
        for (i, p) in points.iter().enumerate() {
            while start.elapsed() < PACE * i as u32 {
                std::hint::spin_loop();
            }
            let t = Instant::now();
            d.push(&PoseInput::at(*p));
            lat.push(t.elapsed().as_nanos() as f64);
            if !d.poll().is_empty() {
                first_candidate.get_or_insert(i);
                last_candidate = i;
            }
            let n = d.poll_corrections().len();
            if n > 0 {
                corrections += n;
                last_correction = i;
            }
        }
        // After the last candidate the correction's thread is busy to the
        // end of the pushes, or until its last event.
        if let Some(from) = first_candidate {
            let to = match last_correction > last_candidate {
                true => last_correction,
                false => lat.len() - 1,
            };
            during.extend_from_slice(&lat[from..=to]);
        }
        black_box(d.finish());
    }
    if during.is_empty() {
        println!("push while correcting: no candidate arrived");
        return;
    }
    during.sort_by(f64::total_cmp);
    let q = |f: f64| during[((during.len() - 1) as f64 * f).round() as usize];
    println!(
        "push while the correction solves, MULLS 00 x5 paced at {} µs ({} pushes, {} corrections): p50 {:.0} ns, p99 {:.0} ns, p99.9 {:.0} ns, max {:.0} ns",
        PACE.as_micros(),
        during.len(),
        corrections,
        q(0.5),
        q(0.99),
        q(0.999),
        during[during.len() - 1]
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench_batch, bench_online, bench_push_while_correcting
}
criterion_main!(benches);
