//! Speed of the visual verifier and of the renderer at 640x480, one core
//! (OpenCV set to one thread).

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use turnprint_verifier::features::GrayImage;
use turnprint_verifier::matching::{DescriptorMatcher, MatchParams};
use turnprint_verifier::render::{on_road, render, World, WorldParams};
use turnprint_verifier::{CameraModel, OrbVerifier, VerifierParams};

const W: u32 = 640;
const H: u32 = 480;

/// KITTI 00 ground-truth camera poses from the shared data (`None`, after
/// a line saying the benchmark is skipped, when they are absent).
fn kitti00() -> Option<Vec<Isometry3<f64>>> {
    let file = turnprint_eval::data::require("kitti_gt/00.txt")?;
    let text = std::fs::read_to_string(file).expect("KITTI 00 ground truth");
    let poses = text
        .lines()
        .map(|line| {
            let v: Vec<f64> = line
                .split_whitespace()
                .map(|x| x.parse().expect("number"))
                .collect();
            let r = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
            Isometry3::from_parts(
                Translation3::new(v[3], v[7], v[11]),
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r)),
            )
        })
        .collect();
    Some(poses)
}

fn bench(c: &mut Criterion) {
    opencv::core::set_num_threads(1).expect("OpenCV threads");
    let Some(poses) = kitti00() else {
        return;
    };
    let positions: Vec<_> = poses.iter().map(|p| p.translation.vector).collect();
    let world = World::from_positions(&positions, WorldParams::default()).expect("world");
    let pinhole = CameraModel::standard_pinhole(W, H, 90f64.to_radians());
    let omni = CameraModel::standard_omni(W, H, 0.9, 200f64.to_radians());
    // A revisit of KITTI 00: frame 505 and frame 3496 are 2.8 m apart.
    let (a, b) = (on_road(&poses[505]), on_road(&poses[3496]));
    let image_a = render(&world, &pinhole, a, W, H);
    let image_b = render(&world, &pinhole, b, W, H);
    let image_c = render(&world, &omni, b, W, H);
    let mut verifier = OrbVerifier::new(VerifierParams::default()).expect("verifier");
    for (id, image, camera) in [
        (1, &image_a, pinhole),
        (2, &image_b, pinhole),
        (3, &image_c, omni),
    ] {
        verifier
            .add_keyframe(
                id,
                camera,
                GrayImage {
                    data: image,
                    width: W,
                    height: H,
                    stride: W,
                },
            )
            .expect("keyframe");
    }
    assert!(
        verifier.verify(1, 2).confirmed(),
        "bench pair must be a true revisit"
    );
    c.bench_function("verify pinhole-pinhole 640x480", |bench| {
        bench.iter(|| verifier.verify(1, 2))
    });
    c.bench_function("verify pinhole-omni 640x480", |bench| {
        bench.iter(|| verifier.verify(1, 3))
    });
    let matcher = DescriptorMatcher::new(MatchParams::default()).expect("matcher");
    let (fa, fb) = (
        verifier.features(1).expect("a").clone(),
        verifier.features(2).expect("b").clone(),
    );
    c.bench_function("match descriptors 640x480", |bench| {
        bench.iter(|| matcher.match_features(&fa, &fb).expect("match"))
    });
    let mut extract = OrbVerifier::new(VerifierParams::default()).expect("verifier");
    c.bench_function("add keyframe (ORB) 640x480", |bench| {
        bench.iter(|| {
            extract.add_keyframe(
                9,
                pinhole,
                GrayImage {
                    data: &image_a,
                    width: W,
                    height: H,
                    stride: W,
                },
            )
        })
    });
    let mut group = c.benchmark_group("render 640x480");
    group.sample_size(10);
    group.bench_function("pinhole", |bench| {
        bench.iter(|| render(&world, &pinhole, a, W, H))
    });
    group.bench_function("omni", |bench| {
        bench.iter(|| render(&world, &omni, a, W, H))
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
