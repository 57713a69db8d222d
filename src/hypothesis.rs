//! A hypothesis: "this part of B is that part of A", with the similarity that
//! maps B onto A and the evidence behind it.

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// One ranked overlap hypothesis between path A and path B.
///
/// For loops, A is the later (query) part and B the earlier (match) part of
/// the same path. The similarity maps B into A's frame:
/// `p_A = scale * rotation * p_B + translation`.
#[derive(Debug, Clone, PartialEq)]
pub struct Hypothesis {
    /// 1-based rank after sorting by score.
    pub rank: usize,
    /// Likelihood of a true overlap, in [0, 1].
    pub score: f64,
    /// ZNCC of the curvature signatures over the matched part.
    pub zncc: f64,
    /// True when B travels the common part in the opposite direction.
    pub reversed: bool,
    /// Inclusive pose-index range in A.
    pub a_range: [usize; 2],
    /// Inclusive pose-index range in B.
    pub b_range: [usize; 2],
    /// Uniform scale of `a_T_b`.
    pub scale: f64,
    /// Proper rotation of `a_T_b`.
    pub rotation: Matrix3<f64>,
    /// Translation of `a_T_b`.
    pub translation: Vector3<f64>,
    /// RMS distance (A's units) between transformed matched B and A.
    pub rmse: f64,
    /// Total turning (radians) inside the common part: the evidence.
    pub turning: f64,
    /// Matched length along A (A's units).
    pub length: f64,
    /// Matched length along A over matched length along B times the scale.
    pub length_ratio: f64,
    /// Matched pose pairs (a index, b index) used for the final fit.
    pub correspondences: Vec<(usize, usize)>,
}

#[cfg(test)]
impl Hypothesis {
    /// A hypothesis with this score, these ranges and direction, and the
    /// identity similarity (unit tests of the stages that sort, rank and
    /// settle hypotheses).
    pub(crate) fn scored(
        score: f64,
        a_range: [usize; 2],
        b_range: [usize; 2],
        reversed: bool,
    ) -> Self {
        Hypothesis {
            rank: 0,
            score,
            zncc: 1.0,
            reversed,
            a_range,
            b_range,
            scale: 1.0,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            rmse: 0.0,
            turning: 0.0,
            length: 1.0,
            length_ratio: 1.0,
            correspondences: Vec::new(),
        }
    }
}

impl Hypothesis {
    /// Maps a point of B into A's frame.
    pub fn transform(&self, p_b: &Vector3<f64>) -> Vector3<f64> {
        self.scale * (self.rotation * p_b) + self.translation
    }
}

/// JSON form of a hypothesis, field names per `cli.md`.
#[derive(Debug, Serialize)]
pub struct HypothesisJson {
    /// [`Hypothesis::rank`].
    pub rank: usize,
    /// [`Hypothesis::score`].
    pub score: f64,
    /// [`Hypothesis::zncc`].
    pub zncc: f64,
    /// [`Hypothesis::reversed`].
    pub reversed: bool,
    /// [`Hypothesis::a_range`].
    pub a_range: [usize; 2],
    /// [`Hypothesis::b_range`].
    pub b_range: [usize; 2],
    /// [`Hypothesis::scale`].
    pub scale: f64,
    /// [`Hypothesis::rotation`], row by row.
    pub rotation: [[f64; 3]; 3],
    /// [`Hypothesis::translation`].
    pub translation: [f64; 3],
    /// [`Hypothesis::rmse`].
    pub rmse: f64,
    /// [`Hypothesis::turning`] in degrees.
    pub turning_deg: f64,
}

impl Hypothesis {
    /// The similarity `p_A = scale · rotation · p_B + translation`.
    pub fn similarity(&self) -> crate::geometry::Similarity3 {
        crate::geometry::Similarity3 {
            scale: self.scale,
            rotation: self.rotation,
            translation: self.translation,
        }
    }

    /// Rotation angle (radians) of the similarity.
    pub fn rotation_angle(&self) -> f64 {
        self.similarity().angle()
    }

    /// The JSON form of `cli.md`.
    pub fn to_json(&self) -> HypothesisJson {
        let r = &self.rotation;
        HypothesisJson {
            rank: self.rank,
            score: self.score,
            zncc: self.zncc,
            reversed: self.reversed,
            a_range: self.a_range,
            b_range: self.b_range,
            scale: self.scale,
            rotation: [
                [r[(0, 0)], r[(0, 1)], r[(0, 2)]],
                [r[(1, 0)], r[(1, 1)], r[(1, 2)]],
                [r[(2, 0)], r[(2, 1)], r[(2, 2)]],
            ],
            translation: [self.translation.x, self.translation.y, self.translation.z],
            rmse: self.rmse,
            turning_deg: self.turning.to_degrees(),
        }
    }
}
