//! Evaluates the visual verifier on rendered runs of KITTI sequences: true
//! revisits (ground truth within 3 m, heading within 30 deg, frames far apart
//! in time) must be confirmed, pairs of far-apart places must be rejected,
//! for each camera pairing.
//!
//! `cargo run --release -p turnprint-verifier --example vision_eval -- [SEQ...] [--pairs N]`
//!
//! The ground truth (`kitti_gt/SEQ.txt`) comes from the shared data (see
//! `turnprint_eval::data`); a sequence whose file is absent is skipped.

use nalgebra::Isometry3;
use turnprint_verifier::features::GrayImage;
use turnprint_verifier::render::{camera_poses, on_road, render, World, WorldParams};
use turnprint_verifier::{CameraModel, OrbVerifier, VerifierParams};

/// Camera poses of a KITTI ground-truth file, read by the project's reader.
fn kitti_poses(file: &str) -> Vec<Isometry3<f64>> {
    let truth = turnprint::io::read_trajectory(file.as_ref(), turnprint::io::Format::Kitti)
        .unwrap_or_else(|e| panic!("{e}"));
    camera_poses(&truth)
}

/// Heading difference (radians) of the optical axes projected on the ground.
fn heading_difference(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
    let za = a.rotation * nalgebra::Vector3::z();
    let zb = b.rotation * nalgebra::Vector3::z();
    let (ha, hb) = (za.x.atan2(za.z), zb.x.atan2(zb.z));
    let d = (ha - hb).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut per_kind = 12usize;
    let mut seqs = Vec::new();
    let mut params = VerifierParams::default();
    let mut max_heading = 30f64.to_radians();
    let mut min_heading = 0.0;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--max-heading" {
            max_heading = it
                .next()
                .and_then(|v| v.parse::<f64>().ok())
                .expect("--max-heading DEG")
                .to_radians();
        } else if a == "--min-heading" {
            min_heading = it
                .next()
                .and_then(|v| v.parse::<f64>().ok())
                .expect("--min-heading DEG")
                .to_radians();
        } else if a == "--min-cheirality" {
            params.pose.min_cheirality = it
                .next()
                .and_then(|v| v.parse().ok())
                .expect("--min-cheirality X");
        } else if a == "--ratio" {
            params.matching.ratio = it.next().and_then(|v| v.parse().ok()).expect("--ratio X");
        } else if a == "--features" {
            params.orb.max_features = it
                .next()
                .and_then(|v| v.parse().ok())
                .expect("--features N");
        } else if a == "--pairs" {
            per_kind = it.next().and_then(|v| v.parse().ok()).expect("--pairs N");
        } else {
            seqs.push(a.clone());
        }
    }
    if seqs.is_empty() {
        seqs = vec!["00".into(), "05".into(), "06".into(), "08".into()];
    }
    let (w, h) = (640u32, 480u32);
    let pinhole = CameraModel::standard_pinhole(w, h, 90f64.to_radians());
    let fisheye = CameraModel::standard_fisheye(w, h, 190f64.to_radians());
    let omni = CameraModel::standard_omni(w, h, 0.9, 200f64.to_radians());
    let pairings = [
        ("pinhole-pinhole", pinhole, pinhole),
        ("pinhole-fisheye", pinhole, fisheye),
        ("pinhole-omni", pinhole, omni),
        ("fisheye-omni", fisheye, omni),
    ];
    let mut totals = vec![(0usize, 0usize, 0usize, 0usize); pairings.len()];
    let mut verify_time = std::time::Duration::ZERO;
    let mut verify_count = 0usize;
    for seq in &seqs {
        let Some(truth) = turnprint_eval::data::require(&format!("kitti_gt/{seq}.txt")) else {
            continue;
        };
        let poses = kitti_poses(truth.to_str().expect("a UTF-8 data path"));
        let positions: Vec<_> = poses.iter().map(|p| p.translation.vector).collect();
        let world = World::from_positions(&positions, WorldParams::default()).expect("world");
        // True revisits: within 3 m, heading within 30 deg (--max-heading), at least 300 frames apart.
        let mut trues = Vec::new();
        let mut i = 0;
        while i < poses.len() {
            let found = (i + 300..poses.len()).find(|&j| {
                let heading = heading_difference(&poses[i], &poses[j]);
                (positions[i] - positions[j]).norm() < 3.0
                    && heading < max_heading
                    && heading >= min_heading
            });
            if let Some(j) = found {
                trues.push((i, j));
                i += 40;
            } else {
                i += 5;
            }
        }
        let stride = (trues.len() / per_kind).max(1);
        let trues: Vec<_> = trues.into_iter().step_by(stride).take(per_kind).collect();
        // False pairs: far apart places (> 100 m), deterministic spread.
        let mut falses = Vec::new();
        let n = poses.len();
        let mut k = 0usize;
        while falses.len() < per_kind && k < 10 * per_kind {
            let i = (k * 7919) % n;
            let j = (k * 104_729 + n / 2) % n;
            if (positions[i] - positions[j]).norm() > 100.0 {
                falses.push((i, j));
            }
            k += 1;
        }
        for (p, (name, ca, cb)) in pairings.iter().enumerate() {
            let mut v = OrbVerifier::new(params).expect("verifier");
            let (mut tp, mut fp) = (0, 0);
            let mut failures = Vec::new();
            for (label, list) in [("true", &trues), ("false", &falses)] {
                for &(i, j) in list.iter() {
                    let ia = render(&world, ca, on_road(&poses[i]), w, h);
                    let ib = render(&world, cb, on_road(&poses[j]), w, h);
                    let (ida, idb) = (2 * i as u64, 2 * j as u64 + 1);
                    v.add_keyframe(
                        ida,
                        *ca,
                        GrayImage {
                            data: &ia,
                            width: w,
                            height: h,
                            stride: w,
                        },
                    )
                    .expect("add");
                    v.add_keyframe(
                        idb,
                        *cb,
                        GrayImage {
                            data: &ib,
                            width: w,
                            height: h,
                            stride: w,
                        },
                    )
                    .expect("add");
                    let t0 = std::time::Instant::now();
                    let verdict = v.verify(ida, idb);
                    verify_time += t0.elapsed();
                    verify_count += 1;
                    if std::env::var_os("VERBOSE").is_some() {
                        // Ground truth b_T_a of the rendered poses.
                        let gt = on_road(&poses[j]).inverse() * on_road(&poses[i]);
                        let errors = verdict.pose.as_ref().map(|p| {
                            let r = (p.b_R_a.inverse() * gt.rotation.to_rotation_matrix())
                                .angle()
                                .to_degrees();
                            let t = if p.b_t_a.norm() > 0.0 {
                                p.b_t_a.angle(&gt.translation.vector).to_degrees()
                            } else {
                                f64::NAN
                            };
                            format!(
                                "rot err {r:.2} deg, t err {t:.1} deg, σ {:.2}/{:.1} deg",
                                p.rotation_std.to_degrees(),
                                p.translation_std.to_degrees()
                            )
                        });
                        println!(
                            "  {label} {i}-{j}: {} matches, {} {errors:?}",
                            verdict.matches, verdict.reason
                        );
                    }
                    if label == "true" {
                        if verdict.confirmed() {
                            tp += 1;
                        } else {
                            failures.push(format!("  missed {i}-{j}: {}", verdict.reason));
                        }
                    } else if verdict.confirmed() {
                        fp += 1;
                        failures.push(format!("  FALSE CONFIRMATION {i}-{j}: {}", verdict.reason));
                    }
                }
            }
            println!(
                "{seq} {name:16} confirmed {tp}/{} true, {fp}/{} false",
                trues.len(),
                falses.len()
            );
            for f in failures {
                println!("{f}");
            }
            totals[p].0 += tp;
            totals[p].1 += trues.len();
            totals[p].2 += fp;
            totals[p].3 += falses.len();
        }
    }
    println!("== totals");
    for ((name, _, _), (tp, nt, fp, nf)) in pairings.iter().zip(&totals) {
        let precision = if tp + fp > 0 {
            *tp as f64 / (*tp + *fp) as f64
        } else {
            1.0
        };
        println!("{name:16} recall {tp}/{nt} = {:.3}  precision {precision:.3}  false confirmations {fp}/{nf}", *tp as f64 / (*nt).max(1) as f64);
    }
    println!(
        "mean verify time {:.2} ms over {verify_count} verifications",
        verify_time.as_secs_f64() * 1e3 / verify_count.max(1) as f64
    );
}
