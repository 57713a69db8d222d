// Frame names as Sophus writes them: `a_T_b` maps points from b to a.
#![allow(non_snake_case)]

use super::*;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};

/// A loop of radius `r` driven once from `(r, 0)`, then its first
/// `overlap` driven again, every `ds`: the revisit's two passes.
fn circle_and_revisit(r: f64, overlap: f64, ds: f64) -> Vec<Vector2<f64>> {
    let total = std::f64::consts::TAU * r + overlap;
    (0..=(total / ds) as usize)
        .map(|i| {
            let a = i as f64 * ds / r;
            Vector2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

/// The path with a heading random walk of `h` per square root of `length`
/// (as the prior models it) integrated along it, from its first point.
fn drifted(points: &[Vector2<f64>], h: f64, length: f64, rng: &mut impl Rng) -> Vec<Vector2<f64>> {
    let mut w = 0.0;
    let mut out = vec![points[0]];
    for pair in points.windows(2) {
        let d = pair[1] - pair[0];
        // Box-Muller: the walk's step over this segment.
        let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
        w += h
            * (d.norm() / length).sqrt()
            * (-2.0 * u1.ln()).sqrt()
            * (std::f64::consts::TAU * u2).cos();
        let (s, c) = w.sin_cos();
        let last = *out.last().unwrap();
        out.push(last + Vector2::new(c * d.x - s * d.y, s * d.x + c * d.y));
    }
    out
}

/// `a_T_b` as a similarity.
fn sim(scale: f64, angle: f64, t: Vector2<f64>) -> Similarity2 {
    Similarity2 {
        scale,
        angle,
        translation: t,
    }
}

/// No correction is no drift.
#[test]
fn the_identity_is_at_no_distance() {
    let path = PathMoments::of_points(circle_and_revisit(100.0, 0.0, 1.0));
    let m2 = mahalanobis2(
        &DriftPrior::default(),
        &Similarity2::identity(),
        Vector2::new(100.0, 0.0),
        &path,
        50.0,
    );
    assert!(m2.abs() < 1e-12, "{m2}");
}

/// The history's moments are the polyline's.
#[test]
fn moments_are_additive_along_the_path() {
    let points = circle_and_revisit(30.0, 10.0, 0.5);
    let whole = PathMoments::of_points(points.iter().copied());
    let k = points.len() / 3;
    let a = PathMoments::of_points(points[..=k].iter().copied());
    let b = PathMoments::of_points(points[k..].iter().copied());
    assert!((whole.length - a.length - b.length).abs() < 1e-9);
    assert!((whole.first - a.first - b.first).norm() < 1e-6);
    assert!((whole.second - a.second - b.second).norm() < 1e-3);
}

/// Heading drift simulated as the prior models it lays the revisit where
/// the prior expects it: over many walks the distance has the mean of a
/// three-dimensional Gaussian's (at most; the fit's floors add variance),
/// and the default cut keeps most of them.
#[test]
fn simulated_heading_drift_is_where_the_prior_expects_it() {
    let prior = DriftPrior::default();
    let (r, length, ds) = (200.0, 60.0, 1.0);
    let truth = circle_and_revisit(r, length, ds);
    let n = (length / ds) as usize;
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let mut m2s = Vec::new();
    for _ in 0..300 {
        let drift = drifted(&truth, prior.heading, length, &mut rng);
        // The query window: the last `length` driven, truly on the first.
        let q0 = truth.len() - 1 - n;
        let pairs: Vec<_> = (q0..truth.len()).map(|i| (truth[i], drift[i])).collect();
        let map_T_query = Similarity2::fit_rigid(&pairs).unwrap();
        let x = drift[q0..].iter().sum::<Vector2<f64>>() / (n + 1) as f64;
        let path = PathMoments::of_points(drift[n / 2..=q0 + n / 2].iter().copied());
        m2s.push(mahalanobis2(&prior, &map_T_query, x, &path, length));
    }
    let mean = m2s.iter().sum::<f64>() / m2s.len() as f64;
    let kept = m2s.iter().filter(|&&m| m <= 5.0).count() as f64 / m2s.len() as f64;
    assert!((0.5..=3.5).contains(&mean), "mean {mean}");
    assert!(kept >= 0.8, "kept {kept}");
}

/// A look-alike: the revisit's own angle, but an offset the angle does not
/// explain (as far the other way). The batch prior's separate terms give
/// both the same factor; the joint prior keeps the revisit, not the
/// look-alike.
#[test]
fn an_offset_the_angle_does_not_explain_is_far() {
    let prior = DriftPrior::default();
    let (r, length, angle) = (200.0, 60.0, 0.3);
    let path = PathMoments::of_points(circle_and_revisit(r, 0.0, 1.0));
    let x = Vector2::new(r, 0.0);
    // The drift turned the path by `angle` a quarter of the loop back.
    let turned_at = Vector2::new(0.0, r);
    let t = turned_at - sim(1.0, angle, Vector2::zeros()).apply(&turned_at);
    let revisit = sim(1.0, angle, t);
    let offset = revisit.apply(&x) - x;
    let look_alike = sim(1.0, angle, t - 2.0 * offset);
    let between = std::f64::consts::TAU * r;
    let separate =
        |c: &Similarity2| prior.factor(angle, 1.0, (c.apply(&x) - x).norm(), length, between);
    assert!((separate(&revisit) - separate(&look_alike)).abs() < 1e-12);
    let true_m2 = mahalanobis2(&prior, &revisit, x, &path, length);
    let false_m2 = mahalanobis2(&prior, &look_alike, x, &path, length);
    assert!(true_m2 < 2.5, "{true_m2}");
    assert!(false_m2 > 6.0, "{false_m2}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    /// The distance is the same in any frame and at any scale: moving,
    /// turning and scaling the path, the revisit and its correction alike
    /// changes nothing (no metre constant, no preferred direction).
    #[test]
    fn the_distance_is_invariant_to_frame_and_scale(
        angle in -0.5..0.5f64,
        tx in -50.0..50.0f64,
        ty in -50.0..50.0f64,
        frame_angle in -3.1..3.1f64,
        log10_scale in -2.0..2.0f64,
        fx in -1000.0..1000.0f64,
        fy in -1000.0..1000.0f64,
    ) {
        // Log-uniform over 0.01..100: half the cases shrink the path.
        let frame_scale = 10f64.powf(log10_scale);
        let prior = DriftPrior::default();
        let points = circle_and_revisit(150.0, 40.0, 2.0);
        let x = Vector2::new(150.0, 20.0);
        let map_T_query = sim(1.0, angle, Vector2::new(tx, ty));
        let m2 = mahalanobis2(&prior, &map_T_query, x, &PathMoments::of_points(points.iter().copied()), 40.0);
        // world_T_frame and the same correction seen in the world frame.
        let world_T_frame = sim(frame_scale, frame_angle, Vector2::new(fx, fy));
        let frame_T_world = world_T_frame.inverse();
        let moved: Vec<_> = points.iter().map(|p| world_T_frame.apply(p)).collect();
        let world_map_T_query = |p: &Vector2<f64>| world_T_frame.apply(&map_T_query.apply(&frame_T_world.apply(p)));
        let xw = world_T_frame.apply(&x);
        let t = world_map_T_query(&Vector2::zeros());
        let in_world = sim(1.0, angle, t);
        prop_assert!((in_world.apply(&xw) - world_map_T_query(&xw)).norm() < 1e-6 * frame_scale.max(1.0));
        let m2w = mahalanobis2(&prior, &in_world, xw, &PathMoments::of_points(moved), 40.0 * frame_scale);
        prop_assert!((m2 - m2w).abs() <= 1e-6 * m2.max(1.0), "{m2} vs {m2w}");
    }
}
