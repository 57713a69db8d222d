//! Invariance properties on real paths (windows of the ground truth of the
//! KITTI drives with loops, from the shared data): matching a copy of a path
//! under any similarity (scale log-uniform over 0.01..100, any 3D rotation,
//! any translation), in either direction, gives the transform back; the
//! copy's segment boundaries fall at the same arc-length fractions, and a
//! reversed copy keeps most of them.

use std::sync::OnceLock;

use nalgebra::{Rotation3, Unit, Vector3};
use proptest::prelude::*;
use turnprint::io::{read_trajectory, Format};
use turnprint::pipeline::{match_paths, Config, PreparedPath};
use turnprint::Trajectory;

mod common;

/// The drives the windows are drawn from: a city loop, a long suburban
/// drive, two residential ones and a drive of many blocks.
const DRIVES: [&str; 5] = ["00", "02", "05", "06", "08"];

/// Every drive's ground truth, read once (`None`, said once, when absent).
fn drives() -> Option<&'static [Trajectory]> {
    static ALL: OnceLock<Option<Vec<Trajectory>>> = OnceLock::new();
    ALL.get_or_init(|| {
        DRIVES
            .iter()
            .map(|d| {
                let path = common::shared(&format!("kitti_gt/{d}.txt"))?;
                Some(read_trajectory(&path, Format::Kitti).expect("KITTI ground truth reads"))
            })
            .collect()
    })
    .as_deref()
}

/// A window of `poses` poses (the whole drive if shorter) of drive `drive`
/// (an index into [`DRIVES`]), starting at `start` (a fraction of where it
/// can start), or `None` when the data is absent.
fn kitti_window(drive: usize, start: f64, poses: usize) -> Option<Trajectory> {
    let all = &drives()?[drive].poses;
    let poses = poses.min(all.len());
    let first = ((all.len() - poses) as f64 * start) as usize;
    Some(Trajectory {
        source: format!("{}[{first}..{}]", DRIVES[drive], first + poses),
        poses: all[first..first + poses].to_vec(),
    })
}

/// `p_b = s R p_a + t`, in reverse order when `reversed`.
fn disguise(
    a: &Trajectory,
    s: f64,
    r: &Rotation3<f64>,
    t: &Vector3<f64>,
    reversed: bool,
) -> Trajectory {
    let mut pts: Vec<Vector3<f64>> = a.positions().iter().map(|p| s * (r * p) + t).collect();
    if reversed {
        pts.reverse();
    }
    Trajectory::from_positions("copy", &pts)
}

fn rotation(axis: [f64; 3], angle: f64) -> Rotation3<f64> {
    let v = Vector3::from(axis);
    let axis = if v.norm() > 1e-6 {
        Unit::new_normalize(v)
    } else {
        Vector3::z_axis()
    };
    Rotation3::from_axis_angle(&axis, angle)
}

/// Boundaries as fractions of the track length.
fn boundary_fractions(p: &PreparedPath) -> Vec<f64> {
    let total = p.track.length();
    p.bounds
        .iter()
        .map(|&k| turnprint::segments::boundary_arc(&p.signature, k) / total)
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, .. ProptestConfig::default() })]

    #[test]
    fn match_recovers_any_similarity(
        drive in 0..DRIVES.len(),
        start in 0.0f64..1.0,
        log_s in -2.0f64..2.0,
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..std::f64::consts::TAU,
        t in prop::array::uniform3(-1e4f64..1e4),
        reversed in any::<bool>(),
    ) {
        let Some(a) = kitti_window(drive, start, 1500) else {
            return Ok(());
        };
        let (s, r, t) = (10f64.powf(log_s), rotation(axis, angle), Vector3::from(t));
        let b = disguise(&a, s, &r, &t, reversed);
        let hyps = match_paths(&a, &b, &Config::for_matching()).expect("valid paths");
        let h = hyps.first().ok_or_else(|| TestCaseError::fail(format!("no hypothesis for {}", a.source)))?;
        // The copy maps back with the inverse: scale 1/s, rotation R^T.
        let scale_err = (h.scale * s - 1.0).abs();
        let r_err = (h.rotation * r.matrix()).trace();
        let angle_err = ((r_err - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
        prop_assert!(scale_err < 0.005, "scale error {:.4} %", 100.0 * scale_err);
        prop_assert!(angle_err < 0.5, "rotation error {angle_err:.3} deg");
        prop_assert_eq!(h.reversed, reversed);
    }

    #[test]
    fn boundaries_fall_at_the_same_arc_fractions(
        drive in 0..DRIVES.len(),
        start in 0.0f64..1.0,
        log_s in -2.0f64..2.0,
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..std::f64::consts::TAU,
    ) {
        let Some(a) = kitti_window(drive, start, 2000) else {
            return Ok(());
        };
        let b = disguise(&a, 10f64.powf(log_s), &rotation(axis, angle), &Vector3::new(5.0, -3.0, 1.0), false);
        let config = Config::default();
        let (pa, pb) = (PreparedPath::new(&a, &config).unwrap(), PreparedPath::new(&b, &config).unwrap());
        let fa = boundary_fractions(&pa);
        let fb = boundary_fractions(&pb);
        // Boundaries at the same fraction, to 0.2 %; a near-tie between two
        // extrema may flip in floating point (one of 16 on drive 00 rotated
        // by 129 degrees about x, at scale 1 but not at 10.6).
        let missing = moved(&fa[1..fa.len() - 1], &fb, 0.002);
        prop_assert!(
            missing.len() <= 1,
            "{} of {} boundaries moved: {missing:?}", missing.len(), fa.len() - 2
        );
    }
}

/// The interior boundaries of `fa` with no counterpart in `fb` within
/// `tolerance`, each with how far its nearest counterpart is.
fn moved(fa: &[f64], fb: &[f64], tolerance: f64) -> Vec<(f64, f64)> {
    fa.iter()
        .map(|f| {
            (
                *f,
                fb.iter()
                    .map(|g| (f - g).abs())
                    .fold(f64::INFINITY, f64::min),
            )
        })
        .filter(|&(_, d)| d >= tolerance)
        .collect()
}

/// The share of boundaries a reversed copy keeps within 2 % of arc length
/// is at least this (measured 0.911 over the 128 draws below, 1450 of 1592;
/// the margin is a few windows' worth). Reversed, the heading dead band
/// lags the other way and moves K samples by up to its width, so weak
/// boundaries appear or vanish: the worst window keeps 0.69 of them.
const MIN_KEPT_REVERSED: f64 = 0.85;

/// Reversed copies of windows of every drive (128 fixed draws: drive,
/// start, log-uniform scale, rotation) keep most of their boundaries.
#[test]
fn reversed_copies_keep_most_boundaries() {
    use rand::{Rng, SeedableRng};
    if drives().is_none() {
        return;
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let config = Config::default();
    let (mut kept, mut total, mut worst) = (0usize, 0usize, 1.0f64);
    for case in 0..128 {
        let a = kitti_window(case % DRIVES.len(), rng.random(), 2000).unwrap();
        let axis = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ];
        let r = rotation(axis, rng.random_range(0.0..std::f64::consts::TAU));
        let b = disguise(
            &a,
            10f64.powf(rng.random_range(-2.0..2.0)),
            &r,
            &Vector3::new(5.0, -3.0, 1.0),
            true,
        );
        let fa = boundary_fractions(&PreparedPath::new(&a, &config).unwrap());
        let fb: Vec<f64> = boundary_fractions(&PreparedPath::new(&b, &config).unwrap())
            .iter()
            .map(|f| 1.0 - f)
            .collect();
        let interior = &fa[1..fa.len() - 1];
        let lost = moved(interior, &fb, 0.02).len();
        kept += interior.len() - lost;
        total += interior.len();
        worst = worst.min(1.0 - lost as f64 / interior.len() as f64);
    }
    let share = kept as f64 / total as f64;
    eprintln!("reversed: {kept} of {total} boundaries kept ({share:.3}), worst window {worst:.3}");
    assert!(share >= MIN_KEPT_REVERSED, "{share}");
}
