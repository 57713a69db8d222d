//! The drift prior along the path between a revisit's two passes: how far
//! the odometry can have moved the later pass off the earlier one, given
//! where it drove in between, not only how far.
//!
//! Heading and log-scale drift are random walks along the path (`w(u)`,
//! `l(u)`, variances `h² du / L` and `k² du / L` for the prior's rates `h`,
//! `k` per square root of the matched length `L`). To first order the
//! correction `map_T_query` that lays the later pass at `x` back onto the
//! earlier one turns and moves it by
//!
//! ```text
//!   angle     = -∫ dw(u)
//!   offset(x) = -∫ J (x - p(u)) dw(u) - ∫ (x - p(u)) dl(u)
//! ```
//!
//! over the path `p(u)` in between (`J` the quarter turn): a heading error
//! picked up far from `x` swings it further, and it turns the pass as much
//! as it moves it. So angle and offset are one Gaussian, with covariance
//! `C = ∫ a aᵀ h² du / L + ∫ b bᵀ k² du / L` (`a = [1, J e]`, `b = [0, e]`,
//! `e = x - p(u)`), which needs only the path's arc-weighted moments `∫ du`,
//! `∫ p du` and `∫ p pᵀ du`. A look-alike road within the drift's reach is
//! laid there by a correction whose angle and offset do not agree the way
//! drift makes them agree: the Mahalanobis distance `vᵀ C⁻¹ v` tells it
//! from the revisit where separate bounds on the angle and on the offset's
//! length ([`DriftPrior::factor`]) cannot. The pass's own scale change is
//! left to that factor's heavy-tailed scale term: a monocular map's scale
//! drifts more than the prior's rate, and in bursts (KITTI 08's monocular
//! revisit).

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use super::history::HistoryView;
use super::register::BAND_FRACTION;
use crate::geometry::Similarity2;
use crate::score::DriftPrior;

/// Most track samples summed per path (a stride keeps the cost flat on
/// long histories; the moments are smooth in the path).
const SAMPLES: usize = 64;

/// Arc-weighted moments of a stretch of the track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathMoments {
    /// `∫ du`: the stretch's length.
    pub length: f64,
    /// `∫ p du`.
    pub first: Vector2<f64>,
    /// `∫ p pᵀ du`.
    pub second: Matrix2<f64>,
}

impl PathMoments {
    /// No path.
    pub fn zero() -> Self {
        PathMoments {
            length: 0.0,
            first: Vector2::zeros(),
            second: Matrix2::zeros(),
        }
    }

    /// The moments of a polyline, each segment weighted by its length at
    /// its middle.
    pub fn of_points(points: impl IntoIterator<Item = Vector2<f64>>) -> Self {
        let mut m = Self::zero();
        let mut points = points.into_iter();
        let Some(mut a) = points.next() else {
            return m;
        };
        for b in points {
            m.add(a, b, (b - a).norm());
            a = b;
        }
        m
    }

    /// The moments of the history's track between samples `g0` and `g1`
    /// (either order, clamped).
    pub fn between(h: &HistoryView, g0: usize, g1: usize) -> Self {
        let last = h.xy.len().saturating_sub(1);
        let (g0, g1) = (g0.min(g1).min(last), g0.max(g1).min(last));
        let stride = ((g1 - g0) / SAMPLES).max(1);
        let mut m = Self::zero();
        let mut i = g0;
        while i < g1 {
            let j = (i + stride).min(g1);
            m.add(h.point(i), h.point(j), h.s[j] - h.s[i]);
            i = j;
        }
        m
    }

    /// Adds the segment `a`-`b` of arc length `du`.
    fn add(&mut self, a: Vector2<f64>, b: Vector2<f64>, du: f64) {
        let p = 0.5 * (a + b);
        self.length += du;
        self.first += du * p;
        self.second += du * p * p.transpose();
    }

    /// `∫ e du` and `∫ e eᵀ du` for `e = x - p(u)`.
    fn about(&self, x: Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let e1 = self.length * x - self.first;
        let e2 = self.length * x * x.transpose()
            - x * self.first.transpose()
            - self.first * x.transpose()
            + self.second;
        (e1, e2)
    }
}

/// Squared Mahalanobis distance of the angle and offset of the correction
/// `map_T_query` of a revisit at `x` (query frame) under `prior`, with
/// `path` the moments of the path between the two passes and `length` the
/// matched length. The prior's heading floor and a road's lanes
/// ([`BAND_FRACTION`] of the length) stand for the fit's own uncertainty.
#[allow(non_snake_case)]
pub fn mahalanobis2(
    prior: &DriftPrior,
    map_T_query: &Similarity2,
    x: Vector2<f64>,
    path: &PathMoments,
    length: f64,
) -> f64 {
    let length = length.max(f64::MIN_POSITIVE);
    let angle = map_T_query.angle.sin().atan2(map_T_query.angle.cos());
    let offset = map_T_query.apply(&x) - x;
    let v = Vector3::new(angle, offset.x, offset.y);
    let (h2, k2) = (prior.heading.powi(2) / length, prior.scale.powi(2) / length);
    let (e1, e2) = path.about(x);
    // `J` is the derivative at no rotation; at the angle the fit found, the
    // secant `(R(angle) - I) / angle` keeps a single rotation's offset exact
    // (drift of 25° lays a point 500 m from where it turned 45 m off the
    // linear model).
    let turn = if angle.abs() > 1e-9 {
        Matrix2::new(
            angle.cos() - 1.0,
            -angle.sin(),
            angle.sin(),
            angle.cos() - 1.0,
        ) / angle
    } else {
        Matrix2::new(0.0, -1.0, 1.0, 0.0)
    };
    let cross = h2 * turn * e1;
    let spread = h2 * turn * e2 * turn.transpose()
        + k2 * e2
        + Matrix2::identity() * (BAND_FRACTION * length).powi(2);
    let c = Matrix3::new(
        h2 * path.length + prior.heading_floor.powi(2),
        cross.x,
        cross.y,
        cross.x,
        spread[(0, 0)],
        spread[(0, 1)],
        cross.y,
        spread[(1, 0)],
        spread[(1, 1)],
    );
    match c.cholesky() {
        Some(chol) => v.dot(&chol.solve(&v)),
        None => f64::INFINITY,
    }
}

/// The prior factor in `(0, 1]` of a squared Mahalanobis distance: as
/// heavy-tailed as [`DriftPrior::factor`]'s terms, three of them with the
/// distance split evenly, each at half the squared distance as a Gaussian
/// has it.
pub fn factor(m2: f64) -> f64 {
    (1.0 + m2.max(0.0) / 6.0).powi(-3)
}

#[cfg(test)]
mod tests;
