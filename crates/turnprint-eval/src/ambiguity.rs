//! Can shape alone place B? A *shape rival* is a similarity that fails the
//! merge test yet lays at least as much of B onto A as the true alignment
//! does. Where one exists, the two paths themselves hold nothing that
//! prefers the truth: no method that sees only the paths can be sure to
//! pick it, so the case bounds what any shape method can score.
//!
//! The rivals tried are the moves a straight leaves free (maths in A's
//! frame, `a_T_b*` the best-fit truth, `tol` the test's tolerance):
//! - slides `p ↦ a_T_b*(p) + t·u` along the principal direction `u` of the
//!   common road, `|t|` = 1.25, 1.5, 2, 3, 4 or 6 tolerances;
//! - scalings `p ↦ c + f·(a_T_b*(p) - c)` about either end `c` of the
//!   common road, `f = 1 ± k·tol/d`, `d` the median distance of the common
//!   road from `c`, `k` = 1.25, 1.5, 2 or 3 (the median error is then
//!   about `k·tol`).
//!
//! Each move is tried as it is and settled onto A (rigid nearest-pose
//! refits at the move's scale). Rivals of symmetric and repeated shapes (a
//! racetrack's other end, a look-alike block of a grid) are not among them,
//! so the count of ambiguous cases is a lower bound; it does not depend on
//! any matcher's answers. The same moves by 0.25, 0.5 and 0.75 tolerances
//! usually still pass the test; the truth's support is the most any passing
//! placement tried lays onto A, so a rival must beat the truth at its best.
//!
//! What a placement lays onto A is counted twice, and a rival must match
//! the truth in both: the road length of B (steps between consecutive
//! poses, measured under the truth) whose both ends lie within a band of
//! A's poses, and the turning of B between chords of about 10 m (in
//! A's frame) whose three knots lie within that band; turns are what shape
//! matching sees, so a rival that slides B's turns off A's has none. The
//! band is twice the truth's own misfit to A (75th percentile), between 1
//! and 8 m: a ground-truth B on its own drive fits A to the centimetre, so
//! a rival must too, while a monocular B or another lane of the road may
//! stray as far as the truth does.
//!
//! The same certificate answers it for one map's revisit events
//! ([`revisit_rival`]): B is the later pass as seen by a deadline, A the
//! map before it, and every placement is weighed by the drift prior, so
//! that in a consistent map position decides and under drift it may not.

use std::collections::HashMap;

use nalgebra::Vector3;
use serde::Serialize;

use super::checks::{median, overlap, Overlap};
use super::revisits::arc_lengths;
use turnprint::geometry::{Plane, Similarity2, Similarity3};
use turnprint::score::DriftPrior;

/// The band around A's poses that counts as on A is this many times the
/// truth's own misfit (the 75th percentile of the distances from B's
/// common-road poses, placed by the truth, to their nearest pose of A) ...
pub const BAND_PER_MISFIT: f64 = 2.0;
/// ... within these bounds (ground-truth metres): at least the spacing of
/// KITTI's poses, at most the same-road radius.
pub const BAND_M: (f64, f64) = (1.0, super::merge::SAME_ROAD_M);
/// A rival must lay at least this share of the truth's road length and of
/// its turning onto A.
pub const RIVAL_COVER_SHARE: f64 = 0.99;
/// Turning is read between knots of the placed B this far apart (m, in
/// A's frame), so that pose noise adds little.
const KNOT_M: f64 = 10.0;

/// What one placement of B lays onto A.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Support {
    /// Road length (m) of B within the band of A.
    pub length_m: f64,
    /// Turning (degrees) of B within the band of A.
    pub turning_deg: f64,
}

/// The strongest failing placement found for one case.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShapeRival {
    /// `"slide"` or `"scale"`, as moved or settled onto A.
    pub kind: &'static str,
    /// Its size in tolerances (signed).
    pub amount: f64,
    /// What it lays onto A.
    pub support: Support,
    /// Its median error (m) on the common road.
    pub median_error: f64,
    /// How plausible the placement is a priori (1 with no prior).
    pub prior: f64,
}

/// How well the truth and its best failing rival are supported by shape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ambiguity {
    /// Band (m) around A's poses.
    pub band_m: f64,
    /// The most any passing placement tried (the best-fit truth or a small
    /// move of it) lays onto A, length and turning each at its best.
    pub truth: Support,
    /// The highest prior plausibility of a passing placement (1 with no
    /// prior).
    pub truth_prior: f64,
    /// The failing rival whose weaker share of the truth's support is the
    /// largest (`None`: every rival tried passed the test, which happens
    /// only on tiny common roads).
    pub best_rival: Option<ShapeRival>,
}

impl Ambiguity {
    /// The smaller of a rival's shares of the truth's length and turning.
    fn share(&self, r: &Support) -> f64 {
        let ratio = |x: f64, of: f64| if of > 0.0 { x / of } else { 1.0 };
        ratio(r.length_m, self.truth.length_m).min(ratio(r.turning_deg, self.truth.turning_deg))
    }

    /// A failing rival lays at least [`RIVAL_COVER_SHARE`] of the truth's
    /// road length and turning onto A, and is a priori as plausible.
    pub fn has_rival(&self) -> bool {
        self.best_rival.is_some_and(|r| {
            self.share(&r.support) >= RIVAL_COVER_SHARE && r.prior >= self.truth_prior
        })
    }
}

/// Rounds of nearest-point refitting that settle a moved placement.
const SETTLE_ROUNDS: usize = 4;
/// Every this many poses of B take part in settling.
const SETTLE_STRIDE: usize = 4;

/// A slide by `t` in A's frame.
fn slide(t: Vector3<f64>) -> Similarity3 {
    Similarity3 {
        translation: t,
        ..Similarity3::identity()
    }
}

/// A scaling by `f` about `c` in A's frame.
fn scaling(c: Vector3<f64>, f: f64) -> Similarity3 {
    Similarity3 {
        scale: f,
        translation: c - f * c,
        ..Similarity3::identity()
    }
}

/// Settles a placement `d` of B (already in A's frame) onto A: each round
/// pulls B's poses within two bands of A onto their nearest pose of A and
/// refits the rotation and translation at `d`'s scale. On a straight this
/// fixes the sideways offset and the heading and leaves the slide along
/// the road; near a turn it pulls a moved placement back towards the
/// truth.
fn settle(grid: &PointGrid, b_in_a: &[Vector3<f64>], mut d: Similarity3) -> Similarity3 {
    for _ in 0..SETTLE_ROUNDS {
        let (src, dst): (Vec<_>, Vec<_>) = b_in_a
            .iter()
            .step_by(SETTLE_STRIDE)
            .filter_map(|p| grid.nearest(&d.apply(p)).map(|a| (*p, a)))
            .unzip();
        let Some(fit) = Similarity3::fit(&src, &dst) else {
            break;
        };
        // The move's scale is kept: a free scale would shrink B onto any
        // dense part of A.
        let mean = |v: &[Vector3<f64>]| v.iter().sum::<Vector3<f64>>() / v.len() as f64;
        d = Similarity3 {
            translation: mean(&dst) - d.scale * (fit.rotation * mean(&src)),
            rotation: fit.rotation,
            scale: d.scale,
        };
    }
    d
}

/// Looks for a shape rival of `a_T_b` (the best-fit truth) for B's poses
/// `b_input` over A's positions `a_true` (true ones for a merge, the
/// map's own for a revisit: the frame placements are judged in); `b_true`
/// are where B's common poses truly lie in that frame and `truth` the
/// common road with its tolerance `tolerance`.
///
/// `prior` says how plausible a placement of B in A's frame is before any
/// shape is seen (`|_| 1.0` for two maps of unknown relation; the drift
/// prior for one map's revisit): a rival must also be at least as
/// plausible as the most plausible passing placement, or knowing where B
/// should be would decide.
#[allow(non_snake_case)]
pub fn shape_rival(
    a_true: &[Vector3<f64>],
    b_input: &[Vector3<f64>],
    b_true: &[Vector3<f64>],
    truth: &Overlap,
    a_T_b: &Similarity3,
    tolerance: f64,
    prior: &dyn Fn(&Similarity3) -> f64,
) -> Ambiguity {
    let b_in_a: Vec<Vector3<f64>> = b_input.iter().map(|p| a_T_b.apply(p)).collect();
    let reach = PointGrid::new(a_true, BAND_M.1);
    let misfit: Vec<f64> = truth
        .b
        .iter()
        .map(|&k| {
            reach
                .nearest(&b_in_a[k])
                .map_or(BAND_M.1, |a| (a - b_in_a[k]).norm())
        })
        .collect();
    let band_m = (BAND_PER_MISFIT * quantile(&misfit, 0.75)).clamp(BAND_M.0, BAND_M.1);
    let grid = PointGrid::new(a_true, band_m);
    let wide = PointGrid::new(a_true, 2.0 * band_m);
    // Steps are measured under the truth, so a scaled rival neither gains
    // nor loses road. Turns are read between knots KNOT_M apart in A's
    // frame, and count only when the knots on both sides lie on A too.
    let steps: Vec<f64> = b_in_a.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
    let support = |m: &Similarity3| -> Support {
        let moved: Vec<Vector3<f64>> = b_in_a.iter().map(|p| m.apply(p)).collect();
        let on: Vec<bool> = moved.iter().map(|p| grid.near(p)).collect();
        let length_m = steps
            .iter()
            .zip(on.windows(2))
            .filter(|(_, o)| o[0] && o[1])
            .map(|(d, _)| d)
            .sum();
        let knots = knots(&moved);
        let turning_deg = knots
            .windows(3)
            .filter(|w| w.iter().all(|p| grid.near(p)))
            .map(|w| (w[1] - w[0]).angle(&(w[2] - w[1])).to_degrees())
            .sum();
        Support {
            length_m,
            turning_deg,
        }
    };
    let error = |m: &Similarity3| -> f64 {
        let e: Vec<f64> = truth
            .b
            .iter()
            .map(|&k| (m.apply(&b_in_a[k]) - b_true[k]).norm())
            .collect();
        median(&e)
    };
    let mut moves: Vec<(&'static str, f64, Similarity3)> =
        vec![("none", 0.0, Similarity3::identity())];
    let common: Vec<Vector3<f64>> = truth.b.iter().map(|&k| b_true[k]).collect();
    // The plane's first axis is the direction of largest spread.
    let u = Plane::fit(&common).world_R_plane.column(0).into_owned();
    for k in [0.25, 0.5, 0.75, 1.25, 1.5, 2.0, 3.0, 4.0, 6.0] {
        for sign in [-1.0, 1.0] {
            moves.push(("slide", sign * k, slide(u * (sign * k * tolerance))));
        }
    }
    for c in [common[0], common[common.len() - 1]] {
        let d = median(&common.iter().map(|p| (p - c).norm()).collect::<Vec<_>>());
        for k in [0.25, 0.5, 0.75, 1.25, 1.5, 2.0, 3.0] {
            for sign in [-1.0, 1.0] {
                let f = 1.0 + sign * k * tolerance / d;
                if d > 0.0 && f > 0.0 {
                    moves.push(("scale", sign * k, scaling(c, f)));
                }
            }
        }
    }
    let mut amb = Ambiguity {
        band_m,
        truth: Support::default(),
        truth_prior: 0.0,
        best_rival: None,
    };
    let mut rivals = Vec::new();
    let settled: Vec<_> = moves
        .iter()
        .map(|(kind, amount, m)| (*kind, *amount, settle(&wide, &b_in_a, *m)))
        .collect();
    for (kind, amount, m) in moves.into_iter().chain(settled) {
        let (median_error, s) = (error(&m), support(&m));
        let prior = prior(&m.compose(a_T_b));
        if median_error <= tolerance {
            amb.truth.length_m = amb.truth.length_m.max(s.length_m);
            amb.truth.turning_deg = amb.truth.turning_deg.max(s.turning_deg);
            amb.truth_prior = amb.truth_prior.max(prior);
        } else {
            rivals.push(ShapeRival {
                kind,
                amount,
                support: s,
                median_error,
                prior,
            });
        }
    }
    // The best rival as plausible as the truth; failing that, the best.
    let best = |plausible: bool| {
        rivals
            .iter()
            .filter(|r| !plausible || r.prior >= amb.truth_prior)
            .max_by(|x, y| amb.share(&x.support).total_cmp(&amb.share(&y.support)))
            .copied()
    };
    amb.best_rival = best(true).or_else(|| best(false));
    amb
}

/// The drift-aware certificate of one revisit event of a single map: can
/// anything that sees the map's own poses up to `deadline` (inclusive)
/// place the later pass `event` on its earlier pass?
///
/// B is the later pass with `approach` of road before it (ground-truth
/// units) up to `deadline`; A the map's poses at least `min_gap` poses
/// before the event. Both are the map's own positions `input`; `truth`
/// are the ground-truth positions (same indices). The common road is B's
/// poses within `radius` of A (ground truth); each is truly at its
/// nearest pose of A, so the best-fit truth is the similarity taking B's
/// common poses onto those of A, in the map's frame. A placement `P` is
/// weighed a priori by the drift prior of a revisit,
/// `drift.factor(angle(P), scale(P), median |P(p) - p|, length, distance)`
/// (offsets, lengths and distances along the map's own path), so in a
/// consistent map, where the truth is the identity, a slid copy is less
/// plausible and position decides; under drift it may not be. `None` when
/// the event lies beyond the poses or after the deadline, has no earlier
/// pass in A, too few common poses to fit, or is too long for one
/// similarity of the drifting map to place within the loop test's radius.
#[allow(clippy::too_many_arguments)]
pub fn revisit_rival(
    truth: &[Vector3<f64>],
    input: &[Vector3<f64>],
    event: [usize; 2],
    deadline: usize,
    approach: f64,
    min_gap: usize,
    radius: f64,
    drift: &DriftPrior,
) -> Option<Ambiguity> {
    let n = truth.len().min(input.len());
    let deadline = deadline.min(n.saturating_sub(1));
    if event[0] >= n || deadline < event[0] {
        return None;
    }
    let a_end = event[0].checked_sub(min_gap)?;
    let arc = arc_lengths(truth);
    // The map in ground-truth units (a monocular map has its own), so that
    // the band and the knots mean the same on every input.
    let arc_in = arc_lengths(input);
    let to_m = arc[arc.len() - 1] / arc_in[arc_in.len() - 1].max(f64::MIN_POSITIVE);
    let input: Vec<Vector3<f64>> = input.iter().map(|p| to_m * p).collect();
    let b0 = arc[..=event[0]].partition_point(|&s| s < arc[event[0]] - approach);
    let (a_gt, b_gt) = (&truth[..=a_end], &truth[b0..=deadline]);
    let (a_in, b_in) = (&input[..=a_end], &input[b0..=deadline]);
    let common = overlap(a_gt, b_gt, radius);
    if common.b.len() < 3 {
        return None;
    }
    // Where each common pose of B truly is: its nearest pose of A.
    let nearest_a = |k: usize| {
        (0..a_gt.len())
            .min_by(|&i, &j| {
                (a_gt[i] - b_gt[k])
                    .norm_squared()
                    .total_cmp(&(a_gt[j] - b_gt[k]).norm_squared())
            })
            .unwrap_or(0)
    };
    let mut b_true = b_in.to_vec();
    let mut matched = Vec::with_capacity(common.b.len());
    for &k in &common.b {
        let j = nearest_a(k);
        b_true[k] = a_in[j];
        matched.push(j);
    }
    // The best-fit truth in the map's plane: a 3D fit of a nearly straight
    // road may turn it over about its own axis, which the map cannot do.
    let plane = Plane::fit(&input);
    let pairs: Vec<_> = common
        .b
        .iter()
        .map(|&k| (plane.to_2d(&b_true[k]), plane.to_2d(&b_in[k])))
        .collect();
    #[allow(non_snake_case)]
    let a_T_b = plane.lift(&plane, &Similarity2::fit(&pairs, None)?);
    let length: f64 = common
        .b
        .windows(2)
        .filter(|w| w[1] == w[0] + 1)
        .map(|w| (b_in[w[1]] - b_in[w[0]]).norm())
        .sum();
    let mid = common.b.len() / 2;
    let distance = to_m * (arc_in[b0 + common.b[mid]] - arc_in[matched[mid]]);
    // A placement's heading change: how far it turns the common road's
    // direction within the plane.
    let src: Vec<_> = common.b.iter().map(|&k| b_in[k]).collect();
    let u = Plane::fit(&src).world_R_plane.column(0).into_owned();
    let in_plane = |v: Vector3<f64>| plane.to_2d(&(plane.origin + v));
    let prior = |p: &Similarity3| {
        let offsets: Vec<f64> = src.iter().map(|x| (p.apply(x) - x).norm()).collect();
        let heading = in_plane(p.rotation * u).angle(&in_plane(u));
        drift.factor(heading, p.scale, median(&offsets), length, distance)
    };
    let amb = shape_rival(
        a_in,
        b_in,
        &b_true,
        &common,
        &a_T_b,
        super::loops::LOOP_RADIUS_M,
        &prior,
    );
    // No placement passes: one similarity cannot hold the whole pass.
    (amb.truth_prior > 0.0).then_some(amb)
}

/// The `q` quantile of `values` (nearest rank; 0 when empty).
fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(((v.len() as f64 - 1.0) * q).round() as usize)
        .copied()
        .unwrap_or(0.0)
}

/// Points of `path` about [`KNOT_M`] apart, its first included.
fn knots(path: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let mut knots = vec![path[0]];
    for p in path {
        if (p - knots[knots.len() - 1]).norm() >= KNOT_M {
            knots.push(*p);
        }
    }
    knots
}

/// A hash grid over points: is there one within `radius` of a query?
struct PointGrid {
    radius: f64,
    cells: HashMap<[i64; 3], Vec<Vector3<f64>>>,
}

impl PointGrid {
    fn new(points: &[Vector3<f64>], radius: f64) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<Vector3<f64>>> = HashMap::new();
        for p in points {
            cells.entry(Self::key(p, radius)).or_default().push(*p);
        }
        PointGrid { radius, cells }
    }

    fn key(p: &Vector3<f64>, radius: f64) -> [i64; 3] {
        [
            (p.x / radius).floor() as i64,
            (p.y / radius).floor() as i64,
            (p.z / radius).floor() as i64,
        ]
    }

    /// The nearest point within `radius` of `p`.
    fn nearest(&self, p: &Vector3<f64>) -> Option<Vector3<f64>> {
        let [x, y, z] = Self::key(p, self.radius);
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for q in self
                        .cells
                        .get(&[x + dx, y + dy, z + dz])
                        .into_iter()
                        .flatten()
                    {
                        let d2 = (q - p).norm_squared();
                        if d2 <= self.radius * self.radius && best.is_none_or(|(b, _)| d2 < b) {
                            best = Some((d2, *q));
                        }
                    }
                }
            }
        }
        best.map(|(_, q)| q)
    }

    fn near(&self, p: &Vector3<f64>) -> bool {
        self.nearest(p).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// B is A's road at scale 0.1, shifted: the truth maps it back exactly.
    fn case(
        a: &[Vector3<f64>],
        b_true: Vec<Vector3<f64>>,
    ) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>, Overlap, Similarity3) {
        let b_input: Vec<_> = b_true
            .iter()
            .map(|p| 0.1 * p + Vector3::new(3.0, -2.0, 1.0))
            .collect();
        let o = overlap(a, &b_true, 8.0);
        let src: Vec<_> = o.b.iter().map(|&k| b_input[k]).collect();
        let dst: Vec<_> = o.b.iter().map(|&k| b_true[k]).collect();
        let fit = Similarity3::fit(&src, &dst).unwrap();
        (b_input, b_true, o, fit)
    }

    #[test]
    fn a_straight_common_road_has_a_rival() {
        // A: 600 m of straight; B: 300 m of it, then a turn A never makes.
        let a: Vec<_> = (0..600).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        let b: Vec<_> = (0..300)
            .map(|i| Vector3::new(150.0 + i as f64, 0.0, 0.0))
            .chain((1..100).map(|i| Vector3::new(449.0, 0.0, i as f64)))
            .collect();
        let (b_input, b_true, o, fit) = case(&a, b);
        let tol = (0.02 * o.length).max(3.0);
        let amb = shape_rival(&a, &b_input, &b_true, &o, &fit, tol, &|_| 1.0);
        assert!(amb.has_rival(), "{amb:?}");
        assert!(amb.best_rival.unwrap().median_error > tol);
    }

    #[test]
    fn a_common_road_with_its_turns_has_none() {
        // A: legs of 100, 60, 140 and 80 m joined by right-angle turns; B:
        // from the middle of the first leg to the middle of the last.
        let legs = [
            (100, Vector3::x()),
            (60, Vector3::z()),
            (140, -Vector3::x()),
        ];
        let mut a = vec![Vector3::zeros()];
        for (n, dir) in legs.into_iter().chain([(80, -Vector3::z())]) {
            for _ in 0..n {
                a.push(a[a.len() - 1] + dir);
            }
        }
        let b: Vec<_> = a[50..=340].to_vec();
        let (b_input, b_true, o, fit) = case(&a, b);
        let tol = (0.02 * o.length).max(3.0);
        let amb = shape_rival(&a, &b_input, &b_true, &o, &fit, tol, &|_| 1.0);
        assert!(!amb.has_rival(), "{amb:?}");
        assert!((amb.truth.length_m - 290.0).abs() < 1e-6, "{amb:?}");
        assert!((amb.truth.turning_deg - 270.0).abs() < 10.0, "{amb:?}");
    }

    /// A drive east, round a block, and back along the first 100 m of the
    /// drive from a road A never took; 1 m steps. Returns the poses and the
    /// revisit event.
    fn block_and_straight_revisit() -> (Vec<Vector3<f64>>, [usize; 2]) {
        let mut path = vec![Vector3::zeros()];
        let legs = [
            (400, Vector3::x()),
            (150, Vector3::z()),
            (600, -Vector3::x()),
            (150, -Vector3::z()),
            (340, Vector3::x()),
        ];
        for (n, dir) in legs {
            for _ in 0..n {
                path.push(path[path.len() - 1] + dir);
            }
        }
        // The last leg is on the first from x = 0 to its end, x = 140.
        let first = path.len() - 141;
        (path, [first, first + 100])
    }

    #[test]
    fn a_straight_revisit_is_decided_by_position_unless_drift_slid_it() {
        let (truth, event) = block_and_straight_revisit();
        let prior = DriftPrior::default();
        let certify = |input: &[Vector3<f64>]| {
            revisit_rival(&truth, input, event, event[1] + 40, 100.0, 300, 8.0, &prior)
        };
        // A consistent map: the truth is the identity, the most plausible
        // placement there is; a slide along the road is less plausible.
        let consistent = certify(&truth).unwrap();
        assert!(!consistent.has_rival(), "{consistent:?}");
        assert!(consistent.truth_prior > 0.99, "{consistent:?}");
        // Drift has moved the later pass 30 m along the road: the slide
        // back onto the identity lays as much road onto A and is the more
        // plausible, so neither shape nor position can tell them apart.
        let first_back = 400 + 150 + 600;
        let drifted: Vec<_> = truth
            .iter()
            .enumerate()
            .map(|(i, p)| {
                if i > first_back {
                    p + Vector3::new(30.0, 0.0, 0.0)
                } else {
                    *p
                }
            })
            .collect();
        let slid = certify(&drifted).unwrap();
        assert!(slid.has_rival(), "{slid:?}");
    }

    #[test]
    fn an_event_beyond_the_poses_or_after_its_deadline_has_no_certificate() {
        let (truth, event) = block_and_straight_revisit();
        let prior = DriftPrior::default();
        let n = truth.len();
        let beyond = revisit_rival(&truth, &truth, [n, n + 10], n + 50, 100.0, 300, 8.0, &prior);
        assert!(beyond.is_none());
        let late = revisit_rival(&truth, &truth, event, event[0] - 1, 100.0, 300, 8.0, &prior);
        assert!(late.is_none());
        assert!(revisit_rival(&[], &[], [0, 0], 0, 100.0, 0, 8.0, &prior).is_none());
    }
}
