//! How nearly the two passes of a loop coincide in the map, against the
//! size of a place in it.
//!
//! The drift prior ([`crate::score::DriftPrior`]) lets a revisit's passes
//! lie apart by what drift could have put between them: 10 % of the matched
//! length plus 5 % of the path in between. In a map that has not drifted
//! there, that tolerance hides the difference between the place itself and
//! its neighbour: a drone circling a room laps 15-50 cm above or beside
//! its earlier laps, each lap as alike in shape as the true revisit, and
//! the prior keeps them all near 1 (KAIST-VIO circles and squares, EuRoC:
//! 7 of 17 rank-1 loops on the drones' truths still wrong after the
//! offset went 3D). Of two loops alike in shape, the one whose passes
//! coincide is the likelier; a drifted true loop keeps half its score, as
//! every loop of a drifted map loses alike.

/// Size of a place as a fraction of the path's extent (bounding-box
/// diagonal): passes one place apart keep three quarters of their score
/// ([`coincidence_factor`]), many places apart half. A lane change on
/// KITTI 00 (3 m of 700 m) or the spread of one lap's revisit in a 3 m
/// room (5-10 cm) lie well within it. At 2 % the
/// hand-held rooms' long loops, whose passes spread 2-3 % apart, lost to
/// short ones and covered fewer events (seed 1: 37.6 against 40.9 %).
pub const PLACE_SIZE: f64 = 0.05;

/// Weight of coincidence against drift: a loop whose passes coincide
/// scores up to `1 + COINCIDENCE_WEIGHT` times one whose passes lie many
/// places apart, all else equal. At 1 a drifted true loop keeps half its
/// score, enough to outrank the look-alikes the drift prior already sinks
/// (strong-drift KITTI loops unchanged); at 3 the hand-held rooms under a
/// bias lost rank-1 (seed 1: 83.3 -> 66.7 %).
pub const COINCIDENCE_WEIGHT: f64 = 1.0;

/// The share of a loop's score kept for passes `offset` apart (median, in
/// the map) in a path of `extent`: 1 where they coincide, falling to
/// `1 / (1 + COINCIDENCE_WEIGHT)` many places apart (heavy-tailed, as the
/// drift prior's terms).
pub fn coincidence_factor(offset: f64, extent: f64) -> f64 {
    let x = offset / (PLACE_SIZE * extent).max(f64::MIN_POSITIVE);
    let coincide = 1.0 / (1.0 + x * x);
    (1.0 + COINCIDENCE_WEIGHT * coincide) / (1.0 + COINCIDENCE_WEIGHT)
}
