//! A synthetic drive for long-run and speed figures: a Manhattan street
//! grid (blocks of 100 units), one pose per unit of travel, rounded turns
//! at intersections chosen by a fixed pseudo-random sequence, small lateral
//! noise. It revisits streets often, like a delivery robot in a city.

use nalgebra::Vector3;

/// An endless synthetic drive (deterministic for a given seed).
#[derive(Debug, Clone)]
pub struct CityDrive {
    state: u64,
    p: Vector3<f64>,
    heading: f64,
    /// Remaining straight length before the next intersection.
    straight: f64,
    /// Remaining turn (radians, signed) at one turn step per pose.
    turn_left: f64,
}

/// Block length (units).
const BLOCK: f64 = 100.0;
/// Turn radius (units): a quarter turn takes about 16 poses.
const RADIUS: f64 = 10.0;

impl CityDrive {
    /// A drive from the origin heading east.
    pub fn new(seed: u64) -> Self {
        CityDrive {
            state: seed ^ 0x9e37_79b9_7f4a_7c15,
            p: Vector3::zeros(),
            heading: 0.0,
            straight: BLOCK,
            turn_left: 0.0,
        }
    }

    fn next_u(&mut self) -> f64 {
        self.state = self
            .state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.state >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl Iterator for CityDrive {
    type Item = Vector3<f64>;

    fn next(&mut self) -> Option<Vector3<f64>> {
        let step = 1.0;
        if self.turn_left.abs() > 1e-9 {
            let d = (step / RADIUS).min(self.turn_left.abs()) * self.turn_left.signum();
            self.heading += d;
            self.turn_left -= d;
        } else if self.straight <= 0.0 {
            let u = self.next_u();
            self.turn_left = if u < 0.3 {
                std::f64::consts::FRAC_PI_2
            } else if u < 0.6 {
                -std::f64::consts::FRAC_PI_2
            } else {
                0.0
            };
            // Blocks counted from the end of the turn: a quarter turn
            // shortens the straight by its radius on both sides.
            self.straight = BLOCK
                - if self.turn_left != 0.0 {
                    2.0 * RADIUS
                } else {
                    0.0
                };
        } else {
            self.straight -= step;
        }
        let noise = (self.next_u() - 0.5) * 0.05;
        self.p += Vector3::new(self.heading.cos(), self.heading.sin(), 0.0) * step;
        Some(self.p + Vector3::new(-self.heading.sin(), self.heading.cos(), 0.0) * noise)
    }
}
