//! The stages against closed-form truth, on generated curves: a circle's
//! curvature is 1/r, a clothoid's is linear in arc length, the integral of
//! absolute curvature of a circle is s/r, and the segment boundaries of a
//! known piecewise path fall at its apexes and mid-straights. Each at
//! scales 0.01..100 of the same shape, since nothing may depend on metres.

use std::f64::consts::PI;

use nalgebra::{Vector2, Vector3};
use turnprint::pipeline::{Config, PreparedPath};
use turnprint::segments::{boundary_arc, segments};
use turnprint::track::Track;
use turnprint::Trajectory;

/// Scales the shapes are drawn at: what holds must hold at every one.
const SCALES: [f64; 3] = [0.01, 1.0, 100.0];

/// Samples per unit of the shape's own length scale: dense enough that the
/// sampling itself adds no error beyond the tolerances below.
const SAMPLES_PER_UNIT: f64 = 2.0;

/// Points of the curve whose curvature at arc length `s` is `kappa(s)`,
/// from 0 to `length`, one every `ds`, starting at the origin heading +x.
fn integrate(kappa: impl Fn(f64) -> f64, length: f64, ds: f64) -> Vec<Vector2<f64>> {
    let n = (length / ds).round() as usize;
    let (mut p, mut heading) = (Vector2::zeros(), 0.0f64);
    let mut out = vec![p];
    for i in 0..n {
        // Midpoint rule: the heading half a step on.
        let s = i as f64 * ds;
        let mid = heading + 0.5 * ds * kappa(s);
        p += ds * Vector2::new(mid.cos(), mid.sin());
        heading += ds * kappa(s + 0.5 * ds);
        out.push(p);
    }
    out
}

/// Track samples further than four smoothing bandwidths from either end,
/// where the kernel (three bandwidths) and the differentiation see the
/// curve on both sides.
fn interior(track: &Track) -> std::ops::Range<usize> {
    let margin = (4.0 * track.bandwidth / track.step).ceil() as usize;
    margin..track.s.len().saturating_sub(margin)
}

#[test]
fn a_circles_curvature_is_one_over_its_radius() {
    let mut errors = Vec::new();
    for scale in SCALES {
        let r = 20.0 * scale;
        let ds = scale / SAMPLES_PER_UNIT;
        let points = integrate(|_| 1.0 / r, 1.5 * 2.0 * PI * r, ds);
        let track = Track::build(&points).expect("a circle moves");
        let range = interior(&track);
        assert!(range.len() > 100, "scale {scale}: {range:?}");
        let worst = range
            .map(|i| (track.curvature[i].abs() * r - 1.0).abs())
            .fold(0.0, f64::max);
        errors.push(worst);
    }
    eprintln!("circle: worst relative curvature error per scale {errors:?}");
    // Kernel smoothing shrinks a circle by a factor of about
    // exp(-h^2 / 2r^2): 0.03 % at the bandwidth chosen here (one pose
    // spacing, a fortieth of the radius). The same at every scale.
    assert!(errors.iter().all(|e| *e < 0.002), "{errors:?}");
}

#[test]
fn a_clothoids_curvature_is_linear_in_arc_length() {
    let mut errors = Vec::new();
    for scale in SCALES {
        // kappa = s / a^2: heading s^2 / 2a^2, a quarter turn at s = a sqrt(pi).
        let a = 30.0 * scale;
        let length = a * (2.0 * PI).sqrt();
        let points = integrate(|s| s / (a * a), length, scale / SAMPLES_PER_UNIT);
        let track = Track::build(&points).expect("a clothoid moves");
        let range = interior(&track);
        assert!(range.len() > 100, "scale {scale}: {range:?}");
        let kappa_max = length / (a * a);
        let worst = range
            .map(|i| (track.curvature[i].abs() - track.s[i] / (a * a)).abs() / kappa_max)
            .fold(0.0, f64::max);
        errors.push(worst);
    }
    eprintln!("clothoid: worst curvature error over the peak per scale {errors:?}");
    // Against the largest curvature of the piece: the smoothed track's
    // arc length and curvature agree with the generator's to 1 %.
    assert!(errors.iter().all(|e| *e < 0.01), "{errors:?}");
}

#[test]
fn the_turning_of_a_circle_is_its_arc_length_over_its_radius() {
    for scale in SCALES {
        let r = 20.0 * scale;
        let points = integrate(|_| 1.0 / r, 2.0 * 2.0 * PI * r, scale / SAMPLES_PER_UNIT);
        let trajectory = Trajectory::from_positions("circle", &to_3d(&points));
        let path = PreparedPath::new(&trajectory, &Config::default()).expect("a circle");
        let sig = &path.signature;
        // K is sampled every dk, so consecutive samples are r dk apart in
        // arc length (K = s / r), and each holds sqrt(1 / r).
        let n = sig.s.len();
        assert!(n > 300, "scale {scale}: {n} samples");
        let steps: Vec<f64> = sig
            .s
            .windows(2)
            .map(|w| (w[1] - w[0]) / (r * sig.dk))
            .collect();
        let inner = &steps[n / 10..n - n / 10];
        let worst = inner.iter().map(|x| (x - 1.0).abs()).fold(0.0, f64::max);
        // The sign of curvature depends on which side the fitted plane's
        // normal points: direction-free, so only its size is checked.
        let value = sig.value[n / 2].abs() * r.sqrt();
        let turned = n as f64 * sig.dk;
        eprintln!(
            "circle at scale {scale}: ds/dK off by {worst:.4}, value {value:.4}, K {turned:.3}"
        );
        assert!(worst < 0.02, "scale {scale}: ds/dK off by {worst:.4}");
        assert!(
            (value - 1.0).abs() < 0.01,
            "scale {scale}: value {value:.4}"
        );
        // Two full turns: K spans 4 pi less what the ends' smoothing and
        // dead band take.
        assert!(
            turned > 0.9 * 4.0 * PI && turned < 4.0 * PI,
            "scale {scale}: K {turned:.3}"
        );
    }
}

/// A corner of turn `angle` (signed) and length `length`: curvature rising
/// linearly from 0 to its peak at the apex and back (two clothoids).
fn corner(s: f64, start: f64, length: f64, angle: f64) -> f64 {
    let x = s - start;
    if !(0.0..length).contains(&x) {
        return 0.0;
    }
    let peak = 2.0 * angle / length;
    peak * (1.0 - (2.0 * x / length - 1.0).abs())
}

fn to_3d(points: &[Vector2<f64>]) -> Vec<Vector3<f64>> {
    points.iter().map(|p| Vector3::new(p.x, p.y, 0.0)).collect()
}

#[test]
fn segment_boundaries_fall_at_the_apexes_and_mid_straights() {
    // Straights of 100 units and corners of 60, turning about +90, -90,
    // +120 and -60 degrees (a degree off: a turn of a whole number of K
    // steps would end exactly on a sample, a tie that rounding decides).
    let (straight, length) = (100.0, 60.0);
    let turns = [89f64, -91.0, 121.0, -61.0].map(f64::to_radians);
    let starts: Vec<f64> = (0..turns.len())
        .map(|i| straight + i as f64 * (straight + length))
        .collect();
    let total = straight + turns.len() as f64 * (straight + length);
    // Interior boundaries: the middle of each straight between two
    // corners, and the apexes of the 90° corners.
    // Each with how far a boundary may lie from it: a tenth of a corner at
    // an apex (the smoothing rounds it), a tenth of a straight in its
    // middle (a straight's boundary sits midway between the last turning
    // sample before it and the first after it, and the heading dead band
    // of 4° holds that one back by the few units a corner turning the
    // other way takes to turn 4°: up to 5 of 100 here).
    //
    // No apex boundary in the 120° corner: a boundary is an extremum of
    // ds/dK twice as tight as the curve within 40° of turning either side
    // (`SegmentConfig`), and 40° from this corner's apex the curvature is
    // still 0.58 of its peak (x - x²/L = 40°/κ_peak at x = 12.7 of 30), a
    // ratio of 1.73. The 90° corners reach 3 (a third of the peak 20 units
    // on). The last corner's apex is an end effect, allowed either way.
    let apex = |i: usize| (starts[i] + 0.5 * length, 0.1 * length);
    let mut expected: Vec<(f64, f64)> = vec![apex(0), apex(1)];
    expected.extend(
        starts
            .windows(2)
            .map(|w| (w[0] + length + 0.5 * straight, 0.1 * straight)),
    );
    expected.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (wide_apex, last_apex) = (apex(2), apex(3));
    for scale in SCALES {
        let kappa = |s: f64| -> f64 {
            let s = s / scale;
            starts
                .iter()
                .zip(turns)
                .map(|(&start, turn)| corner(s, start, length, turn))
                .sum::<f64>()
                / scale
        };
        let points = integrate(kappa, total * scale, scale / SAMPLES_PER_UNIT);
        let trajectory = Trajectory::from_positions("corners", &to_3d(&points));
        let path = PreparedPath::new(&trajectory, &Config::default()).expect("a path");
        let sig = &path.signature;
        let found: Vec<f64> = path.bounds[1..path.bounds.len() - 1]
            .iter()
            .map(|&k| boundary_arc(sig, k) / scale)
            .collect();
        eprintln!("corners at scale {scale}: boundaries at {found:.1?}, expected {expected:?}");
        let near = |f: f64, &(e, tolerance): &(f64, f64)| (f - e).abs() < tolerance;
        for e in &expected {
            assert!(
                found.iter().any(|f| near(*f, e)),
                "scale {scale}: none at {e:?}"
            );
        }
        for f in &found {
            assert!(
                expected.iter().chain([&last_apex]).any(|e| near(*f, e)),
                "scale {scale}: a boundary at {f:.1}"
            );
            assert!(
                !near(*f, &wide_apex),
                "scale {scale}: the 120° apex is a boundary"
            );
        }
        // The pieces' fitted curvature: zero mid-straight, the corner's
        // peak at an apex (to 10 % of the largest peak, the smoothing's
        // rounding).
        let peak = 2.0 * turns.iter().fold(0.0f64, |m, t| m.max(t.abs())) / (length * scale);
        for piece in segments(sig, &path.bounds) {
            for (kappa_fit, k) in piece.kappa.iter().zip([piece.start, piece.end]) {
                // At the boundary's own sample: a straight's boundary takes
                // the curvature of the last turning sample before it.
                let s = sig.s[k];
                let truth = kappa(s).abs();
                assert!(
                    (kappa_fit.abs() - truth).abs() < 0.1 * peak,
                    "scale {scale}: kappa {kappa_fit:.5} at s {:.1}, truth {truth:.5}",
                    s / scale
                );
            }
        }
    }
}
