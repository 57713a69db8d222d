//! Invariance properties on a real path (KITTI 00 ground truth, from the
//! shared data): matching a copy of a path under any similarity (scale
//! 0.01..100, any 3D rotation, any translation), in either direction, gives
//! the transform back, and the copy's segment boundaries fall at the same
//! arc-length fractions.

use std::sync::OnceLock;

use nalgebra::{Rotation3, Unit, Vector3};
use proptest::prelude::*;
use turnprint::io::{read_trajectory, Format};
use turnprint::pipeline::{match_paths, Config, PreparedPath};
use turnprint::Trajectory;

mod common;

/// KITTI 00 ground truth, read once (`None`, said once, when absent).
fn kitti_00() -> Option<&'static Trajectory> {
    static FULL: OnceLock<Option<Trajectory>> = OnceLock::new();
    FULL.get_or_init(|| {
        let path = common::shared("kitti_gt/00.txt")?;
        Some(read_trajectory(&path, Format::Kitti).expect("KITTI 00 reads"))
    })
    .as_ref()
}

/// Poses `first..=last` of KITTI 00 ground truth, or `None` when absent.
fn kitti_window(first: usize, last: usize) -> Option<Trajectory> {
    Some(Trajectory {
        source: format!("00[{first}..{last}]"),
        poses: kitti_00()?.poses[first..=last].to_vec(),
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
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn match_recovers_any_similarity(
        log_s in -2.0f64..2.0,
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..std::f64::consts::TAU,
        t in prop::array::uniform3(-1e4f64..1e4),
        reversed in any::<bool>(),
    ) {
        let Some(a) = kitti_window(0, 1500) else {
            return Ok(());
        };
        let (s, r, t) = (10f64.powf(log_s), rotation(axis, angle), Vector3::from(t));
        let b = disguise(&a, s, &r, &t, reversed);
        let hyps = match_paths(&a, &b, &Config::for_matching()).expect("valid paths");
        let h = hyps.first().expect("a hypothesis");
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
        log_s in -2.0f64..2.0,
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..std::f64::consts::TAU,
        reversed in any::<bool>(),
    ) {
        let Some(a) = kitti_window(300, 2300) else {
            return Ok(());
        };
        let b = disguise(&a, 10f64.powf(log_s), &rotation(axis, angle), &Vector3::new(5.0, -3.0, 1.0), reversed);
        let config = Config::default();
        let (pa, pb) = (PreparedPath::new(&a, &config).unwrap(), PreparedPath::new(&b, &config).unwrap());
        let fa = boundary_fractions(&pa);
        let mut fb = boundary_fractions(&pb);
        if reversed {
            fb = fb.iter().map(|f| 1.0 - f).rev().collect();
        }
        // Same direction: boundaries at the same fraction (to 0.2 %; a
        // near-tie between two extrema may flip in floating point).
        // Reversed: the heading dead band lags the other way, which moves
        // K samples by up to its width; most boundaries stay within 1 % and
        // an occasional weak one appears or vanishes.
        let (tolerance, allowed_moves) = if reversed { (0.01, 0.15) } else { (0.002, 0.07) };
        let interior = &fa[1..fa.len() - 1];
        let missing: Vec<f64> = interior
            .iter()
            .copied()
            .filter(|f| !fb.iter().any(|g| (f - g).abs() < tolerance))
            .collect();
        prop_assert!(
            missing.len() as f64 <= allowed_moves * interior.len() as f64,
            "{} of {} boundaries moved: {missing:?}", missing.len(), interior.len()
        );
    }
}
