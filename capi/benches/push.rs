//! `tp_detector_push` through the C ABI (what a C or C++ caller pays per
//! pose), over KITTI 00 with the live policy; also prints the latency
//! histogram measured with `Instant` around each call, as the library's
//! own `push` bench does.

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use turnprint_c::{
    tp_detector_finish, tp_detector_free, tp_detector_new, tp_detector_poll, tp_detector_push,
    TpCandidate, TpPose,
};

/// KITTI 00's ground truth from the shared data, `None` when absent.
fn kitti_00() -> Option<Vec<[f64; 3]>> {
    let path = turnprint_eval::data::require("kitti_gt/00.txt")?;
    let points = turnprint::io::read_trajectory(&path, turnprint::io::Format::Kitti)
        .expect("kitti_gt/00.txt")
        .positions()
        .iter()
        .map(|p| [p.x, p.y, p.z])
        .collect();
    Some(points)
}

fn pose(position: [f64; 3]) -> TpPose {
    TpPose {
        t: 0.0,
        has_time: 0,
        position,
        keyframe: -1,
    }
}

fn push(c: &mut Criterion) {
    let Some(points) = kitti_00() else {
        return;
    };
    let mut polled = [TpCandidate::default(); 8];
    let mut lat = Vec::with_capacity(points.len() * 20);
    for _ in 0..20 {
        // SAFETY: a detector from `tp_detector_new`, freed once; valid
        // pointers to a pose and to 8 candidates.
        unsafe {
            let d = tp_detector_new(std::ptr::null());
            for p in &points {
                let t = Instant::now();
                tp_detector_push(d, &pose(*p));
                lat.push(t.elapsed().as_nanos() as f64);
                tp_detector_poll(d, polled.as_mut_ptr(), polled.len());
            }
            tp_detector_finish(d, std::ptr::null_mut());
            tp_detector_free(d);
        }
    }
    lat.sort_by(f64::total_cmp);
    let q = |q: f64| lat[((lat.len() - 1) as f64 * q).round() as usize];
    println!(
        "tp_detector_push latency over KITTI 00 x20: p50 {:.0} ns, p99 {:.0} ns, p99.9 {:.0} ns",
        q(0.5),
        q(0.99),
        q(0.999)
    );
    let mut g = c.benchmark_group("c_abi");
    g.throughput(Throughput::Elements(1));
    g.bench_function("push", |b| {
        // SAFETY: as above.
        let d = unsafe { tp_detector_new(std::ptr::null()) };
        let mut i = 0usize;
        // KITTI 00 again and again, each lap 5 km higher.
        b.iter(|| {
            let lap = (i / points.len()) as f64;
            let mut p = points[i % points.len()];
            p[2] += 5000.0 * lap;
            i += 1;
            // SAFETY: as above.
            unsafe { tp_detector_push(d, &pose(p)) }
        });
        // SAFETY: as above.
        unsafe {
            tp_detector_finish(d, std::ptr::null_mut());
            tp_detector_free(d);
        }
    });
    g.finish();
}

criterion_group!(benches, push);
criterion_main!(benches);
