//! A 10-million-pose synthetic run (EVALUATION_ONLINE.md, "Memory"): push
//! latency per million poses stays flat and memory grows linearly.
//!
//! `cargo run --release --example online_long_run -- [POSES] [EVERY]`
//! (default 10 000 000 poses; `EVERY` = k keeps every k-th pose of the
//! drive, so each pose spans k times the road, as a 1 Hz GPS does against
//! 10 Hz odometry; default 1). `WORKERS=n` sets `OnlineConfig::workers`
//! (matching threads over the one history). Prints, per million poses: push p50/p99/max
//! (ns, measured around each push), the process's resident memory, and at
//! the end the detector's own count of history bytes per pose.

use std::time::Instant;

use turnprint::online::synthetic::CityDrive;
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};

fn rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

fn main() {
    let total: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let every: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
        .max(1);
    let chunk = 1_000_000.min(total);
    let rss0 = rss_bytes();
    let config = OnlineConfig {
        workers: std::env::var("WORKERS").map_or(1, |v| v.parse().expect("WORKERS")),
        ..OnlineConfig::default()
    };
    let mut d = Detector::new(config, Overflow::MergeLatest);
    let mut lat = Vec::with_capacity(chunk);
    let mut candidates = 0usize;
    let t0 = Instant::now();
    println!(
        "poses     push_p50_ns push_p99_ns push_max_ns  rss_MB  rss_bytes_per_pose  candidates"
    );
    for (i, p) in CityDrive::new(11).step_by(every).take(total).enumerate() {
        let t = Instant::now();
        d.push(&PoseInput::at(p));
        lat.push(t.elapsed().as_nanos() as u64);
        candidates += d.poll().len();
        if (i + 1) % chunk == 0 {
            lat.sort_unstable();
            let rss = rss_bytes().saturating_sub(rss0);
            println!(
                "{:9} {:11} {:11} {:11} {:7.1} {:19.1} {:11}",
                i + 1,
                lat[lat.len() / 2],
                lat[(lat.len() * 99) / 100],
                lat[lat.len() - 1],
                rss as f64 / 1e6,
                rss as f64 / (i + 1) as f64,
                candidates
            );
            lat.clear();
        }
    }
    let push_s = t0.elapsed().as_secs_f64();
    let (rest, s) = d.finish();
    candidates += rest.len();
    println!(
        "pushed {total} poses in {push_s:.1} s ({:.0} poses/s on the caller's thread); finish {:.1} s",
        total as f64 / push_s,
        t0.elapsed().as_secs_f64() - push_s
    );
    println!(
        "history: {} track samples, {} signature samples, {} bytes = {:.1} bytes/pose; worker: {} messages, {} segments, {} matched, {} skipped, {} probes, {} batches shared out; {} deferred sends; {candidates} candidates",
        s.worker.grid_samples,
        s.worker.sig_samples,
        s.worker.history_bytes,
        s.worker.history_bytes as f64 / total as f64,
        s.worker.messages,
        s.worker.segments,
        s.worker.matched,
        s.worker.skipped,
        s.worker.probes,
        s.worker.parallel_batches,
        s.deferred
    );
}
