//! Geometry shared by the stages: the best-fit plane that takes 3D paths to
//! 2D and back, and similarity transforms in 2D and 3D.

pub mod plane;
pub mod polyline;
pub mod similarity;

pub use plane::Plane;
pub use polyline::Polyline2;
pub use similarity::{nearest_rotation, Similarity2, Similarity3};

/// Diagonal of the points' bounding box (0 for none): a path's size in its
/// own units, for tolerances that are fractions of it.
pub fn extent(points: &[nalgebra::Vector3<f64>]) -> f64 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    let (lo, hi) = points
        .iter()
        .fold((*first, *first), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    (hi - lo).norm()
}
