//! Two paths smoothed alike. Each path chooses its smoothing bandwidth from
//! its own poses (GCV in its pose spacings, widened past wobble), so a
//! thinned, noisier or shorter record of the same road is smoothed several
//! times wider or narrower in road units; the signatures then lose
//! different turns, and the true overlap may not be among the candidates at
//! all. Where the first match finds nothing convincing, each path is matched
//! again smoothed wider by factors of two (smoothing only removes detail, so
//! the finer path is the one to coarsen), and a hypothesis of such a level
//! is kept only when its own scale makes the two bandwidths alike: the
//! level it came from is then the pair's common resolution.

use super::prepare::PreparedPath;
use super::{match_prepared_within, Config};
use crate::Hypothesis;

/// A first match whose best hypothesis scores below this looks again
/// smoothed alike: the score that places a path through one overlap alone
/// ([`super::placement::STRONG_OVERLAP_SCORE`]), which no stranger reaches.
/// Above it the first match stands and the extra matches are not paid for.
pub const ALIKE_BELOW_SCORE: f64 = super::placement::STRONG_OVERLAP_SCORE;

/// Ratio between consecutive levels: the bandwidths of one level and the
/// next differ by half an octave's tolerance each way
/// ([`ALIKE_TOLERANCE`]).
const LEVEL_RATIO: f64 = 2.0;

/// Levels tried per path: up to 16 times its own bandwidth. Where one
/// path's turning passes the wobble gate and the other's does not, one is
/// smoothed over a pose spacing and the other over up to 64 of its own
/// (`track::smooth`); `evaluate_kinds` (seed 1, walkers, wheeled robots
/// and hand-held cameras) placed 72.7, 76.0 and 78.6 % of its cases right
/// with 2, 3 and 4 levels, each level costing two matches.
const LEVELS: i32 = 4;

/// A level's hypothesis is kept when the two bandwidths, carried into one
/// frame by its own scale, lie within this factor of each other: the
/// geometric middle between two levels, so that every ratio belongs to a
/// level.
const ALIKE_TOLERANCE: f64 = std::f64::consts::SQRT_2;

/// A level is skipped when the coarsened path would span fewer than this
/// many bandwidths: a common part must span several bandwidths on each
/// side to be verified (`verify`'s floor is 2), and a query several
/// segments, so a path of fewer than 16 holds little to match.
const MIN_BANDWIDTHS: f64 = 16.0;

/// How far a candidate's scale, read from the arc lengths of its aligned
/// ranges before any fit, is trusted: within a factor of 2. A true
/// overlap's ranges are the same road, so they differ by the scale up to
/// where their ends fall on the two signatures' `K` grids (a few percent
/// over a query of several segments); a factor of 2 leaves every such
/// candidate in, and sends to verification only the quarter of the
/// candidates whose scale the level could keep.
const SCALE_READING: f64 = 2.0;

/// The hypotheses of `a` and `b` with one of them smoothed wider, at each
/// level where its hypotheses find the two bandwidths alike.
pub fn match_smoothed_alike(
    pa: &PreparedPath,
    pb: &PreparedPath,
    config: &Config,
) -> Vec<Hypothesis> {
    let mut all = Vec::new();
    for level in 1..=LEVELS {
        let widen = LEVEL_RATIO.powi(level);
        // A smoothed wider, B as chosen: A's bandwidth over B's in A's
        // units is `widen · bw_a / (scale · bw_b)`, so the level keeps
        // scales near `widen · bw_a / bw_b`.
        if let Some(wide) = coarsened(pa, widen, config) {
            let scales = around(wide.track.bandwidth / pb.track.bandwidth);
            all.extend(
                match_prepared_within(&wide, pb, Some(scales), config)
                    .into_iter()
                    .filter(|h| alike(wide.track.bandwidth, h.scale * pb.track.bandwidth)),
            );
        }
        if let Some(wide) = coarsened(pb, widen, config) {
            let scales = around(pa.track.bandwidth / wide.track.bandwidth);
            all.extend(
                match_prepared_within(pa, &wide, Some(scales), config)
                    .into_iter()
                    .filter(|h| alike(pa.track.bandwidth, h.scale * wide.track.bandwidth)),
            );
        }
    }
    all
}

/// The scales a level's candidates are verified at: those that make the
/// two bandwidths alike ([`ALIKE_TOLERANCE`] about `scale`), widened by
/// [`SCALE_READING`] for the candidates' rough readings of scale.
fn around(scale: f64) -> [f64; 2] {
    let k = ALIKE_TOLERANCE * SCALE_READING;
    [scale / k, scale * k]
}

/// `p` smoothed `widen` times wider, unless it would then span too few
/// bandwidths to hold a shape.
fn coarsened(p: &PreparedPath, widen: f64, config: &Config) -> Option<PreparedPath> {
    let bandwidth = widen * p.track.bandwidth;
    if !(bandwidth > 0.0 && p.track.length() >= MIN_BANDWIDTHS * bandwidth) {
        return None;
    }
    p.smoothed_with(bandwidth, config)
}

/// Two bandwidths in one frame are alike within [`ALIKE_TOLERANCE`].
fn alike(x: f64, y: f64) -> bool {
    x > 0.0 && y > 0.0 && x.max(y) <= ALIKE_TOLERANCE * x.min(y)
}
