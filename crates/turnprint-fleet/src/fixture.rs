//! Generated drives for the fleet's tests and figures when no real data is
//! at hand: a curvature that varies smoothly at random (a sum of sines of
//! random wavelengths and phases), so that turns of every sharpness follow
//! each other and no two stretches of road look alike (the library's
//! `CityDrive` turns only at right angles on a grid, where every block
//! matches every other). Windows of one drive, each put under a known
//! similarity, are robots that share road; another seed's drive is a
//! stranger.

use nalgebra::{Matrix3, Rotation3, Vector3};
use turnprint::geometry::Similarity3;

/// Sines summed into the curvature.
const SINES: usize = 6;
/// Shortest and longest wavelength of the curvature (path units, one pose
/// per unit): turns from about a block to a few blocks long.
const WAVELENGTHS: (f64, f64) = (60.0, 500.0);
/// Largest curvature of one sine (1/units): together they reach radii of
/// about 15 units, a street corner at one pose per metre.
const AMPLITUDE: f64 = 0.015;
/// Lateral noise (units): a few centimetres of odometry jitter.
const NOISE: f64 = 0.03;

/// A deterministic pseudo-random sequence in [0, 1).
#[derive(Debug, Clone)]
pub struct Lcg(u64);

impl Lcg {
    /// The sequence of `seed`.
    pub fn new(seed: u64) -> Lcg {
        Lcg(seed ^ 0x9e37_79b9_7f4a_7c15)
    }

    /// The next number.
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A number in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

/// `poses` positions of the drive of `seed`, one unit apart, in the plane
/// `z = 0`.
pub fn curvy_drive(seed: u64, poses: usize) -> Vec<Vector3<f64>> {
    let mut rng = Lcg::new(seed);
    let sines: Vec<(f64, f64)> = (0..SINES)
        .map(|_| {
            let wavelength = rng.range(WAVELENGTHS.0, WAVELENGTHS.1);
            (
                std::f64::consts::TAU / wavelength,
                rng.range(0.0, std::f64::consts::TAU),
            )
        })
        .collect();
    let (mut p, mut heading) = (Vector3::zeros(), 0.0f64);
    (0..poses)
        .map(|i| {
            let s = i as f64;
            let kappa: f64 = sines
                .iter()
                .map(|(w, phi)| AMPLITUDE * (w * s + phi).sin())
                .sum();
            heading += kappa;
            p += Vector3::new(heading.cos(), heading.sin(), 0.0);
            let noise = rng.range(-NOISE, NOISE);
            p + Vector3::new(-heading.sin(), heading.cos(), 0.0) * noise
        })
        .collect()
}

/// A random similarity: scale in 0.5..2, any rotation about the vertical
/// with a tilt of up to 0.2 rad, a translation of up to 1000 units.
pub fn random_similarity(rng: &mut Lcg) -> Similarity3 {
    let yaw = Rotation3::from_axis_angle(
        &Vector3::z_axis(),
        rng.range(-std::f64::consts::PI, std::f64::consts::PI),
    );
    let tilt = Rotation3::from_axis_angle(&Vector3::x_axis(), rng.range(-0.2, 0.2));
    let rotation: Matrix3<f64> = (tilt * yaw).into_inner();
    Similarity3 {
        scale: rng.range(0.0, 2f64.ln() * 2.0).exp() * 0.5,
        rotation,
        translation: Vector3::new(
            rng.range(-1000.0, 1000.0),
            rng.range(-1000.0, 1000.0),
            rng.range(-50.0, 50.0),
        ),
    }
}

/// TUM lines (`t x y z qx qy qz qw`, identity orientations) of `points`.
pub fn tum(points: &[Vector3<f64>]) -> String {
    points
        .iter()
        .enumerate()
        .map(|(i, p)| format!("{i} {:.6} {:.6} {:.6} 0 0 0 1\n", p.x, p.y, p.z))
        .collect()
}
