//! Alignment: the similarity that maps the query path onto the target, from
//! a candidate's sample correspondences (RANSAC), then grown along both paths
//! and refitted robustly, then lifted to 3D.

pub mod grow;
pub mod lift;
pub mod polish;
pub mod ransac;

pub use grow::{grow_and_refit, Overlap};
pub use lift::refine_lift;
pub use polish::{polish, search_window, RawPath};
pub use ransac::ransac_similarity;
