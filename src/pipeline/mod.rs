//! The batch pipeline: `match`, `loops` and `merge` strung from the stages.
//! (Work in progress: the stages are being filled in.)

use crate::{Hypothesis, Result, Trajectory};

/// Settings of the batch pipeline.
#[derive(Debug, Clone, Default)]
pub struct Config {
    /// How many hypotheses to return.
    pub top_k: usize,
}

/// Where path B overlaps path A, best first.
pub fn match_paths(_a: &Trajectory, _b: &Trajectory, _config: &Config) -> Result<Vec<Hypothesis>> {
    Ok(Vec::new())
}

/// Places that path A revisits: `a_range` is the later (query) part,
/// `b_range` the earlier (match) part; the similarity maps match onto query.
pub fn find_loops(_a: &Trajectory, _config: &Config) -> Result<Vec<Hypothesis>> {
    Ok(Vec::new())
}
