//! The score of a hypothesis, in [0, 1]: how likely the overlap is true.
//!
//! Each factor is scale-free and saturates:
//! - ZNCC of the signatures (shape agreement, scale removed),
//! - total turning inside the overlap (how many distinct turns agree: in a
//!   city grid a single corner matches everywhere),
//! - the geometric residual as a fraction of the matched length,
//! - the arc-length consistency of the two matched stretches (straights carry
//!   no `K`: their lengths must agree through the common scale),
//! - for loops within one map, a drift-aware prior that the similarity is
//!   near identity.

/// Settings of the score.
#[derive(Debug, Clone, Copy)]
pub struct ScoreConfig {
    /// Turning (radians) at which the turning factor reaches 1 - 1/e.
    pub turning_scale: f64,
    /// Residual (fraction of matched length) at which the residual factor is ½.
    pub residual_scale: f64,
    /// |ln(length ratio)| at which the length factor is 1/e.
    pub length_log_tolerance: f64,
    /// Exponent of the coverage factor (0: coverage ignored).
    pub coverage_power: f64,
}

impl Default for ScoreConfig {
    fn default() -> Self {
        ScoreConfig {
            turning_scale: 1.5 * std::f64::consts::PI,
            residual_scale: 0.002,
            length_log_tolerance: 0.3,
            coverage_power: 0.5,
        }
    }
}

/// The evidence behind one hypothesis.
#[derive(Debug, Clone, Copy)]
pub struct Evidence {
    /// ZNCC of the seed match.
    pub zncc: f64,
    /// Turning inside the overlap (radians), the smaller of the two sides.
    pub turning: f64,
    /// RMS residual over matched length.
    pub relative_rmse: f64,
    /// Matched target length over matched query length times scale.
    pub length_ratio: f64,
    /// Share of the shorter path (by length) inside the overlap.
    pub coverage: f64,
}

/// Combines the evidence into a score in [0, 1].
pub fn score(e: &Evidence, config: &ScoreConfig) -> f64 {
    let zncc = e.zncc.clamp(0.0, 1.0).sqrt();
    let turning = 1.0 - (-e.turning / config.turning_scale).exp();
    let residual = 1.0 / (1.0 + (e.relative_rmse / config.residual_scale).powi(2));
    let length = if e.length_ratio > 0.0 && e.length_ratio.is_finite() {
        (-e.length_ratio.ln().abs() / config.length_log_tolerance).exp()
    } else {
        0.0
    };
    let coverage = e.coverage.clamp(0.0, 1.0).powf(config.coverage_power);
    (zncc * turning * residual * length * coverage).clamp(0.0, 1.0)
}

/// Score of a loop within one map: the geometric fit, times the better of
/// shape evidence and the drift prior, times the prior's square root. A
/// straight revisit of a consistent map (no turns, prior near 1) scores
/// high; a city-grid look-alike (good shape, far from identity) scores low;
/// a drifted true loop keeps its shape evidence, discounted by the prior.
pub fn loop_score(e: &Evidence, prior: f64, config: &ScoreConfig) -> f64 {
    let shape = score(e, config);
    let geometry = score(
        &Evidence {
            zncc: 1.0,
            turning: f64::INFINITY,
            coverage: 1.0,
            ..*e
        },
        config,
    );
    (geometry * (shape / geometry.max(f64::MIN_POSITIVE)).max(prior) * prior.sqrt()).clamp(0.0, 1.0)
}

/// Drift model of one map: how far a true revisit's similarity may be from
/// identity, growing with the path length travelled between the two parts.
///
/// Each term is heavy-tailed, `1 / (1 + (x/σ)²)`, so strong drift lowers a
/// true loop's score without erasing it, while σ grows with
/// `sqrt(distance / matched length)` like a random walk.
#[derive(Debug, Clone, Copy)]
pub struct DriftPrior {
    /// Heading drift (radians) per square root of (distance / matched length).
    pub heading: f64,
    /// Heading offset allowed at no distance (radians).
    pub heading_floor: f64,
    /// Log-scale drift per square root of (distance / matched length).
    pub scale: f64,
    /// Log-scale offset allowed at no distance.
    pub scale_floor: f64,
    /// Position drift as a fraction of the distance travelled in between.
    pub position: f64,
}

impl Default for DriftPrior {
    fn default() -> Self {
        DriftPrior {
            heading: 4f64.to_radians(),
            heading_floor: 4f64.to_radians(),
            scale: 0.03,
            scale_floor: 0.02,
            position: 0.05,
        }
    }
}

impl DriftPrior {
    /// Factor in `(0, 1]` for a revisit with rotation `angle`, scale
    /// `scale`, median map displacement `offset`, matched length `length`,
    /// after travelling `distance` between the parts (same units).
    pub fn factor(&self, angle: f64, scale: f64, offset: f64, length: f64, distance: f64) -> f64 {
        let ratio = drift_ratio(length, distance);
        let sigma_offset = 0.1 * length + self.position * distance;
        term(angle, self.heading_floor + self.heading * ratio)
            * term(scale.ln(), self.scale_floor + self.scale * ratio)
            * term(offset, sigma_offset)
    }

    /// The scale term of [`DriftPrior::factor`] alone (the online score
    /// weighs angle and offset jointly, `online::drift_path`).
    pub fn scale_factor(&self, scale: f64, length: f64, distance: f64) -> f64 {
        let ratio = drift_ratio(length, distance);
        term(scale.ln(), self.scale_floor + self.scale * ratio)
    }

    /// An upper bound of [`DriftPrior::factor`] before the overlap is
    /// grown: each term at its most lenient over matched lengths in
    /// `length = [min, max]` and distances up to `distance`.
    pub fn bound(
        &self,
        angle: f64,
        scale: f64,
        offset: f64,
        length: [f64; 2],
        distance: f64,
    ) -> f64 {
        let ratio = drift_ratio(length[0], distance);
        let sigma_angle = self.heading_floor + self.heading * ratio;
        let sigma_scale = self.scale_floor + self.scale * ratio;
        let sigma_offset = 0.1 * length[1] + self.position * distance;
        term(angle, sigma_angle) * term(scale.ln(), sigma_scale) * term(offset, sigma_offset)
    }
}

/// `sqrt(distance / length)`: the drift's sigmas grow with the square root
/// of the path between the parts, in matched lengths.
fn drift_ratio(length: f64, distance: f64) -> f64 {
    (distance / length.max(f64::MIN_POSITIVE)).max(0.0).sqrt()
}

/// A heavy-tailed factor in `(0, 1]` of a deviation `x` at scale `sigma`.
fn term(x: f64, sigma: f64) -> f64 {
    1.0 / (1.0 + (x / sigma).powi(2))
}

/// An upper bound of [`loop_score`] given the drift prior: every other
/// factor is at most 1, so the score is at most `sqrt(prior)`.
pub fn loop_score_bound(prior: f64) -> f64 {
    prior.clamp(0.0, 1.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The bound the online search uses to skip growing a candidate is
        /// never below the factor of any overlap it allows.
        #[test]
        fn drift_prior_bound_is_above_every_allowed_factor(
            angle in 0.0..3.2f64,
            log_scale in -1.0..1.0f64,
            offset in 0.0..2000.0f64,
            l_min in 1.0..500.0f64,
            l_extra in 0.0..2000.0f64,
            at in 0.0..1.0f64,
            distance in 0.0..20000.0f64,
            at_d in 0.0..1.0f64,
        ) {
            let prior = DriftPrior::default();
            let (l_max, length) = (l_min + l_extra, l_min + at * l_extra);
            let bound = prior.bound(angle, log_scale.exp(), offset, [l_min, l_max], distance);
            let factor = prior.factor(angle, log_scale.exp(), offset, length, at_d * distance);
            prop_assert!(bound >= factor - 1e-12, "{bound} < {factor}");
        }
    }

    #[test]
    fn loop_score_never_exceeds_its_bound() {
        for (zncc, turning, rmse, prior) in [
            (1.0, 10.0, 0.0, 0.04),
            (0.9, 1.0, 0.01, 0.5),
            (0.2, 0.1, 0.1, 1.0),
        ] {
            let e = Evidence {
                zncc,
                turning,
                relative_rmse: rmse,
                length_ratio: 1.0,
                coverage: 1.0,
            };
            assert!(
                loop_score(&e, prior, &ScoreConfig::default()) <= loop_score_bound(prior) + 1e-12
            );
        }
    }
}
