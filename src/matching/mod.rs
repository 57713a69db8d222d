//! Whole-to-part and part-to-part matching of signatures by zero-mean
//! normalised cross-correlation (ZNCC), both directions of travel.

pub mod blocks;
pub mod candidates;
pub mod peaks;
pub mod turn_index;
pub mod turns;
pub mod zncc;

pub use candidates::{Candidate, Orientation};
pub use zncc::{Correlator, ZnccScores};
