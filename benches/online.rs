//! Speed of the online detector (EVALUATION_ONLINE.md, "Speed"):
//!
//! - `push`: one pose on the caller's thread over KITTI 00 (live policy,
//!   the worker running beside it); the bench also prints the latency
//!   histogram's p50/p99/max measured with `Instant` around each push;
//! - `match_segment_100k`: one newly finalised segment matched against a
//!   100 000-pose history (`kitti`: KITTI ground truth driven lap after lap;
//!   `city`: a synthetic city drive). Each iteration runs the queries of
//!   the newest N = 2..12 distinct consecutive segments, both directions,
//!   by piece correlation with the block spectra: the newest segment's
//!   piece is correlated inside the timing, the eleven before it come
//!   cached, as a detector holds them from their own segments. `_search`
//!   stops at the shape candidates, `_search_verify` adds their batch
//!   verification;
//! - `register_window_100k`: the network registration of the newest window
//!   over the same history, at its widest reach;
//! - `stream_kitti_00`: the whole of KITTI 00 pushed and finished, default
//!   settings (`_no_drift_probe`: without `OnlineConfig::drift_probe`).
//!
//! KITTI ground truth is read from the shared data, `kitti_gt/NN.txt` under
//! `$TURNPRINT_DATA` (default `../shared/data` beside the package); without
//! it the KITTI rows are skipped and the synthetic ones still run.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use nalgebra::Vector3;
use turnprint::io::{read_trajectory, Format};
use turnprint::online::correlator::LazyPiece;
use turnprint::online::frontend::{Frontend, Outbox};
use turnprint::online::register::{register, Bounds};
use turnprint::online::search::{verify_all, Frame};
use turnprint::online::synthetic::CityDrive;
use turnprint::online::worker::{Message, WorkerState};
use turnprint::online::{Detector, GuardCounts, OnlineConfig, Overflow, PoseInput};

/// The positions of KITTI ground truth sequence `name` from the shared
/// data, or `None` (said on stdout) when it is absent.
fn kitti_gt(name: &str) -> Option<Vec<Vector3<f64>>> {
    let dir = std::env::var_os("TURNPRINT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let path = dir.join("kitti_gt").join(format!("{name}.txt"));
    if !path.is_file() {
        println!(
            "skipped: KITTI ground truth {} not found (set TURNPRINT_DATA)",
            path.display()
        );
        return None;
    }
    let t =
        read_trajectory(&path, Format::Kitti).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Some(t.positions())
}

fn quantile(v: &[f64], q: f64) -> f64 {
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn push(c: &mut Criterion) {
    let Some(points) = kitti_gt("00") else {
        return;
    };
    // Latency histogram: every push of KITTI 00, 20 runs.
    let mut lat = Vec::with_capacity(points.len() * 20);
    for _ in 0..20 {
        let mut d = Detector::new(OnlineConfig::default(), Overflow::MergeLatest);
        for p in &points {
            let t = Instant::now();
            d.push(&PoseInput::at(*p));
            lat.push(t.elapsed().as_nanos() as f64);
            std::hint::black_box(d.poll());
        }
        d.finish();
    }
    lat.sort_by(f64::total_cmp);
    println!(
        "push latency over KITTI 00 x20 ({} pushes): p50 {:.0} ns, p90 {:.0} ns, p99 {:.0} ns, p99.9 {:.0} ns, max {:.0} ns",
        lat.len(),
        quantile(&lat, 0.5),
        quantile(&lat, 0.9),
        quantile(&lat, 0.99),
        quantile(&lat, 0.999),
        lat[lat.len() - 1]
    );
    let mut g = c.benchmark_group("online");
    g.throughput(Throughput::Elements(1));
    g.bench_function("push", |b| {
        let mut d = Detector::new(OnlineConfig::default(), Overflow::MergeLatest);
        let mut i = 0usize;
        // An endless path: KITTI 00 driven again and again, shifted.
        b.iter(|| {
            let lap = (i / points.len()) as f64;
            let p = points[i % points.len()] + Vector3::new(0.0, 0.0, 5000.0 * lap);
            i += 1;
            d.push(&PoseInput::at(p))
        });
        d.finish();
    });
    g.finish();
}

/// 100 000 poses of KITTI ground truth (00, 02, 05, 06, 08 driven one
/// after the other, each lap shifted by 5 km so laps do not overlap): a
/// realistic history, if the shared data holds them. The laps repeat, so
/// the newest segment has exact copies in the earlier ones: their
/// candidates pass the shape gates and grow over their whole windows
/// before the drift prior turns them away (they lie laps apart), which
/// makes this history's verification dearer than the city's.
fn kitti_100k() -> Option<Vec<Vector3<f64>>> {
    let laps = ["00", "02", "05", "06", "08"]
        .into_iter()
        .map(kitti_gt)
        .collect::<Option<Vec<_>>>()?;
    let mut out = Vec::with_capacity(100_000);
    let mut lap = 0.0;
    while out.len() < 100_000 {
        for t in &laps {
            let shift = Vector3::new(5000.0 * lap, 0.0, 0.0);
            let origin = out.last().copied().unwrap_or_else(Vector3::zeros);
            let first = t[0];
            out.extend(t.iter().map(|p| p - first + origin + shift));
            lap += 1.0;
        }
    }
    out.truncate(100_000);
    Some(out)
}

fn match_segment(c: &mut Criterion) {
    if let Some(points) = kitti_100k() {
        match_segment_on(c, "kitti", &points);
    }
    let city: Vec<_> = CityDrive::new(7).take(100_000).collect();
    match_segment_on(c, "city", &city);
}

fn match_segment_on(c: &mut Criterion, name: &str, points: &[Vector3<f64>]) {
    let config = OnlineConfig::default();
    let (mut counts, mut out) = (GuardCounts::default(), Outbox::default());
    let mut f = Frontend::Warmup(Vec::new());
    for (i, p) in points.iter().enumerate() {
        f.push(i, *p, &config, &mut counts, &mut out);
    }
    let params = *f.params().expect("warm-up done");
    let frame = Frame {
        plane: params.plane,
        step: params.grid_step,
        bandwidth: params.smoother.bandwidth,
        poses: points.len(),
    };
    let mut state = WorkerState::new(config.clone());
    // The whole history as one merged message: only its newest segment is
    // matched (and the last pieces cached).
    state.take(&Message {
        earlier: Vec::new(),
        out,
        at_pose: points.len() - 1,
        frame,
        merged: true,
    });
    let h = &state.history;
    println!(
        "{name} history: {} poses, {} track samples, {} signature samples, {} segments",
        points.len(),
        h.xy.len(),
        h.sig_value.len(),
        h.bounds.len()
    );
    // The pieces a detector holds when segment `k` is finalised: those of
    // segments k-keep+1..=k, all distinct. The older ones were correlated
    // by their own segments' matchings, so they are computed here, once;
    // the newest is made afresh for each iteration, outside the timing,
    // and correlated inside it, as its matching does.
    let k = state.history.bounds.len() - 1;
    let keep = config.pipeline.query.max_segments;
    state.searcher.pieces.clear();
    for j in k + 1 - keep..=k {
        state.searcher.add_piece(&state.history, j, keep);
    }
    let (searcher, history) = (&state.searcher, &state.history);
    let (newest, older) = searcher.pieces.split_last().expect("pieces");
    for p in older {
        p.get(&searcher.correlator, &history.sig_value);
    }
    let pieces = || {
        let mut pieces = older.to_vec();
        pieces.push(Arc::new(LazyPiece::new(
            newest.start,
            newest.len,
            history.sig_value.len(),
        )));
        pieces
    };
    let mut g = c.benchmark_group("online");
    g.measurement_time(Duration::from_secs(8));
    g.bench_function(format!("match_segment_100k_{name}_search"), |b| {
        b.iter_batched_ref(
            pieces,
            |pieces| searcher.shape_candidates(&history.now(), pieces, &config),
            BatchSize::SmallInput,
        )
    });
    g.bench_function(format!("match_segment_100k_{name}_search_verify"), |b| {
        b.iter_batched_ref(
            pieces,
            |pieces| {
                let h = &history.now();
                let shape = searcher.shape_candidates(h, pieces, &config);
                verify_all(h, &frame, &shape, None, &config)
            },
            BatchSize::SmallInput,
        )
    });
    // The network registration of the newest window at its widest reach:
    // as far from its start as KITTI 00's last revisit (3 km).
    let (h, spatial) = (
        &state.history.now(),
        state.searcher.spatial.as_ref().expect("indexed"),
    );
    let prior = config.pipeline.drift_prior.expect("loops prior");
    let g1 = h.xy.len() - 1;
    let g0 = g1 - 4 * config.probe_every;
    let length = h.s[g1] - h.s[g0];
    let bounds = Bounds::of_drift(
        &prior,
        config.drift_radius(),
        length,
        3000.0,
        spatial,
        frame.step,
    );
    g.bench_function(format!("register_window_100k_{name}"), |b| {
        b.iter(|| register(h, spatial, g0, g1, &bounds, &prior))
    });
    g.finish();
}

fn stream(c: &mut Criterion) {
    let Some(points) = kitti_gt("00") else {
        return;
    };
    let mut g = c.benchmark_group("online");
    g.throughput(Throughput::Elements(points.len() as u64));
    g.sample_size(20);
    for (name, drift_probe, workers) in [
        ("stream_kitti_00", true, 1),
        ("stream_kitti_00_two_workers", true, 2),
        ("stream_kitti_00_no_drift_probe", false, 1),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let config = OnlineConfig {
                    drift_probe,
                    workers,
                    ..Default::default()
                };
                let mut d = Detector::new(config, Overflow::Block);
                for p in &points {
                    d.push(&PoseInput::at(*p));
                }
                d.finish()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, push, match_segment, stream);
criterion_main!(benches);
