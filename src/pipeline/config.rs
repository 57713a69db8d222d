//! Settings of the whole pipeline, grouped by stage. Every tolerance is in
//! radians, ratios or fractions of a matched length: none is in metres.

use crate::align::grow::GrowConfig;
use crate::matching::candidates::QueryConfig;
use crate::matching::turns::TurnConfig;
use crate::score::{DriftPrior, ScoreConfig};
use crate::segments::SegmentConfig;
use crate::signature::SignatureConfig;

/// Settings of `match`, `loops` and the online detector.
#[derive(Debug, Clone)]
pub struct Config {
    // --- signature: K grid step 2°, heading dead band 4°.
    /// Signature settings.
    pub signature: SignatureConfig,
    // --- segmentation: boundaries are extrema of ln(ds/dK) within ±40° of K,
    // standing out by a factor 2.
    /// Segmentation settings.
    pub segments: SegmentConfig,
    // --- matching: N = 2..12 segments, 3 peaks per query, ZNCC ≥ 0.5.
    /// Part-to-part search settings.
    pub query: QueryConfig,
    // --- alignment: 2-point RANSAC (threshold 4 % of the matched length,
    // at most 64 hypotheses, fewer once 99.9 % sure), then grow/refit at
    // 3 % of the matched length.
    /// RANSAC inlier threshold as a fraction of the matched target length.
    pub ransac_threshold: f64,
    /// RANSAC iterations per candidate, at most.
    pub ransac_iterations: usize,
    /// RANSAC stops once an all-inlier sample would have been drawn with
    /// this probability, given the best inlier share so far
    /// ([`crate::align::ransac_similarity`]).
    pub ransac_confidence: f64,
    /// Grow/refit settings.
    pub grow: GrowConfig,
    /// Turn-pair proposals (independent of K alignment).
    pub turns: TurnConfig,
    /// Candidates verified geometrically (the strongest first).
    pub max_candidates: usize,
    /// Beyond those, the best-correlating candidates also verified: a short
    /// overlap at a window's end pools few votes and loses on strength to
    /// long alignments that correlate at 0.5-0.7 (merge of KITTI windows,
    /// seeds 1-4: rank-1 +0.4..1.4 points, top-5 +0.7..1.2).
    pub max_zncc_candidates: usize,
    // --- scoring and ranking.
    /// Score settings.
    pub score: ScoreConfig,
    /// Within-map drift prior for loops (`None`: no prior, as for merging).
    pub drift_prior: Option<DriftPrior>,
    /// Loops: parts closer than this much turning (radians of K) are the
    /// same place's neighbourhood, never a revisit.
    pub loop_exclusion: f64,
    /// Hypotheses scoring below this are not returned (a short list beats
    /// a padded one: every false loop costs the verifier and the user).
    pub min_score: f64,
    /// Hypotheses returned.
    pub top_k: usize,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            signature: SignatureConfig::default(),
            segments: SegmentConfig::default(),
            query: QueryConfig::default(),
            ransac_threshold: 0.04,
            ransac_iterations: 64,
            // The textbook 0.999: with about 60 pairs at 55 % inliers it
            // stops after 20-odd hypotheses instead of 64.
            ransac_confidence: 0.999,
            grow: GrowConfig::default(),
            turns: TurnConfig::default(),
            max_candidates: 60,
            max_zncc_candidates: 20,
            score: ScoreConfig::default(),
            drift_prior: None,
            loop_exclusion: std::f64::consts::FRAC_PI_2,
            min_score: 0.0,
            top_k: 5,
        }
    }
}

impl Config {
    /// Defaults for `match` / `merge`: no prior, mirrored paths searched.
    pub fn for_matching() -> Self {
        Config::default()
    }

    /// Defaults for `loops`: one map, so no mirror and the drift prior on.
    pub fn for_loops() -> Self {
        let mut c = Config {
            drift_prior: Some(DriftPrior::default()),
            min_score: 0.0,
            top_k: 10,
            ..Config::default()
        };
        c.query.mirror = false;
        // Within one map the drift prior tells look-alikes apart, and a long
        // revisit bent by drift fits one similarity less tightly.
        c.score.residual_scale = 0.006;
        c.score.coverage_power = 0.0;
        // A revisit of a drifting map is bent: the prior's 4° of heading
        // drift per matched length puts the two parts up to about 2 % of
        // that length apart beyond the matching noise, so growth keeps
        // points within 5 % (not 3 %) on the first round. On the strong-drift
        // loops of KITTI (5 seeds): rank-1 +5..20 points, events +5..9.
        c.grow.tolerance = 0.05;
        // Within one map the extra best-correlating candidates are
        // look-alikes that beat drifted revisits (strong-drift loops, seeds
        // 1 and 2: rank-1 60 -> 55 % and 70 -> 60 %).
        c.max_zncc_candidates = 0;
        c
    }
}
