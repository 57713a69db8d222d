//! Whether a match between two paths holds them the same way up.
//!
//! Each path is matched in its own best-fit plane, seen from either side
//! (`query.mirror`): a plane has no up. Seen from the wrong side, a layout
//! whose pieces are alike mirrored (a room walked round in arcs, a flight
//! of loops) fits turned over, a rotation of half a turn about a line in
//! the plane. The plane then carries each path's heights above it upside
//! down, so what climbs in one descends in the other: the heights of the
//! matched points agree better negated than as they are. Where heights are
//! noise, both ways fit alike and the score keeps all of it.

use nalgebra::Vector3;

use crate::geometry::Similarity3;

/// The share of a match's score kept for how its heights agree: 1 where
/// the matched points' heights along A's plane normal `normal` (mean
/// removed) agree at least as well as they would negated, else the ratio
/// of the two RMS misfits, negated over as they are (`a_T_b` maps B onto
/// A; `pairs` are `(p_a, p_b)` in each path's frame).
///
/// A ratio of two misfits of the same points, so free of scale and of the
/// heights' size: flat paths and noisy altimeters fit both ways alike and
/// keep their score.
#[allow(non_snake_case)]
pub fn upright_factor(
    pairs: &[(Vector3<f64>, Vector3<f64>)],
    a_T_b: &Similarity3,
    normal: &Vector3<f64>,
) -> f64 {
    if pairs.len() < 3 {
        return 1.0;
    }
    let n = pairs.len() as f64;
    let h: Vec<(f64, f64)> = pairs
        .iter()
        .map(|(p_a, p_b)| (normal.dot(p_a), normal.dot(&a_T_b.apply(p_b))))
        .collect();
    let mean_a = h.iter().map(|x| x.0).sum::<f64>() / n;
    let mean_b = h.iter().map(|x| x.1).sum::<f64>() / n;
    let (mut upright, mut turned) = (0.0, 0.0);
    for (a, b) in &h {
        let (a, b) = (a - mean_a, b - mean_b);
        upright += (a - b) * (a - b);
        turned += (a + b) * (a + b);
    }
    // Not finite (bad input) or upright at least as close: all of it.
    match upright.is_finite() && turned.is_finite() && upright > turned {
        true => (turned / upright).sqrt(),
        false => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, UnitQuaternion};

    /// A path that climbs and turns: heights carry a shape.
    fn climbing() -> Vec<Vector3<f64>> {
        (0..200)
            .map(|i| {
                let t = i as f64 * 0.05;
                Vector3::new(t.cos() * 3.0, t.sin() * 2.0, (1.7 * t).sin())
            })
            .collect()
    }

    /// Corresponding points `(p_a, p_b)`.
    type Pairs = Vec<(Vector3<f64>, Vector3<f64>)>;

    #[allow(non_snake_case)]
    fn pairs_under(b_T_a: &Similarity3, pts: &[Vector3<f64>]) -> Pairs {
        pts.iter().map(|p| (*p, b_T_a.apply(p))).collect()
    }

    /// The climbing path as A and as B under an oblique similarity of
    /// `scale`: the pairs and the right `a_T_b`.
    fn climbing_under(scale: f64) -> (Pairs, Similarity3) {
        let b_t_a = Similarity3 {
            scale,
            rotation: UnitQuaternion::from_scaled_axis(
                Vector3::new(0.3, -0.8, 0.5).normalize() * 2.1,
            )
            .to_rotation_matrix()
            .into_inner(),
            translation: Vector3::new(5.0, -2.0, 1.0),
        };
        (pairs_under(&b_t_a, &climbing()), b_t_a.inverse())
    }

    #[test]
    fn a_right_match_keeps_its_whole_score_in_any_frame() {
        let (pairs, a_t_b) = climbing_under(37.0);
        assert_eq!(upright_factor(&pairs, &a_t_b, &Vector3::z()), 1.0);
    }

    #[test]
    fn a_match_turned_over_loses_score() {
        let (pairs, a_t_b) = climbing_under(0.02);
        // Half a turn about the x axis after the right map: heights negated.
        let flip = Similarity3 {
            scale: 1.0,
            rotation: Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
                .into_inner(),
            translation: Vector3::zeros(),
        };
        let f = upright_factor(&pairs, &flip.compose(&a_t_b), &Vector3::z());
        assert!(f < 0.05, "{f}");
    }

    #[test]
    fn flat_paths_and_too_few_points_keep_their_score() {
        let flat: Vec<_> = climbing()
            .iter()
            .map(|p| Vector3::new(p.x, p.y, 0.0))
            .collect();
        let id = Similarity3::identity();
        assert_eq!(
            upright_factor(&pairs_under(&id, &flat), &id, &Vector3::z()),
            1.0
        );
        assert_eq!(upright_factor(&[], &id, &Vector3::z()), 1.0);
        let nan = vec![(Vector3::new(f64::NAN, 0.0, 1.0), Vector3::zeros()); 5];
        assert_eq!(upright_factor(&nan, &id, &Vector3::z()), 1.0);
    }
}
