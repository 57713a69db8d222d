//! Records of one walk by different apps: each smooths its own way (GCV in
//! its own pose spacings, widened while its turning falls like wobble), and
//! their bandwidths end up several times apart in metres. The first match
//! then finds only look-alikes; matched again smoothed alike
//! (`pipeline::alike`), the walk is placed. A walk thinned far enough was
//! smoothed too wide to be matched at all (`track::smooth`).

mod common;

use nalgebra::{Rotation3, Vector3};
use turnprint::pipeline::{match_paths, Config};
use turnprint::{Hypothesis, Trajectory};
use turnprint_eval::checks::median;
use turnprint_eval::kinds::catalog::{catalog, Session};

/// The two sessions of these names (catalogue names and data files), or
/// `None` after a line saying the test is skipped.
fn two_sessions(names: [&str; 2], files: [&str; 2]) -> Option<[Session; 2]> {
    let dir = common::shared_dir(&files)?;
    let sessions = catalog(&dir).sessions;
    Some(names.map(|name| {
        sessions
            .iter()
            .find(|s| s.name == name)
            .unwrap_or_else(|| panic!("{name} in the catalog"))
            .clone()
    }))
}

/// `disguised` (B, whose points are truly at `b_truth`) matched against
/// `a`: the rank-1 hypothesis, the median distance of B's points mapped by
/// it from their truth, and B's length.
fn placed(
    a: &[Vector3<f64>],
    disguised: &[Vector3<f64>],
    b_truth: &[Vector3<f64>],
) -> (Hypothesis, f64, f64) {
    let hypotheses = match_paths(
        &Trajectory::from_positions("a", a),
        &Trajectory::from_positions("b", disguised),
        &Config::for_matching(),
    )
    .expect("matches");
    let best = hypotheses.first().expect("a hypothesis").clone();
    let length: f64 = b_truth.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    let errors: Vec<f64> = disguised
        .iter()
        .zip(b_truth)
        .map(|(p, truth)| (best.transform(p) - truth).norm())
        .collect();
    (best, median(&errors), length)
}

#[test]
fn two_apps_on_one_walk_smoothed_apart_were_placed_by_a_look_alike() {
    let Some([a, b]) = two_sessions(
        ["routage Guichet_asc_orux", "routage Guichet_asc_suunto"],
        [
            "multisession/gpx_same_route/routage/Guichet_asc_orux.gpx",
            "multisession/gpx_same_route/routage/Guichet_asc_suunto.gpx",
        ],
    ) else {
        return;
    };
    // B: every second point of the other app, backwards, 1/50 the size and
    // turned (`b_T_world`); A: the first app's track as it is.
    let scale = 0.02;
    let b_r_world = Rotation3::from_euler_angles(0.4, -0.3, 2.0);
    let b_points: Vec<Vector3<f64>> = b.input.iter().step_by(2).rev().copied().collect();
    let b_truth: Vec<Vector3<f64>> = b.truth.iter().step_by(2).rev().copied().collect();
    let disguised: Vec<Vector3<f64>> = b_points
        .iter()
        .map(|p| scale * (b_r_world * p) + Vector3::new(3.0, -1.0, 0.5))
        .collect();
    let (best, median, length) = placed(&a.truth, &disguised, &b_truth);
    // Right: the disguise undone (scale and turn) and B's points where the
    // other app put them, within 2 % of B's length (median).
    assert!(
        (best.scale * scale - 1.0).abs() < 0.05,
        "scale {} (true {})",
        best.scale,
        1.0 / scale
    );
    assert!(
        median < 0.02 * length,
        "median error {median:.1} m over a walk of {length:.0} m (score {:.3})",
        best.score
    );
}

/// A walk recorded with a fix every five seconds (the catalogue keeps every
/// fifth of its 28 130 points): its turning falls like `bandwidth^-0.7` at
/// every scale, GPS wander and streets alike, so the wobble test widened its
/// smoothing to 45 pose spacings, 405 m, and matched against its planned
/// route (a point every 20 m, smoothed over 14 m) it found only
/// look-alikes (score 0.04). The widening now stops at a quarter of the
/// road between its right-angle turns (`track::smooth`).
#[test]
fn a_walk_thinned_to_a_fix_every_five_seconds_was_smoothed_over_400_m_and_lost_its_route() {
    let Some([route, walk]) = two_sessions(
        [
            "arbatov RouteBstd",
            "arbatov Evgeny_Arbatov_2023-09-30_14-12-50",
        ],
        [
            "multisession/gpx_same_route/arbatov/RouteBstd.gpx",
            "multisession/gpx_same_route/arbatov/Evgeny_Arbatov_2023-09-30_14-12-50.GPX",
        ],
    ) else {
        return;
    };
    // The walk backwards, ten times the size and turned; both in one frame
    // (east-north-up at the folder's first point), so the truth is the
    // disguise undone.
    let b_r_world = Rotation3::from_euler_angles(-0.2, 0.5, 1.0);
    let truth: Vec<Vector3<f64>> = walk.truth.iter().rev().copied().collect();
    let disguised: Vec<Vector3<f64>> = truth.iter().map(|p| 10.0 * (b_r_world * p)).collect();
    let (best, median, length) = placed(&route.truth, &disguised, &truth);
    assert!(
        median < 0.02 * length,
        "median error {median:.0} m over a walk of {length:.0} m (score {:.3}, scale {:.4})",
        best.score,
        best.scale
    );
}
