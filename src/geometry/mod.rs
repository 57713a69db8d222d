//! Geometry shared by the stages: the best-fit plane that takes 3D paths to
//! 2D and back, and similarity transforms in 2D and 3D.

pub mod plane;
pub mod polyline;
pub mod similarity;

pub use plane::Plane;
pub use polyline::Polyline2;
pub use similarity::{nearest_rotation, Similarity2, Similarity3};
