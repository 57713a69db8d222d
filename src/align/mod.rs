//! Alignment: the similarity that maps the query path onto the target, from
//! a candidate's sample correspondences (RANSAC), then grown along both paths
//! and refitted robustly, then lifted to 3D.

pub mod grow;
pub mod lift;
pub mod polish;
pub mod ransac;

pub use grow::{grow_and_refit, Overlap};
pub use lift::{refine_lift, rms_residual};
pub use polish::{polish, search_window, Fit, RawPath};
pub use ransac::ransac_similarity;

/// A 3D refinement (`lift::refine_lift`, `polish::polish`) is taken beyond
/// its rotation limit when it brings the correspondences this many times
/// closer (median, in B's units): a part of a path that leaves every plane
/// (a drone, a hand-held camera) has a best-fit plane of its own, and the
/// planes' lift is off by tens of degrees ...
const MUCH_CLOSER: f64 = 4.0;
/// ... as long as the scale moves by less than this factor: points shrunk
/// onto one place are as close to it as can be (the polish took a drone's
/// 5 000 poses of flight to scale 1e-11 onto a hover).
const MAX_SCALE_FACTOR: f64 = 1.3;
