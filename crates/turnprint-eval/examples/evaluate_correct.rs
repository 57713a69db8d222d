//! Drift correction on every real odometry estimate of KITTI and every
//! EuRoC VIO estimate in the shared data, and on KITTI's ground truth itself
//! (do no harm): APE before and after
//! `turnprint::correct`, as evo computes it (SE(3) Umeyama for metric
//! estimates, Sim(3) for monocular ones), with the loops kept and rejected
//! and the time taken (EVALUATION.md, "Drift correction").
//!
//! Usage: `cargo run --release --example evaluate_correct -- [FILTER]`
//! (data from ../shared/data, or `DATA=dir`); FILTER keeps the rows whose
//! estimate name contains it. `ONLINE=1` streams each estimate through the
//! online detector with drift correction instead (`stream --correct`) and
//! reports its corrected path at the end. `SYNTH=1` corrects the ground
//! truth under synthetic drift (random walks and systematic biases, random
//! similarities, both directions) instead (`SYNTH=wheel`: the drifts whose
//! name contains it); FILTER then keeps the sequences whose name contains
//! it. `VERBOSE=1` lists every loop with its true offset on stderr, under
//! a line naming the estimate (before its table row).
//! `ORACLE=1` corrects with the loops the ground truth shows instead of the
//! search's (what the graph makes of right loops); `NODES=n` and `TOP=k`
//! set the graph's even keyframes and the loops taken from the search,
//! `RIGID=1` takes the loops as rigid motions (`CorrectConfig::rigid_loops`),
//! `SIMILAR=1` corrects each estimate under a random similarity (scale 0.01
//! to 100, any rotation) and driven the other way (not with `ORACLE=1`),
//! `SWAPPED=1` the estimate driven the other way with the loops the search
//! finds on it as it is, their passes swapped (the graph's own dependence
//! on direction; batch, not with `ORACLE=1` or `SIMILAR=1`),
//! `GROUP=se3` or `GROUP=sim3` sets the node group instead of `auto`.
//! Drones' and hand-held cameras' motion-capture truths are a second table
//! (do no harm: how far the correction moves them), wheeled robots' dead
//! reckoning with measured relations (CARMEN ACES) a third: relation errors
//! before and after, batch and streamed.

use std::path::{Path, PathBuf};
use std::time::Instant;

use nalgebra::Vector3;
use turnprint::correct::{correct, CorrectConfig};
use turnprint::io::{read_trajectory, Format};
use turnprint::Trajectory;
use turnprint_eval::ape::{ape, Alignment};

/// The shared data, relative to the project root (`DATA=dir` to change).
fn data_dir() -> PathBuf {
    PathBuf::from(std::env::var("DATA").unwrap_or_else(|_| "../shared/data".into()))
}

/// One estimate of one sequence, paired pose by pose with the truth.
struct Case {
    name: String,
    seq: String,
    path: PathBuf,
    format: Format,
    alignment: Alignment,
    /// The truth by time (EuRoC's motion capture); KITTI's for the
    /// sequence `seq` when `None`.
    truth: Option<PathBuf>,
}

const SEQS: [&str; 7] = ["00", "02", "05", "06", "07", "08", "09"];

fn cases(dir: &Path) -> Vec<Case> {
    let mut out = Vec::new();
    let mut add = |name: &str, seq: &str, path: PathBuf, format: Format, alignment| {
        if path.is_file() {
            out.push(Case {
                name: name.into(),
                seq: seq.into(),
                path,
                format,
                alignment,
                truth: None,
            });
        }
    };
    for seq in SEQS {
        let gt = dir.join("kitti_gt").join(format!("{seq}.txt"));
        add("ground truth", seq, gt, Format::Kitti, Alignment::Se3);
        let odo = dir.join("odometry");
        for (name, sub) in [
            (
                "MULLS without loop closure",
                "kitti_mulls_dso/mulls_no_loop",
            ),
            ("MULLS with loop closure", "kitti_mulls_dso/mulls_with_loop"),
            ("A-LOAM", "kitti_aloam"),
            ("LiDAR GICP", "kitti_cvo_lidar/lidar_gicp"),
            ("LiDAR NDT", "kitti_cvo_lidar/lidar_ndt"),
            ("DSO (metric)", "kitti_mulls_dso/dso"),
        ] {
            add(
                name,
                seq,
                odo.join(sub).join(format!("{seq}.txt")),
                Format::Kitti,
                Alignment::Se3,
            );
        }
        add(
            "LiDAR CVO",
            seq,
            odo.join("kitti_cvo_lidar/lidar_cvo_geometric")
                .join(format!("acvo_geometric_{seq}.txt")),
            Format::Kitti,
            Alignment::Se3,
        );
        add(
            "ORB-SLAM2 monocular",
            seq,
            dir.join("kitti_orbslam2_vio")
                .join(format!("{seq}_orbslam2_tum.txt")),
            Format::Tum,
            Alignment::Sim3,
        );
    }
    add(
        "S-PTAM stereo",
        "00",
        dir.join("evo/KITTI_00_SPTAM.txt"),
        Format::Kitti,
        Alignment::Se3,
    );
    add(
        "ORB-SLAM stereo (loop-closed)",
        "00",
        dir.join("evo/KITTI_00_ORB.txt"),
        Format::Kitti,
        Alignment::Se3,
    );
    // Drones: EuRoC's VIO estimates, metric (an IMU fixes the scale).
    for v in turnprint_eval::kinds::catalog::euroc_vio_estimates(dir) {
        out.push(Case {
            name: format!("EuRoC {}", v.method),
            seq: v.session.into(),
            path: dir.join(v.estimate),
            format: Format::Auto,
            alignment: Alignment::Se3,
            truth: Some(dir.join(v.truth)),
        });
    }
    out
}

/// The estimate's poses that have a truth, and the truth of each: KITTI's
/// by frame, or the motion capture's interpolated at each pose's time
/// (poses outside its span left out). `None` when they do not pair.
fn with_truth(dir: &Path, case: &Case, est: Trajectory) -> Option<(Trajectory, Vec<Vector3<f64>>)> {
    if let Some(file) = &case.truth {
        let gt = read_trajectory(file, Format::Auto).ok()?;
        let at = turnprint_eval::kinds::catalog::truth_at_times(&est, &gt);
        let (poses, truth): (Vec<_>, Vec<_>) = est
            .poses
            .into_iter()
            .zip(at)
            .filter_map(|(p, t)| Some((p, t?)))
            .unzip();
        let est = Trajectory {
            source: est.source,
            poses,
        };
        return (est.len() >= 2).then_some((est, truth));
    }
    let gt = read_trajectory(
        &dir.join("kitti_gt").join(format!("{}.txt", case.seq)),
        Format::Kitti,
    )
    .ok()?;
    let times: Vec<f64> =
        std::fs::read_to_string(dir.join("kitti_gt").join(format!("{}_times.txt", case.seq)))
            .map(|s| s.lines().filter_map(|l| l.trim().parse().ok()).collect())
            .unwrap_or_default();
    let pairs = pairing(&est, gt.len(), &times)?;
    let truth = pairs.iter().map(|&j| gt.poses[j].position).collect();
    Some((est, truth))
}

/// Ground-truth index of each pose: by order for one pose per frame, else
/// by timestamp (within 20 ms of a frame time).
fn pairing(t: &Trajectory, gt_len: usize, times: &[f64]) -> Option<Vec<usize>> {
    if t.len() == gt_len {
        return Some((0..gt_len).collect());
    }
    t.poses
        .iter()
        .map(|p| {
            let t = p.t?;
            let k = times.partition_point(|x| *x < t);
            [k.saturating_sub(1), k.min(times.len().checked_sub(1)?)]
                .into_iter()
                .min_by(|a, b| (times[*a] - t).abs().total_cmp(&(times[*b] - t).abs()))
                .filter(|j| (times[*j] - t).abs() < 0.02)
        })
        .collect()
}

/// The estimate streamed through the online detector with drift
/// correction (its candidates at the shape cut enter the graph, as in
/// `stream --correct` without a verifier); the corrected path at the
/// end, with the re-optimisations' count and slowest time on stderr.
fn streamed(est: &Trajectory) -> turnprint::Result<turnprint::correct::Corrected> {
    use turnprint::online::correction::LoopInput;
    use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block)
        .with_correction(config(), LoopInput::Candidates);
    let mut solves = Vec::new();
    for p in &est.poses {
        d.push(&PoseInput::from(p));
        d.poll();
        solves.extend(d.poll_corrections());
    }
    let (_, _, finished) = d.finish_corrected();
    let finished = finished.expect("correction enabled");
    solves.extend(finished.events);
    let slowest = solves.iter().map(|c| c.seconds).fold(0.0, f64::max);
    eprintln!(
        "  {} re-optimisations while streaming, slowest {slowest:.3} s",
        solves.len()
    );
    finished
        .corrected
        .ok_or_else(|| turnprint::Error::input(&est.source, "not corrected"))
}

/// The synthetic drifts of `SYNTH=1`.
#[derive(Clone, Copy, PartialEq)]
enum Drift {
    /// The random walks of [`DriftModel::strong`] at a quarter strength
    /// (about 4.5° of heading and 1 % of scale after 2 km, as KITTI's
    /// stereo and LiDAR odometry).
    Walk,
    /// A monocular odometry's: heading turning 0.3° and scale growing 1 %
    /// per 100 m travelled.
    Bias,
    /// A wheel odometry's: heading turning 0.3° per 100 m (its wheels'
    /// radii unequal) and every turn counted 2 % too far (its wheel base
    /// off), the two CARMEN's ACES log shows by its measured relations.
    Wheel,
}

/// The ground truth's positions with synthetic `drift`, then moved by a
/// random similarity (scale 0.01 to 100, any rotation); half the seeds
/// drive the path the other way.
fn drifted(truth: &[Vector3<f64>], drift: Drift, seed: u64) -> (Vec<Vector3<f64>>, Vec<usize>) {
    use rand::SeedableRng;
    use turnprint_eval::drift::{plane_normal, DriftModel};
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut order: Vec<usize> = (0..truth.len()).collect();
    if seed % 2 == 1 {
        order.reverse();
    }
    let ordered: Vec<Vector3<f64>> = order.iter().map(|&i| truth[i]).collect();
    let moved = if drift == Drift::Walk {
        DriftModel::strong().scaled(0.25).apply(&ordered, &mut rng)
    } else {
        let n = plane_normal(&ordered);
        let (growth, overturn) = match drift {
            Drift::Bias => (0.01, 0.0),
            _ => (0.0, 0.02),
        };
        // `turned`: the signed turn about `n` since the start.
        let (mut at, mut s, mut turned) = (ordered[0], 0.0, 0.0);
        let mut out = vec![at];
        let mut last = Vector3::zeros();
        for w in ordered.windows(2) {
            let d = w[1] - w[0];
            if d.norm() > 0.0 {
                if last.norm() > 0.0 {
                    turned += n.dot(&last.cross(&d)).atan2(last.dot(&d));
                }
                last = d;
            }
            s += d.norm();
            let heading = (0.3f64).to_radians() * s / 100.0 + overturn * turned;
            let r = nalgebra::Rotation3::from_axis_angle(&n, heading);
            at += (1.0 + growth * s / 100.0) * (r * d);
            out.push(at);
        }
        out
    };
    let sim = turnprint_eval::similarity::random_similarity(&mut rng, 100.0);
    (moved.iter().map(|p| sim.apply(p)).collect(), order)
}

/// `SYNTH=1`: APE after / before on ground truth with synthetic drift,
/// per drift model, over every sequence that revisits and ten seeds.
fn synthetic(dir: &Path) {
    println!(
        "| drift | runs | median APE after / before | share improved 5x | median kept loops |"
    );
    println!("|---|---|---|---|---|");
    let only = std::env::args().nth(1).unwrap_or_default();
    for (drift, name) in [
        (Drift::Walk, "random walk"),
        (Drift::Bias, "systematic bias"),
        (Drift::Wheel, "wheel odometry's bias"),
    ] {
        // `SYNTH=wheel` (any part of a name) runs that drift alone.
        let which = std::env::var("SYNTH").unwrap_or_default();
        if which != "1" && !name.contains(which.as_str()) {
            continue;
        }
        let (mut ratios, mut kept) = (Vec::new(), Vec::new());
        for seq in ["00", "02", "05", "06", "08"]
            .into_iter()
            .filter(|s| s.contains(&only))
        {
            let Ok(gt) = read_trajectory(
                &dir.join("kitti_gt").join(format!("{seq}.txt")),
                Format::Kitti,
            ) else {
                continue;
            };
            let truth = gt.positions();
            for seed in 0..10 {
                let (est, order) = drifted(&truth, drift, seed);
                let t: Vec<Vector3<f64>> = order.iter().map(|&i| truth[i]).collect();
                let path = Trajectory {
                    source: format!("{seq} seed {seed}"),
                    poses: est.iter().map(|p| turnprint::Pose::at(*p)).collect(),
                };
                let result = if std::env::var("ORACLE").is_ok() {
                    oracle(&path, &t)
                } else {
                    correct(&path, &config())
                };
                let Ok(c) = result else {
                    continue;
                };
                let after: Vec<_> = c.poses.iter().map(|p| p.position).collect();
                let (Some(b), Some(a)) = (
                    ape(&est, &t, Alignment::Sim3),
                    ape(&after, &t, Alignment::Sim3),
                ) else {
                    continue;
                };
                eprintln!(
                    "  {name} {seq} seed {seed}: APE {:.2} -> {:.2} m (truth units), kept {}, {}, bias {}",
                    b.rmse,
                    a.rmse,
                    c.kept(),
                    c.group.name(),
                    c.bias.map_or("none".into(), |b| b.to_json().to_string())
                );
                if std::env::var("VERBOSE").is_ok() {
                    print_loops(&c, &t, &est);
                }
                ratios.push(a.rmse / b.rmse);
                kept.push(c.kept() as f64);
            }
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        let five = ratios.iter().filter(|r| **r <= 0.2).count() as f64 / ratios.len().max(1) as f64;
        println!(
            "| {name} | {} | {:.2} | {:.0} % | {:.0} |",
            ratios.len(),
            median(&mut ratios),
            100.0 * five,
            median(&mut kept)
        );
    }
}

/// `VERBOSE=1`: every loop of `c` on stderr, with the true distance
/// between its two passes (`truth` paired pose by pose with the input).
fn print_loops(c: &turnprint::correct::Corrected, truth: &[Vector3<f64>], est: &[Vector3<f64>]) {
    let arc = turnprint_eval::revisits::arc_lengths(est);
    let total = arc.last().copied().unwrap_or(1.0).max(f64::MIN_POSITIVE);
    for l in &c.loops {
        let q = &l.closure;
        let offset = turnprint_eval::revisits::true_offset(q.query_range, q.match_range, truth);
        // On a path without drift a right loop moves nothing: the RMS move
        // of the match range is then the loop's own error.
        let part = &truth[q.match_range[0]..=q.match_range[1]];
        let moved = (part
            .iter()
            .map(|p| (q.query_T_match.apply(p) - p).norm_squared())
            .sum::<f64>()
            / part.len() as f64)
            .sqrt();
        // The later pass's length over the path's, and over how far apart
        // the path has the passes, in the estimate.
        let length =
            arc[q.query_range[1].min(arc.len() - 1)] - arc[q.query_range[0].min(arc.len() - 1)];
        let share = length / total;
        let over_apart = length / q.apart(est).max(f64::MIN_POSITIVE);
        eprintln!(
            "  q {:?} m {:?} rev {} score {:.2} scale {:.3} rmse {:.2} residual {:.1} kept {} true dist {:.1} m, moves the truth {:.2}, {:.2} % of the path, {:.1} times the passes' distance",
            q.query_range, q.match_range, q.reversed, q.score, q.query_T_match.scale, q.rmse, l.residual, l.kept, offset, moved, 100.0 * share, over_apart
        );
    }
    eprintln!("  --");
}

/// `ORACLE=1`: the loops the truth shows (every revisit within 3 m, cut
/// into pieces of about 100 m), to measure what the graph makes of right
/// loops, apart from the search.
fn oracle(
    est: &Trajectory,
    truth: &[Vector3<f64>],
) -> turnprint::Result<turnprint::correct::Corrected> {
    use turnprint::correct::{correct_with_loops, LoopClosure};
    use turnprint_eval::revisits;
    let arc = revisits::arc_lengths(truth);
    let gap = arc.partition_point(|a| *a < 100.0).max(1);
    let visits = revisits::revisits(truth, 3.0, gap);
    let mut loops = Vec::new();
    let mut start: Option<usize> = None;
    for i in 0..=visits.len() {
        let open = i < visits.len() && visits[i].is_some();
        if let Some(s) = start {
            if !open || arc[i] - arc[s] > 100.0 {
                let q = [s, i - 1];
                let js: Vec<usize> = (s..i).filter_map(|k| visits[k]).collect();
                let m = [*js.iter().min().unwrap(), *js.iter().max().unwrap()];
                // A run whose nearest earlier poses jump between passes
                // is no one loop.
                let (lq, lm) = (arc[q[1]] - arc[q[0]], arc[m[1]] - arc[m[0]]);
                if lq > 20.0 && m[1] > m[0] && lm < 2.0 * lq {
                    let reversed = js.first() > js.last();
                    if let Ok(l) = LoopClosure::new(est, q, m, None, 1.0, reversed) {
                        loops.push(l);
                    }
                }
                start = None;
            }
        }
        if open && start.is_none() {
            start = Some(i);
        }
    }
    eprintln!("  oracle: {} loops", loops.len());
    correct_with_loops(est, &loops, &config())
}

/// `SWAPPED=1`: the loops the search finds on the estimate, each with its
/// passes swapped (the later pass the earlier), on the estimate driven the
/// other way, corrected and put back in order: how the graph alone depends
/// on the direction, the loops being the same.
#[allow(non_snake_case)]
fn swapped(est: &Trajectory) -> turnprint::Result<turnprint::correct::Corrected> {
    use turnprint::correct::{correct_with_loops, LoopClosure};
    let c = config();
    let last = est.len().saturating_sub(1);
    let mut reversed = est.clone();
    reversed.poses.reverse();
    let back = |r: [usize; 2]| [last - r[1], last - r[0]];
    let loops = turnprint::find_loops(est, &c.loops)?
        .iter()
        .map(|h| {
            let l = LoopClosure::from_hypothesis(est, h)?;
            let match_T_query = l.query_T_match.inverse();
            let (q, m) = (back(l.match_range), back(l.query_range));
            LoopClosure::new(&reversed, q, m, Some(match_T_query), l.score, l.reversed)
        })
        .collect::<turnprint::Result<Vec<_>>>()?;
    let identity = turnprint::geometry::Similarity3::identity();
    let mut out = taken_back(correct_with_loops(&reversed, &loops, &c)?, &identity, true);
    // Each loop as the search found it forward: its passes swapped back.
    for v in &mut out.loops {
        let l = &mut v.closure;
        std::mem::swap(&mut l.query_range, &mut l.match_range);
        l.query_T_match = l.query_T_match.inverse();
    }
    Ok(out)
}

/// Default settings, with `NODES=` (keyframes at most), `TOP=` (loops
/// from the search), `RIGID=1` (`rigid_loops`) and `GROUP=se3|sim3` (the
/// node group instead of `auto`) to measure their effect.
fn config() -> CorrectConfig {
    let mut c = CorrectConfig::default();
    let var = |name: &str| {
        std::env::var(name)
            .ok()
            .and_then(|v| v.parse::<usize>().ok())
    };
    if let Some(n) = var("NODES") {
        c.max_nodes = n;
    }
    if let Some(k) = var("TOP") {
        c.loops.top_k = k;
    }
    c.rigid_loops = std::env::var("RIGID").is_ok();
    match std::env::var("GROUP").as_deref() {
        Ok("se3") => c.group = turnprint::correct::Group::Se3,
        Ok("sim3") => c.group = turnprint::correct::Group::Sim3,
        _ => {}
    }
    c
}

/// A seed per estimate, the same in every run.
fn case_seed(name: &str, seq: &str) -> u64 {
    name.bytes()
        .chain(seq.bytes())
        .fold(1469598103934665603u64, |h, b| {
            (h ^ b as u64).wrapping_mul(1099511628211)
        })
}

/// The corrected path of a moved and reversed input in the estimate's
/// frame and order (`similarity::moved_and_reversed`); as it is otherwise.
#[allow(non_snake_case)]
fn taken_back(
    mut c: turnprint::correct::Corrected,
    est_T_input: &turnprint::geometry::Similarity3,
    reversed: bool,
) -> turnprint::correct::Corrected {
    for p in &mut c.poses {
        p.position = est_T_input.apply(&p.position);
    }
    if reversed {
        c.poses.reverse();
        // The loops' ranges in the estimate's order, for `VERBOSE=1` (their
        // similarities stay in the input's frame).
        let last = c.poses.len().saturating_sub(1);
        let back = |r: [usize; 2]| [last - r[1].min(last), last - r[0].min(last)];
        for l in &mut c.loops {
            l.closure.query_range = back(l.closure.query_range);
            l.closure.match_range = back(l.closure.match_range);
        }
    }
    c
}

#[allow(non_snake_case)]
fn main() {
    let dir = data_dir();
    if std::env::var("SYNTH").is_ok() {
        synthetic(&dir);
        return;
    }
    let online = std::env::var("ONLINE").is_ok();
    let filter = std::env::args().nth(1).unwrap_or_default();
    println!("| estimate | seq | poses | APE before | APE after | after / before | loops kept / rejected | graph | s |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for case in cases(&dir).into_iter().filter(|c| c.name.contains(&filter)) {
        let est = match read_trajectory(&case.path, case.format) {
            Ok(t) => t,
            Err(e) => {
                println!("| {} | {} | unreadable: {e} |", case.name, case.seq);
                continue;
            }
        };
        let Some((est, truth)) = with_truth(&dir, &case, est) else {
            println!(
                "| {} | {} | not paired with the truth | | | | | | |",
                case.name, case.seq,
            );
            continue;
        };
        // Whatever a case prints on stderr (`VERBOSE=1`, the stream's
        // re-optimisations) follows its name there: its table row comes
        // after.
        if std::env::var("VERBOSE").is_ok() {
            eprintln!("{} {}:", case.name, case.seq);
        }
        let started = Instant::now();
        // `SIMILAR=1`: the estimate under a random similarity, driven the
        // other way; its corrected path taken back for the APE. `ORACLE=1`
        // builds its loops from the truth in the estimate's order and frame,
        // and takes the estimate as it is.
        let oracle_loops = std::env::var("ORACLE").is_ok();
        let swap = std::env::var("SWAPPED").is_ok() && !oracle_loops && !online;
        let similar = std::env::var("SIMILAR").is_ok() && !oracle_loops && !swap;
        let (input, est_T_input) = match similar {
            true => {
                use rand::SeedableRng;
                let seed = case_seed(&case.name, &case.seq);
                let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
                turnprint_eval::similarity::moved_and_reversed(&est, &mut rng)
            }
            false => (est.clone(), turnprint::geometry::Similarity3::identity()),
        };
        let result = if oracle_loops {
            oracle(&est, &truth)
        } else if online {
            streamed(&input)
        } else if swap {
            swapped(&est)
        } else {
            correct(&input, &config())
        };
        let corrected = match result.map(|c| taken_back(c, &est_T_input, similar)) {
            Ok(c) => c,
            Err(e) => {
                println!(
                    "| {} | {} | {} | failed: {e} |",
                    case.name,
                    case.seq,
                    est.len()
                );
                continue;
            }
        };
        let seconds = started.elapsed().as_secs_f64();
        let before = ape(&est.positions(), &truth, case.alignment).map_or(f64::NAN, |s| s.rmse);
        let after_positions: Vec<_> = corrected.poses.iter().map(|p| p.position).collect();
        let after = ape(&after_positions, &truth, case.alignment).map_or(f64::NAN, |s| s.rmse);
        if std::env::var("VERBOSE").is_ok() {
            print_loops(&corrected, &truth, &est.positions());
        }
        let kept = corrected.kept();
        println!(
            "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {} / {} | {} | {:.2} |",
            case.name,
            case.seq,
            est.len(),
            before,
            after,
            after / before,
            kept,
            corrected.loops.len() - kept,
            corrected.group.name(),
            seconds
        );
    }
    if !online && std::env::var("ORACLE").is_err() && "motion capture".contains(&filter) {
        motion_capture(&dir);
    }
    if !online && std::env::var("ORACLE").is_err() && "wheel odometry".contains(&filter) {
        relations(&dir);
    }
}

/// Do no harm off the road: every drone and hand-held camera's
/// motion-capture truth in the data (`kinds::catalog`, sessions over 6000
/// poses thinned evenly, positions only) corrected, and how far the
/// correction moves it (APE against itself, SE(3) Umeyama) in metres and
/// as a share of its extent.
fn motion_capture(dir: &Path) {
    use turnprint_eval::kinds::{catalog::catalog, Kind};
    println!();
    println!("| motion-capture truth | poses | extent, m | moved, m RMS | moved / extent | loops kept / rejected |");
    println!("|---|--:|--:|--:|--:|--:|");
    let sessions = catalog(dir).sessions;
    let truths = sessions
        .iter()
        .filter(|s| matches!(s.kind, Kind::Drone | Kind::Handheld) && s.input == s.truth);
    for s in truths {
        let path = Trajectory::from_positions(s.name.clone(), &s.truth);
        let extent = turnprint::geometry::extent(&s.truth);
        match correct(&path, &config()) {
            Ok(c) => {
                let after: Vec<_> = c.poses.iter().map(|p| p.position).collect();
                let moved = ape(&after, &s.truth, Alignment::Se3).map_or(f64::NAN, |a| a.rmse);
                let kept = c.kept();
                println!(
                    "| {} | {} | {extent:.1} | {moved:.3} | {:.1} % | {kept} / {} |",
                    s.name,
                    path.len(),
                    100.0 * moved / extent,
                    c.loops.len() - kept
                );
            }
            Err(e) => println!("| {} | {} | failed: {e} |", s.name, path.len()),
        }
    }
}

/// `VERBOSE=1`: every loop of `c` on stderr, with the median of its
/// misses against the relations that join its passes
/// (`turnprint_eval::relations::loop_misses`).
fn print_relation_loops(
    c: &turnprint::correct::Corrected,
    est: &Trajectory,
    relations: &[turnprint_eval::relations::Relation],
) {
    for l in &c.loops {
        let q = &l.closure;
        let misses: Vec<f64> = turnprint_eval::relations::loop_misses(
            &est.poses,
            relations,
            q.query_range,
            q.match_range,
            &q.query_T_match,
        )
        .into_iter()
        .map(|(_, m)| m)
        .collect();
        let median = match misses.is_empty() {
            true => "no relation".to_string(),
            false => format!("{:.2} m", turnprint_eval::checks::median(&misses)),
        };
        eprintln!(
            "  q {:?} m {:?} rev {} score {:.2} kept {}: {} relations between its passes, median miss {median}",
            q.query_range, q.match_range, q.reversed, q.score, l.kept, misses.len()
        );
    }
}

/// Wheeled robots' dead reckoning (the CARMEN logs with measured
/// relations beside them, `<log>.relations` and `<log>_odom.csv`): the
/// relations' mean errors (`turnprint_eval::relations`) before and after
/// correction, batch and streamed.
fn relations(dir: &Path) {
    use turnprint_eval::relations::{errors, read, Errors};
    println!();
    println!("| log | poses | relations (revisits) | before: all, m / deg | before: revisits, m / deg | batch: all | batch: revisits | loops kept / rejected | stream: all | stream: revisits | loops kept / rejected |");
    println!("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|");
    let cell = |e: &Errors| format!("{:.3} / {:.2}", e.translation, e.rotation.to_degrees());
    for sub in ["carmen", "carmen/more"] {
        let Ok(entries) = std::fs::read_dir(dir.join(sub)) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|e| e == "relations"))
            .collect();
        files.sort();
        for file in files {
            let stem = file.file_stem().unwrap_or_default().to_string_lossy();
            let odom = file.with_file_name(format!("{stem}_odom.csv"));
            let (Ok(rel), Ok(est)) = (read(&file), read_trajectory(&odom, Format::Auto)) else {
                println!("| {stem} | unreadable |");
                continue;
            };
            let Some((all, revisits)) = errors(&est.poses, &rel) else {
                println!("| {stem} | poses without a time or heading |");
                continue;
            };
            let mut row = format!(
                "| {stem} | {} | {} ({}) | {} | {} |",
                est.len(),
                all.count,
                revisits.count,
                cell(&all),
                cell(&revisits)
            );
            for result in [correct(&est, &config()), streamed(&est)] {
                match result.ok().and_then(|c| Some((errors(&c.poses, &rel)?, c))) {
                    Some(((a, r), c)) => {
                        if std::env::var("VERBOSE").is_ok() {
                            print_relation_loops(&c, &est, &rel);
                        }
                        let kept = c.kept();
                        row += &format!(
                            " {} | {} | {} / {} |",
                            cell(&a),
                            cell(&r),
                            kept,
                            c.loops.len() - kept
                        );
                    }
                    None => row += " failed | | |",
                }
            }
            println!("{row}");
        }
    }
}
