//! Drift-correction speed: `correct` on KITTI 00's drifting MULLS estimate
//! end to end (loop search included) and the graph solve alone, and the
//! online detector's re-optimisation after one new loop on a 10 000-pose
//! drive whose earlier loops were kept before (`correct_again`), each also
//! with 2000 even nodes (the graph's former size) for comparison. Real data
//! from `TURNPRINT_DATA` (default `../shared/data`); those benches are
//! skipped with a message when it is absent.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use turnprint::correct::{correct, correct_again, correct_with_loops, CorrectConfig, LoopClosure};
use turnprint::io::{read_trajectory, Format};
use turnprint::online::synthetic::CityDrive;
use turnprint::{find_loops, Pose, Trajectory};

fn mulls_00() -> Option<Trajectory> {
    let dir = std::env::var("TURNPRINT_DATA").unwrap_or_else(|_| "../shared/data".into());
    let p = PathBuf::from(dir).join("odometry/kitti_mulls_dso/mulls_no_loop/00.txt");
    match read_trajectory(&p, Format::Kitti) {
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
    let Some(est) = mulls_00() else { return };
    let config = CorrectConfig::default();
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

/// A 10 000-pose synthetic city drive with a heading drift of 0.1° per
/// pose-length unit turned in slowly, so that its revisits are loops.
fn drifting_drive() -> Trajectory {
    let mut heading = 0.0f64;
    let mut prev = None;
    let mut at = nalgebra::Vector3::zeros();
    let poses = CityDrive::new(11)
        .take(10_000)
        .map(|p| {
            if let Some(q) = prev {
                let step: nalgebra::Vector3<f64> = p - q;
                heading += 2e-4;
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

fn bench_online(c: &mut Criterion) {
    let path = drifting_drive();
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
            "online re-optimisation after one new loop (10 000 poses, {} loops, {nodes} even nodes)",
            loops.len()
        );
        c.bench_function(&name, |b| {
            b.iter(|| correct_again(black_box(&path), &loops, &kept, &config).unwrap())
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench_batch, bench_online
}
criterion_main!(benches);
