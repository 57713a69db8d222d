//! Batch speed on this machine: `loops` on KITTI 00 (4541 poses) end to end,
//! and on five KITTI drives driven one after the other (17 k poses, 15 km:
//! the ZNCC search grows with the square of the length), `match` of two
//! 5000-pose paths, `match` of KITTI 00 against its 1 Hz GPS
//! (two sampling rates: matched twice), and, side by side, the FFT ZNCC
//! against the direct one on the same signature, and reading a generated
//! 30 000-point GPX track, and `merge` of 100 sessions of about 1 km
//! (windows of the eleven KITTI drives, each under its own similarity,
//! half of them driven the other way). The paths come from the
//! shared data (`turnprint_eval::data`); a bench whose file is absent says
//! so and is skipped.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use turnprint::io::{read_trajectory, Format};
use turnprint::matching::zncc::zncc_direct;
use turnprint::matching::Correlator;
use turnprint::pipeline::{find_loops, match_paths, merge_many, Config, PreparedPath};
use turnprint::Trajectory;

/// `file` of the shared data (e.g. `kitti_gt/00.txt`), or `None` after a
/// line saying it is skipped.
fn data(file: &str) -> Option<Trajectory> {
    let path = turnprint_eval::data::require(file)?;
    Some(read_trajectory(&path, Format::Auto).expect("the file reads"))
}

/// KITTI ground truth `name`.
fn kitti(name: &str) -> Option<Trajectory> {
    data(&format!("kitti_gt/{name}.txt"))
}

/// 5000 poses: KITTI 02 (4661 poses) continued by KITTI 00's first 339.
fn five_thousand() -> Option<Trajectory> {
    let mut t = kitti("02")?;
    let tail = kitti("00")?;
    let offset = t.poses.last().unwrap().position - tail.poses[0].position;
    t.poses.extend(
        tail.poses[..339]
            .iter()
            .map(|p| turnprint::Pose::at(p.position + offset)),
    );
    Some(t)
}

fn bench_loops(c: &mut Criterion) {
    let Some(a) = kitti("00") else {
        return;
    };
    let config = Config::for_loops();
    c.bench_function("loops KITTI 00 (4541 poses, end to end)", |b| {
        b.iter(|| find_loops(black_box(&a), &config).unwrap())
    });
}

/// KITTI 00, 02, 05, 06 and 08 driven one after the other, each drive
/// starting where the last one ended.
fn five_drives() -> Option<Trajectory> {
    let mut t = kitti("00")?;
    for name in ["02", "05", "06", "08"] {
        let next = kitti(name)?;
        let offset = t.poses.last().unwrap().position - next.poses[0].position;
        t.poses.extend(
            next.poses
                .iter()
                .map(|p| turnprint::Pose::at(p.position + offset)),
        );
    }
    Some(t)
}

fn bench_loops_long(c: &mut Criterion) {
    let Some(a) = five_drives() else {
        return;
    };
    let config = Config::for_loops();
    let mut group = c.benchmark_group("loops of five KITTI drives in a row");
    group.sample_size(10);
    group.bench_function("17135 poses, 15 km, end to end", |b| {
        b.iter(|| find_loops(black_box(&a), &config).unwrap())
    });
    group.finish();
}

fn bench_match(c: &mut Criterion) {
    let Some(a) = five_thousand() else {
        return;
    };
    let r = Rotation3::from_euler_angles(0.4, -0.9, 2.2);
    let mut pts: Vec<Vector3<f64>> = a
        .positions()
        .iter()
        .map(|p| 0.07 * (r * p) + Vector3::new(3.0, 1.0, -2.0))
        .collect();
    pts.reverse();
    let b = Trajectory::from_positions("b", &pts);
    assert_eq!((a.len(), b.len()), (5000, 5000));
    let config = Config::for_matching();
    c.bench_function("match 5000 x 5000 poses (end to end)", |bch| {
        bch.iter(|| match_paths(black_box(&a), black_box(&b), &config).unwrap())
    });
}

fn bench_match_gps(c: &mut Criterion) {
    let (Some(a), Some(b)) = (kitti("00"), data("gtsam_data/KittiGps_converted.txt")) else {
        return;
    };
    let config = Config::for_matching();
    c.bench_function("match KITTI 00 x its 1 Hz GPS (4541 x 470 poses)", |bch| {
        bch.iter(|| match_paths(black_box(&a), black_box(&b), &config).unwrap())
    });
}

fn bench_zncc(c: &mut Criterion) {
    let Some(a) = kitti("00") else {
        return;
    };
    let p = PreparedPath::new(&a, &Config::default()).unwrap();
    let sig = &p.signature.value;
    let query = &sig[200..400];
    let mut group = c.benchmark_group("ZNCC of a 200-sample query against KITTI 00's signature");
    // On the same footing as the direct sum, which has no set-up to share:
    // the FFT row with the signature's transform built every time. The
    // amortised row is what a search pays per query once the signature's
    // transform is shared by its queries.
    group.bench_function("FFT with its set-up", |b| {
        b.iter(|| Correlator::new(black_box(sig), 400).scores(black_box(query)))
    });
    let mut correlator = Correlator::new(sig, 400);
    group.bench_function("FFT, set-up shared", |b| {
        b.iter(|| correlator.scores(black_box(query)))
    });
    group.bench_function("direct", |b| {
        b.iter(|| zncc_direct(black_box(sig), black_box(query)))
    });
    group.finish();
}

/// Reading a GPX track of 30 000 points (a GPS watch's day, 3 MB),
/// generated: the reader must stay linear in the file's size.
fn bench_read_gpx(c: &mut Criterion) {
    let mut text = String::from("<?xml version=\"1.0\"?>\n<gpx version=\"1.1\"><trk><trkseg>\n");
    for i in 0..30_000 {
        let (lat, lon) = (
            48.0 + 1e-5 * i as f64,
            11.0 + 1e-5 * (i as f64 * 0.01).sin(),
        );
        text.push_str(&format!(
            "<trkpt lat=\"{lat:.7}\" lon=\"{lon:.7}\">\n  <ele>500.0</ele>\n  <time>2024-05-01T10:{:02}:{:02}Z</time>\n</trkpt>\n",
            (i / 60) % 60,
            i % 60
        ));
    }
    text.push_str("</trkseg></trk></gpx>\n");
    let name = std::path::Path::new("generated.gpx");
    c.bench_function("read_gpx_30k_points", |b| {
        b.iter(|| {
            turnprint::io::read_trajectory_from(black_box(text.as_bytes()), name, Format::Gpx)
                .expect("the generated track reads")
        })
    });
}

/// `n` sessions of about 1 km: windows at random places of the KITTI
/// drives taken in turn (90 % of a drive shorter than 1.1 km), each under
/// a random similarity, every other one reversed.
fn sessions(n: usize) -> Option<Vec<Trajectory>> {
    let drives: Vec<Vec<Vector3<f64>>> = (0..11)
        .map(|i| kitti(&format!("{i:02}")).map(|t| t.positions()))
        .collect::<Option<_>>()?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let windows = (0..n).map(|i| {
        let p = &drives[i % drives.len()];
        let arc = turnprint_eval::revisits::arc_lengths(p);
        let length = arc[arc.len() - 1];
        let want = 1000.0f64.min(0.9 * length);
        let start = rng.random_range(0.0..length - want);
        let (a, b) = (
            arc.partition_point(|&s| s < start),
            arc.partition_point(|&s| s < start + want),
        );
        let t = turnprint_eval::similarity::random_similarity(&mut rng, 500.0);
        let mut moved: Vec<_> = p[a..b].iter().map(|x| t.apply(x)).collect();
        if i % 2 == 1 {
            moved.reverse();
        }
        Trajectory::from_positions(format!("session {i}"), &moved)
    });
    Some(windows.collect())
}

fn bench_merge_many(c: &mut Criterion) {
    let Some(paths) = sessions(100) else {
        return;
    };
    let config = Config::for_matching();
    let mut group = c.benchmark_group("merge");
    group.sample_size(10);
    group.bench_function("merge 100 sessions of 1 km (end to end)", |b| {
        b.iter(|| merge_many(black_box(&paths), &config).unwrap())
    });
    group.finish();
}

criterion_group!(
    benches,
    bench_merge_many,
    bench_read_gpx,
    bench_loops,
    bench_loops_long,
    bench_match,
    bench_match_gps,
    bench_zncc
);
criterion_main!(benches);
