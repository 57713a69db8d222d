//! Streams KITTI paths through the online detector and scores the
//! candidates against ground truth (EVALUATION_ONLINE.md).
//!
//! Revisit: a pose within 8 m of a ground-truth pose at least 300 frames
//! earlier. Event: a run of revisit poses spanning at least 40 m of driving
//! (gaps under 20 frames bridged). A candidate is correct when the median
//! ground-truth distance from its query poses to the nearest pose of its
//! match range is at most 10 m. An event is detected when a correct
//! candidate whose query range overlaps the event arrives while the event
//! runs or within 40 m after it; the delay is the distance driven inside the
//! event before that candidate's `at_pose`.
//!
//! Usage: `cargo run --release --example evaluate_online -- [gt|orb|stereo|drift|strong] [SEQ...]`
//! (data from ../shared/data, or `DATA=dir`). `gt` streams the ground truth, `orb` the
//! monocular ORB-SLAM2 estimate (paired to GT frames by timestamp), `stereo`
//! the S-PTAM stereo estimate of KITTI 00 (one pose per frame, real drift,
//! no loop closure; 00 only), `drift`
//! the ground truth with added drift (heading random walk and scale drift),
//! `strong` the ground truth through the evaluation's strong drift model
//! (`eval::drift::DriftModel::strong`, seed `SEED`, default 1; `DRIFT_FACTOR=f`
//! makes both random walks f times as strong; `DRIFT_LOG_SCALE=x` then sets
//! the log-scale walk to x per sqrt(m)).
//! `MIN_SCORE=x` sets `OnlineConfig::min_score`, `DRIFT_MIN_SCORE=x`
//! `OnlineConfig::drift_min_score`; `DRIFT_PROBE=0` turns off
//! `OnlineConfig::drift_probe` (on by default); `WORKERS=n` sets
//! `OnlineConfig::workers` (the candidates are the same); `PRIOR_GATE=0` turns
//! off `OnlineConfig::prior_gate` (the candidates are the same).
//! `SIMILARITY=1` streams the input under a random similarity (scale
//! log-uniform in 0.01..100, any 3D rotation, a translation; drawn from
//! `SEED`, apart from the drift's draw); `REVERSE=1` streams it driven the
//! other way (events are then those of the reversed drive).

use std::path::Path;

use nalgebra::{Rotation3, Vector3};
use turnprint::io::{read_trajectory, Format};
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput};

/// The shared data, relative to the project root (`DATA=dir` to change).
fn data_dir() -> String {
    std::env::var("DATA").unwrap_or_else(|_| "../shared/data".into())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mode = args.first().cloned().unwrap_or_else(|| "gt".into());
    let seqs: Vec<String> = if args.len() > 1 {
        args[1..].to_vec()
    } else if mode == "stereo" {
        vec!["00".to_string()]
    } else {
        ["00", "02", "05", "06", "08"]
            .iter()
            .map(|s| s.to_string())
            .collect()
    };
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let drift_factor: f64 = std::env::var("DRIFT_FACTOR")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let log_scale: Option<f64> = std::env::var("DRIFT_LOG_SCALE")
        .ok()
        .and_then(|s| s.parse().ok());
    println!("mode {mode} (seed {seed}, factor {drift_factor} for strong drift, log-scale walk {log_scale:?})");
    let show_events = std::env::var("SCORES").is_ok();
    println!("seq  poses events detected  rate  delay_med_m delay_p90_m  cands correct share  push_p50_us push_p99_us  wall_s");
    let (mut ev_all, mut det_all, mut c_all, mut ok_all) = (0, 0, 0, 0);
    let mut delays_all = Vec::new();
    // (shape rival under the drift prior, if decided; detected) of every
    // event.
    let mut certified: Vec<(Option<bool>, bool)> = Vec::new();
    for seq in &seqs {
        let gt = read_trajectory(
            Path::new(&format!("{}/kitti_gt/{seq}.txt", data_dir())),
            Format::Kitti,
        )
        .expect("gt");
        let gt_xyz: Vec<Vector3<f64>> = gt.positions();
        // Input poses and the GT frame of each.
        let (input, frames): (Vec<Vector3<f64>>, Vec<usize>) = match mode.as_str() {
            "orb" => orb_paired(seq, gt_xyz.len()),
            "stereo" => {
                let path = format!("{}/evo/KITTI_{seq}_SPTAM.txt", data_dir());
                let stereo = read_trajectory(Path::new(&path), Format::Kitti).expect("S-PTAM");
                (stereo.positions(), (0..gt_xyz.len()).collect())
            }
            "drift" => (drifted(&gt_xyz), (0..gt_xyz.len()).collect()),
            "strong" => {
                use rand::SeedableRng;
                let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
                let mut model = turnprint_eval::drift::DriftModel::strong().scaled(drift_factor);
                if let Some(walk) = log_scale {
                    model = model.with_log_scale(walk);
                }
                (model.apply(&gt_xyz, &mut rng), (0..gt_xyz.len()).collect())
            }
            _ => (gt_xyz.clone(), (0..gt_xyz.len()).collect()),
        };
        // The whole input in another frame and scale (`SIMILARITY=1`) or
        // driven the other way (`REVERSE=1`): the detector knows neither.
        let (input, frames, g) = reframed(input, frames, &gt_xyz, seed);
        let mut config = OnlineConfig::default();
        if let Ok(v) = std::env::var("MIN_SCORE") {
            config.min_score = v.parse().expect("MIN_SCORE");
        }
        if let Ok(v) = std::env::var("DRIFT_MIN_SCORE") {
            config.drift_min_score = v.parse().expect("DRIFT_MIN_SCORE");
        }
        if let Ok(v) = std::env::var("DRIFT_PROBE") {
            config.drift_probe = v == "1";
        }
        if let Ok(v) = std::env::var("WORKERS") {
            config.workers = v.parse().expect("WORKERS");
        }
        if let Ok(v) = std::env::var("PRIOR_GATE") {
            config.prior_gate = v == "1";
        }
        let drift = config.pipeline.drift_prior.unwrap_or_default();
        let mut det = Detector::new(config, Overflow::Block);
        let mut cands: Vec<CandidateEvent> = Vec::new();
        let mut lat = Vec::with_capacity(input.len());
        let t0 = std::time::Instant::now();
        for p in &input {
            let s = std::time::Instant::now();
            det.push(&PoseInput::at(*p));
            lat.push(s.elapsed().as_nanos() as f64 / 1000.0);
            cands.extend(det.poll());
        }
        let (rest, _summary) = det.finish();
        cands.extend(rest);
        let wall = t0.elapsed().as_secs_f64();
        lat.sort_by(f64::total_cmp);
        let arc = turnprint_eval::revisits::arc_lengths(&g);
        let events = revisit_events(&g, &frames, &arc);
        if show_events {
            eprintln!("events {seq} {events:?}");
        }
        let correct: Vec<bool> = cands.iter().map(|c| is_correct(c, &g)).collect();
        let mut delays = Vec::new();
        let mut detected = 0;
        let mut hits = Vec::new();
        for &(e0, e1) in &events {
            let end_arc = arc[e1] + 40.0;
            let first = cands
                .iter()
                .zip(&correct)
                .filter(|(c, ok)| {
                    **ok && c.hypothesis.a_range[0] <= e1
                        && c.hypothesis.a_range[1] >= e0
                        && c.at_pose >= e0
                        && arc[c.at_pose.min(arc.len() - 1)] <= end_arc
                })
                .map(|(c, _)| c.at_pose)
                .min();
            hits.push(first.is_some());
            if let Some(at) = first {
                detected += 1;
                delays.push((arc[at.min(e1)] - arc[e0]).max(0.0));
            }
        }
        // Which events the map's own poses could decide by the deadline.
        for (&(e0, e1), &hit) in events.iter().zip(&hits) {
            let deadline = arc.partition_point(|&s| s <= arc[e1] + 40.0);
            let amb = turnprint_eval::ambiguity::revisit_rival(
                &g,
                &input,
                [e0, e1],
                deadline,
                APPROACH_M,
                300,
                8.0,
                &drift,
            );
            let rival = amb.map(|a| a.has_rival());
            certified.push((rival, hit));
            if show_events {
                eprintln!("certificate {seq} [{e0}, {e1}] detected {hit} rival {rival:?} {amb:?}");
            }
        }
        let ok = correct.iter().filter(|&&b| b).count();
        if std::env::var("SCORES").is_ok() {
            for (c, ok) in cands.iter().zip(&correct) {
                eprintln!(
                    "score {seq} {} {:.4} {} {} at {} q {:?} m {:?} d {:.1} f {:.4} {:.4} {:.4} {:.4} {:.2} {:.4} {:.4}",
                    ok,
                    c.hypothesis.score,
                    c.source.name(),
                    c.hypothesis.reversed,
                    c.at_pose,
                    c.hypothesis.a_range,
                    c.hypothesis.b_range,
                    median_gt_distance(c, &g),
                    c.hypothesis.scale,
                    c.hypothesis.rotation_angle(),
                    c.hypothesis.rmse,
                    c.hypothesis.turning,
                    c.hypothesis.length,
                    c.hypothesis.length_ratio,
                    c.hypothesis.zncc
                );
            }
        }
        delays.sort_by(f64::total_cmp);
        let q = |v: &[f64], f: f64| {
            if v.is_empty() {
                f64::NAN
            } else {
                v[((v.len() - 1) as f64 * f).round() as usize]
            }
        };
        println!(
            "{seq}  {:5} {:6} {:8} {:5.2} {:11.1} {:11.1} {:6} {:7} {:5.2} {:11.2} {:11.2} {:7.2}",
            input.len(),
            events.len(),
            detected,
            detected as f64 / events.len().max(1) as f64,
            q(&delays, 0.5),
            q(&delays, 0.9),
            cands.len(),
            ok,
            ok as f64 / cands.len().max(1) as f64,
            q(&lat, 0.5),
            q(&lat, 0.99),
            wall
        );
        ev_all += events.len();
        det_all += detected;
        c_all += cands.len();
        ok_all += ok;
        delays_all.extend(delays);
    }
    delays_all.sort_by(f64::total_cmp);
    let q = |v: &[f64], f: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            v[((v.len() - 1) as f64 * f).round() as usize]
        }
    };
    println!(
        "all  events {ev_all} detected {det_all} rate {:.3} delay median {:.1} m p90 {:.1} m candidates {c_all} correct {ok_all} share {:.3}",
        det_all as f64 / ev_all.max(1) as f64,
        q(&delays_all, 0.5),
        q(&delays_all, 0.9),
        ok_all as f64 / c_all.max(1) as f64
    );
    let count = |rival: Option<bool>| {
        let of: Vec<bool> = certified
            .iter()
            .filter(|c| c.0 == rival)
            .map(|c| c.1)
            .collect();
        (of.len(), of.iter().filter(|&&d| d).count())
    };
    let (rival, undecided, none) = (count(Some(true)), count(None), count(Some(false)));
    println!(
        "certificate  events with a shape rival under the drift prior {} (detected {}); without {} (detected {}); too long for one similarity {} (detected {})",
        rival.0, rival.1, none.0, none.1, undecided.0, undecided.1
    );
}

/// Whether the environment variable `name` is set to 1.
fn flag(name: &str) -> bool {
    std::env::var(name).is_ok_and(|v| v == "1")
}

/// The input under `SIMILARITY=1` and `REVERSE=1` (module doc), with the
/// GT frame of each pose and its GT position (input index space); a
/// reversed drive's frames count down from the end, so "300 frames
/// earlier" stays earlier in the order streamed.
fn reframed(
    mut input: Vec<Vector3<f64>>,
    mut frames: Vec<usize>,
    gt: &[Vector3<f64>],
    seed: u64,
) -> (Vec<Vector3<f64>>, Vec<usize>, Vec<Vector3<f64>>) {
    let mut g: Vec<Vector3<f64>> = frames.iter().map(|&f| gt[f]).collect();
    if flag("SIMILARITY") {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x5171_1a71);
        let extent = turnprint_eval::revisits::arc_lengths(&input)
            .last()
            .copied()
            .unwrap_or(1.0);
        let b_t_a = turnprint_eval::similarity::random_similarity(&mut rng, extent);
        input = input.iter().map(|p| b_t_a.apply(p)).collect();
    }
    if flag("REVERSE") {
        input.reverse();
        g.reverse();
        frames = frames.iter().rev().map(|&f| gt.len() - 1 - f).collect();
    }
    (input, frames, g)
}

/// Road before an event that its certificate counts as seen (m).
const APPROACH_M: f64 = 100.0;

/// Revisit events (module doc): the library's grouping
/// (`eval::revisits::events`), with the 300-frame gap counted in GT frames
/// (the ORB estimate skips a few).
fn revisit_events(g: &[Vector3<f64>], frames: &[usize], arc: &[f64]) -> Vec<(usize, usize)> {
    let revisits: Vec<Option<usize>> = (0..g.len())
        .map(|i| {
            (0..g.len()).find(|&j| frames[j] + 300 <= frames[i] && (g[i] - g[j]).norm() <= 8.0)
        })
        .collect();
    turnprint_eval::revisits::events(&revisits, arc, 19, 40.0)
        .into_iter()
        .map(|e| (e.first, e.last))
        .collect()
}

/// Median GT distance from the query poses to the nearest match pose ≤ 10 m.
fn is_correct(c: &CandidateEvent, g: &[Vector3<f64>]) -> bool {
    median_gt_distance(c, g) <= 10.0
}

/// Median GT distance from a candidate's query poses to its match range.
fn median_gt_distance(c: &CandidateEvent, g: &[Vector3<f64>]) -> f64 {
    let h = &c.hypothesis;
    let clamp = |i: usize| i.min(g.len() - 1);
    let (q0, q1) = (clamp(h.a_range[0]), clamp(h.a_range[1]));
    let (m0, m1) = (clamp(h.b_range[0]), clamp(h.b_range[1]));
    let step = ((q1 - q0) / 50).max(1);
    let mut d: Vec<f64> = (q0..=q1)
        .step_by(step)
        .map(|i| {
            (m0..=m1)
                .map(|j| (g[i] - g[j]).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(f64::INFINITY)
}

/// ORB-SLAM2 estimate paired to GT frames by timestamp.
fn orb_paired(seq: &str, n_gt: usize) -> (Vec<Vector3<f64>>, Vec<usize>) {
    let orb = read_trajectory(
        Path::new(&format!(
            "{}/kitti_orbslam2_vio/{seq}_orbslam2_tum.txt",
            data_dir()
        )),
        Format::Tum,
    )
    .expect("orb");
    let times: Vec<f64> =
        std::fs::read_to_string(format!("{}/kitti_gt/{seq}_times.txt", data_dir()))
            .expect("times")
            .split_whitespace()
            .filter_map(|s| s.parse().ok())
            .collect();
    let mut input = Vec::new();
    let mut frames = Vec::new();
    for p in &orb.poses {
        let Some(t) = p.t else { continue };
        let k = times.partition_point(|&x| x < t);
        let best = [k.saturating_sub(1), k.min(times.len() - 1)]
            .into_iter()
            .min_by(|&a, &b| (times[a] - t).abs().total_cmp(&(times[b] - t).abs()))
            .unwrap();
        if (times[best] - t).abs() < 0.05 && best < n_gt {
            input.push(p.position);
            frames.push(best);
        }
    }
    (input, frames)
}

/// Ground truth with strong drift: heading random walk (deterministic
/// pseudo-random, 0.5°/√100 m), scale drift 2 %/km, applied along the path.
fn drifted(g: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(g.len());
    let mut state: u64 = 0x5eed;
    let mut yaw = 0.0f64;
    let mut scale = 1.0f64;
    let mut p = g[0];
    out.push(p);
    for i in 1..g.len() {
        let d = g[i] - g[i - 1];
        let len = d.norm();
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let u = ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0;
        yaw += u * 0.5f64.to_radians() * (len / 100.0).sqrt() * 1.7;
        scale *= 1.0 + 0.02 * len / 1000.0;
        // KITTI camera frame: y is down, the road is the x-z plane.
        let r = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw);
        p += scale * (r * d);
        out.push(p);
    }
    out
}
