//! Is a reported hypothesis right? The ground-truth overlap of two windows,
//! the merge correctness test (similarity error on the true overlap, ranges
//! touching it) and the loop correctness test (query poses near match poses).

use nalgebra::Vector3;

use turnprint::Hypothesis;

use crate::relations::REVISIT_DETOUR;

/// The true common road of A and B: the pose indices of each that lie
/// within `radius` (ground-truth metres) of the other path.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overlap {
    /// Indices of A's poses on the common road, increasing.
    pub a: Vec<usize>,
    /// Indices of B's poses on the common road, increasing.
    pub b: Vec<usize>,
    /// Road length (m) of B's overlapping poses: sum of steps between
    /// consecutive overlapping poses of B.
    pub length: f64,
}

/// Finds the common road of two paths given their true (ground-truth)
/// positions. Brute force over all pairs.
pub fn overlap(a_true: &[Vector3<f64>], b_true: &[Vector3<f64>], radius: f64) -> Overlap {
    let r2 = radius * radius;
    let near =
        |p: &Vector3<f64>, q: &[Vector3<f64>]| q.iter().any(|x| (x - p).norm_squared() <= r2);
    let a: Vec<usize> = (0..a_true.len())
        .filter(|&i| near(&a_true[i], b_true))
        .collect();
    let b: Vec<usize> = (0..b_true.len())
        .filter(|&k| near(&b_true[k], a_true))
        .collect();
    let length = b
        .windows(2)
        .filter(|w| w[1] == w[0] + 1)
        .map(|w| (b_true[w[1]] - b_true[w[0]]).norm())
        .sum();
    Overlap { a, b, length }
}

/// Total turning (degrees) of the ground-truth road through `indices` (the
/// longest run of them without a gap of more than 5 poses): heading changes
/// summed over steps of at least [`TURNING_STEP_M`] so that pose noise adds
/// nothing. How much shape a common road has to be found by.
pub fn road_turning_deg(truth: &[Vector3<f64>], indices: &[usize]) -> f64 {
    let mut best = (0, 0);
    let mut start = 0;
    for k in 1..=indices.len() {
        if k == indices.len() || indices[k] > indices[k - 1] + 5 {
            if k - start > best.1 - best.0 {
                best = (start, k);
            }
            start = k;
        }
    }
    if best.1 <= best.0 {
        return 0.0;
    }
    let (first, last) = (indices[best.0], indices[best.1 - 1]);
    let mut knots = vec![truth[first]];
    for p in &truth[first..=last] {
        if (p - knots[knots.len() - 1]).norm() >= TURNING_STEP_M {
            knots.push(*p);
        }
    }
    let headings: Vec<f64> = knots
        .windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            // KITTI's ground plane is x-z.
            d.z.atan2(d.x)
        })
        .collect();
    headings
        .windows(2)
        .map(|w| {
            let d = (w[1] - w[0]).rem_euclid(std::f64::consts::TAU);
            d.min(std::f64::consts::TAU - d)
        })
        .sum::<f64>()
        .to_degrees()
}

/// Step of [`road_turning_deg`] (ground-truth metres).
pub const TURNING_STEP_M: f64 = 10.0;

/// True when the inclusive range `[first, last]` contains one of `indices`.
pub fn range_hits(range: [usize; 2], indices: &[usize]) -> bool {
    let (lo, hi) = (range[0].min(range[1]), range[0].max(range[1]));
    indices.iter().any(|i| (lo..=hi).contains(i))
}

/// Median of a list (`NaN` when empty).
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Outcome of the merge test for one hypothesis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergeVerdict {
    /// Median distance (m) of B's overlap poses, mapped by the hypothesis,
    /// from their true positions in A's frame.
    pub median_error: f64,
    /// The tolerance: `max(0.02 * overlap length, 3 m)` for KITTI.
    pub tolerance: f64,
    /// Both reported ranges touch the true overlap.
    pub ranges_hit: bool,
    /// `median_error <= tolerance && ranges_hit`.
    pub correct: bool,
}

/// The merge test: B's poses on the true overlap, mapped into A's frame by
/// the hypothesis, must land within `max(2 % of the common length, 3 m)`
/// (median) of their true positions, and the reported ranges must intersect
/// the true overlap. A's frame is the ground truth's, so `b_true` (true
/// positions of B's poses) is already in A's frame.
pub fn merge_verdict(
    h: &Hypothesis,
    b_input: &[Vector3<f64>],
    b_true: &[Vector3<f64>],
    truth: &Overlap,
) -> MergeVerdict {
    merge_verdict_of(
        |p| h.transform(p),
        h.a_range,
        h.b_range,
        b_input,
        b_true,
        truth,
        kitti_tolerance(truth),
    )
}

/// The KITTI evaluation's tolerance: 2 % of the common length, at least
/// 3 m (the GPS's and the monocular estimates' own error).
pub fn kitti_tolerance(truth: &Overlap) -> f64 {
    (0.02 * truth.length).max(3.0)
}

/// [`merge_verdict`] for any claimed map of B into A and claimed ranges,
/// within `tolerance` (the evaluation of other kinds of path states it as a
/// fraction of the common length alone).
pub fn merge_verdict_of(
    a_from_b: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    a_range: [usize; 2],
    b_range: [usize; 2],
    b_input: &[Vector3<f64>],
    b_true: &[Vector3<f64>],
    truth: &Overlap,
    tolerance: f64,
) -> MergeVerdict {
    let errors: Vec<f64> = truth
        .b
        .iter()
        .map(|&k| (a_from_b(&b_input[k]) - b_true[k]).norm())
        .collect();
    let median_error = median(&errors);
    let ranges_hit = range_hits(a_range, &truth.a) && range_hits(b_range, &truth.b);
    MergeVerdict {
        median_error,
        tolerance,
        ranges_hit,
        correct: ranges_hit && median_error <= tolerance,
    }
}

/// A loop hypothesis reduced to what the loop test needs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LoopClaim {
    /// Later (query) part, inclusive input pose indices.
    pub query: [usize; 2],
    /// Earlier (match) part, inclusive input pose indices.
    pub matched: [usize; 2],
    /// Ranking score, higher is better.
    pub score: f64,
}

impl From<&Hypothesis> for LoopClaim {
    fn from(h: &Hypothesis) -> Self {
        LoopClaim {
            query: h.a_range,
            matched: h.b_range,
            score: h.score,
        }
    }
}

/// The loop test: the median, over the query poses, of the distance to the
/// nearest match pose is at most `radius`, all in ground-truth positions of
/// the input poses (`truth[i]` for input pose `i`). A claim whose query and
/// match ranges share poses is the trivial self-match (which `cli.md` rules
/// out) and counts as wrong; so does a range outside the input.
pub fn loop_correct(claim: &LoopClaim, truth: &[Vector3<f64>], radius: f64) -> bool {
    let ([q0, q1], [m0, m1]) = (ordered(claim.query), ordered(claim.matched));
    if q1 >= truth.len() || m1 >= truth.len() || (q0 <= m1 && m0 <= q1) {
        return false;
    }
    median_nearest(truth, [q0, q1], [m0, m1], |_, _| true) <= radius
}

/// Least road (in the test's radii) between a pose and a nearer match pose
/// on another pass: a path jittering in place (a drone's hover) covers
/// road without leaving, and a pass that left and came back covers at
/// least the radius out and back twice over (five revisit radii in the
/// kinds evaluation, an event's least span).
pub const DETOUR_RADII: f64 = 4.0;

/// The loop test for paths that repeat themselves (laps of a circuit): as
/// [`loop_correct`], but each query pose's nearest match pose is sought
/// among those on another pass: at least `gap` of road away from it
/// (`arc`: cumulative length of the truth), or nearer but with over
/// [`REVISIT_DETOUR`] times their distance and [`DETOUR_RADII`] times
/// `radius` of road between, the path having left and come back (a walk out
/// along a street and back along it); so the ranges may overlap. A claim
/// that poses 1000-5000 revisit 100-4100 one lap earlier is right when the
/// laps lie on one another; the trivial match of a part with itself or its
/// neighbourhood finds no match pose near enough and is wrong.
pub fn loop_correct_apart(
    claim: &LoopClaim,
    truth: &[Vector3<f64>],
    arc: &[f64],
    radius: f64,
    gap: f64,
) -> bool {
    let ([q0, q1], [m0, m1]) = (ordered(claim.query), ordered(claim.matched));
    if q1 >= truth.len() || m1 >= truth.len() || arc.len() != truth.len() {
        return false;
    }
    median_nearest(truth, [q0, q1], [m0, m1], |q, m| {
        let road = (arc[q] - arc[m]).abs();
        let detour = road > REVISIT_DETOUR * (truth[q] - truth[m]).norm();
        road >= gap || (detour && road > DETOUR_RADII * radius)
    }) <= radius
}

fn ordered(r: [usize; 2]) -> [usize; 2] {
    [r[0].min(r[1]), r[0].max(r[1])]
}

/// Median over the poses of `query` of the distance to the nearest pose of
/// `matched` that `apart(q, m)` admits (infinite when none). Long ranges are
/// thinned to at most ~400 poses each: the median of nearest distances does
/// not need every 10 Hz pose.
fn median_nearest(
    truth: &[Vector3<f64>],
    [q0, q1]: [usize; 2],
    [m0, m1]: [usize; 2],
    apart: impl Fn(usize, usize) -> bool,
) -> f64 {
    let step = |n: usize| n.div_ceil(400).max(1);
    let dists: Vec<f64> = (q0..=q1)
        .step_by(step(q1 - q0 + 1))
        .map(|q| {
            (m0..=m1)
                .step_by(step(m1 - m0 + 1))
                .filter(|m| apart(q, *m))
                .map(|m| (truth[m] - truth[q]).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    median(&dists)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn claim(query: [usize; 2], matched: [usize; 2]) -> LoopClaim {
        LoopClaim {
            query,
            matched,
            score: 1.0,
        }
    }

    #[test]
    fn laps_of_a_circuit_are_loops_even_when_their_ranges_overlap() {
        let lap = crate::test_paths::square_loop(0, 0.0);
        let truth: Vec<_> = lap.iter().chain(&lap).chain(&lap).copied().collect();
        let arc = crate::revisits::arc_lengths(&truth);
        let judge = |c: &LoopClaim| loop_correct_apart(c, &truth, &arc, 3.0, 120.0);
        // The second and third laps over the first two, one lap back.
        let laps = claim([400, 1199], [0, 799]);
        assert!(judge(&laps));
        assert!(!loop_correct(&laps, &truth, 3.0));
        assert!(judge(&claim([400, 799], [0, 399])));
        // The trivial match of a part with itself or its neighbourhood.
        assert!(!judge(&claim([100, 300], [100, 300])));
        assert!(!judge(&claim([100, 300], [95, 305])));
        // Half a lap laid on the other half.
        assert!(!judge(&claim([600, 799], [0, 199])));
    }

    /// A walk out along a street and back along it, 2 m beside: the way back
    /// revisits the way out though less than the revisit gap of road lies
    /// between the poses near the turn (RouteBstd's out-and-back streets,
    /// rank-1 at 0.00 radii, were judged wrong).
    #[test]
    fn a_walk_out_and_back_along_one_street_is_a_loop() {
        let out = line(200, 0.0);
        let back: Vec<_> = line(200, 2.0).into_iter().rev().collect();
        let truth: Vec<_> = out.iter().chain(&back).copied().collect();
        let arc = crate::revisits::arc_lengths(&truth);
        // A gap longer than the whole walk: only the detour rule admits.
        let judge = |c: &LoopClaim| loop_correct_apart(c, &truth, &arc, 3.0, 1000.0);
        assert!(judge(&claim([200, 399], [0, 199])));
        assert!(judge(&claim([250, 300], [99, 149])));
        // A slide along one pass stays a self-match.
        assert!(!judge(&claim([100, 150], [102, 152])));
        assert!(!judge(&claim([250, 300], [240, 290])));
    }

    fn line(n: usize, y: f64) -> Vec<Vector3<f64>> {
        (0..n).map(|i| Vector3::new(i as f64, y, 0.0)).collect()
    }

    #[test]
    fn overlap_of_shifted_windows() {
        // A covers x in [0, 499], B covers x in [300, 899] (true positions).
        let a = line(500, 0.0);
        let b: Vec<_> = line(600, 0.0)
            .iter()
            .map(|p| p + Vector3::new(300.0, 0.0, 0.0))
            .collect();
        let o = overlap(&a, &b, 8.0);
        assert_eq!(o.a.first(), Some(&292));
        assert_eq!(o.b.last(), Some(&207));
        assert!((o.length - 207.0).abs() < 1e-9);
    }

    #[test]
    fn merge_verdict_accepts_the_true_similarity_only() {
        let a = line(500, 0.0);
        let b_true: Vec<_> = line(600, 0.0)
            .iter()
            .map(|p| p + Vector3::new(300.0, 0.0, 0.0))
            .collect();
        // B's input is the truth at scale 0.1, shifted by (5, 0, 0).
        let b_input: Vec<_> = b_true
            .iter()
            .map(|p| p * 0.1 + Vector3::new(5.0, 0.0, 0.0))
            .collect();
        let o = overlap(&a, &b_true, 8.0);
        let map = |dx: f64| move |p: &Vector3<f64>| 10.0 * p + Vector3::new(dx, 0.0, 0.0);
        let verdict = |dx, b_range| {
            let tol = kitti_tolerance(&o);
            merge_verdict_of(map(dx), [300, 499], b_range, &b_input, &b_true, &o, tol)
        };
        let good = verdict(-50.0, [0, 199]);
        assert!(good.correct && good.median_error < 1e-9);
        // 6 m off (tolerance is max(2 % of 207 m, 3 m) = 4.14 m).
        let v = verdict(-44.0, [0, 199]);
        assert!(
            !v.correct && (v.median_error - 6.0).abs() < 1e-9 && (v.tolerance - 4.14).abs() < 1e-9
        );
        // Right similarity, but B's range misses the overlap.
        let miss = verdict(-50.0, [400, 599]);
        assert!(!miss.correct && miss.median_error < 1e-9);
    }

    #[test]
    fn loop_test_uses_true_positions() {
        // Poses 0..100 and 200..300 run along the same road 5 m apart.
        let mut truth = line(100, 0.0);
        truth.extend(line(100, 50.0));
        truth.extend(line(100, 5.0));
        let claim = |q: [usize; 2], m: [usize; 2]| LoopClaim {
            query: q,
            matched: m,
            score: 1.0,
        };
        assert!(loop_correct(&claim([200, 299], [0, 99]), &truth, 10.0));
        assert!(!loop_correct(&claim([100, 199], [0, 99]), &truth, 10.0));
        // Overlapping ranges are the trivial self-match.
        assert!(!loop_correct(&claim([50, 120], [0, 60]), &truth, 10.0));
        assert!(!loop_correct(&claim([250, 400], [0, 99]), &truth, 10.0));
    }
}
