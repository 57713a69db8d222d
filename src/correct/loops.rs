//! Loop closures as the pose graph takes them: two pose ranges of one path
//! and the similarity between them, from the loop search or from a file.

use super::graph::arc_length;
use crate::align::{polish, refine_lift, search_window, Fit, RawPath};
use crate::geometry::plane::Plane;
use crate::geometry::{Similarity2, Similarity3};
use crate::hypothesis::Hypothesis;
use crate::trajectory::Trajectory;
use crate::{Error, Result};
use nalgebra::{Matrix3, Vector2, Vector3};

/// "Poses `match_range`, moved by `query_T_match`, lie on `query_range`."
#[derive(Debug, Clone, PartialEq)]
pub struct LoopClosure {
    /// Inclusive pose range of the later pass.
    pub query_range: [usize; 2],
    /// Inclusive pose range of the earlier pass.
    pub match_range: [usize; 2],
    /// Maps points of the match range onto the query range.
    pub query_T_match: Similarity3,
    /// RMS distance (path units) between the query poses and the moved
    /// match part: the loop's own misfit, its noise in the graph.
    pub rmse: f64,
    /// Score of the search, or of the file (1 when it gives none).
    pub score: f64,
    /// The match range is travelled the other way.
    pub reversed: bool,
    /// The move along the path's normal that lays the passes at one height
    /// ([`LoopClosure::levelled`]); zero where the path does not keep to a
    /// surface ([`SURFACE_GRADE`]).
    pub level: Vector3<f64>,
    /// `query_T_match` has been moved by `level`.
    pub levelled: bool,
    /// The two passes' shape fixes the scale between them: the best rigid
    /// motion misfits them at least [`SCALE_SHOWN`] times as badly as the
    /// best similarity, both refined from `query_T_match` on the query's
    /// poses ([`crate::align::polish()`]). Otherwise `query_T_match.scale`
    /// is only what the fit happened to take.
    pub scale_shown: bool,
    /// Pieces of one loop that share its information
    /// ([`LoopClosure::pieces`]): 1 for a whole loop.
    pub share: usize,
}

/// Misfit of the best rigid motion over that of the best similarity from
/// which a loop shows the scale between its passes
/// ([`LoopClosure::scale_shown`]). A
/// scale is fixed only by turns that lie apart along a pass; one corner
/// between straights, or a short arc, fits as well at any scale about its
/// apex. Twice: a misfit that doubles is no rounding of a fit. At 1.5 every
/// correction of `evaluate_correct` (KITTI, EuRoC) is the same; at 3 LiDAR
/// NDT 00's drifted revisit at scale 1.08 no longer counts (its path then
/// SE(3)); the EuRoC VIO loops, fitted at scales 0.67-1.26, show none at
/// either.
pub const SCALE_SHOWN: f64 = 2.0;

impl LoopClosure {
    /// A loop of `path` from its ranges and, if known, its similarity
    /// (otherwise fitted to the two ranges paired along their arc length,
    /// reversed when `reversed`, as the search fits one: `fit_ranges`).
    /// Ranges outside the path are an error.
    pub fn new(
        path: &Trajectory,
        query_range: [usize; 2],
        match_range: [usize; 2],
        query_T_match: Option<Similarity3>,
        score: f64,
        reversed: bool,
    ) -> Result<Self> {
        let n = path.len();
        for (name, r) in [("query_range", query_range), ("match_range", match_range)] {
            if r[0] > r[1] || r[1] >= n {
                return Err(Error::input(
                    &path.source,
                    format!(
                        "loop {name} [{}, {}] outside the path's {n} poses",
                        r[0], r[1]
                    ),
                ));
            }
        }
        let positions = path.positions();
        let query = &positions[query_range[0]..=query_range[1]];
        let matched = &positions[match_range[0]..=match_range[1]];
        let given = query_T_match.is_some();
        let sim = match query_T_match {
            Some(s) if s.scale > 0.0 && s.scale.is_finite() => s,
            Some(_) => {
                return Err(Error::input(
                    &path.source,
                    "loop similarity has a scale that is not positive and finite",
                ))
            }
            None => fit_ranges(&positions, query, matched, reversed).ok_or_else(|| {
                Error::input(
                    &path.source,
                    format!(
                        "loop [{}, {}] / [{}, {}]: no similarity fits (a range is a single point)",
                        query_range[0], query_range[1], match_range[0], match_range[1]
                    ),
                )
            })?,
        };
        Ok(LoopClosure {
            query_range,
            match_range,
            query_T_match: sim,
            rmse: misfit(query, matched, &sim),
            score,
            reversed,
            scale_shown: shows_scale(query, matched, &sim),
            // A fit of the ranges lays the passes' centroids on each other:
            // level already.
            level: if given {
                level(&positions, query, matched, &sim)
            } else {
                Vector3::zeros()
            },
            levelled: false,
            share: 1,
        })
    }

    /// How far apart in height the passes lay before the loop was levelled,
    /// in path units: a levelled loop says they lie at one height only to
    /// within it. Zero for a loop as the search fitted it.
    pub fn height(&self) -> f64 {
        if self.levelled {
            self.level.norm()
        } else {
            0.0
        }
    }

    /// The loop with its passes laid at one height ([`LoopClosure::level`]),
    /// its misfit measured again, loose by the height it removed.
    ///
    /// The search matches shapes in the path's plane and lifts the fit,
    /// which moves nothing along the normal: a loop of the same path keeps
    /// the height difference the odometry has between its passes, and a
    /// graph would hold that drift as the truth (a LiDAR odometry's 1.5 m
    /// of vertical drift at KITTI 05's revisits). Two passes over one place
    /// of a surface lie at one height, so the final solve takes the loops
    /// levelled, but only to within the difference removed: a road's passes
    /// can differ by metres in a ground truth's heights (KITTI 08's GPS).
    /// Loops are chosen as the search fitted them: a height difference the
    /// path's drift does not explain is what turns away a look-alike of
    /// another place on a hill (KITTI 09).
    /// `positions` are the path's the loop is of.
    pub fn levelled(&self, positions: &[Vector3<f64>]) -> Self {
        let mut out = self.clone();
        if self.levelled {
            return out;
        }
        out.query_T_match.translation += self.level;
        out.rmse = misfit(
            &positions[self.query_range[0]..=self.query_range[1]],
            &positions[self.match_range[0]..=self.match_range[1]],
            &out.query_T_match,
        );
        out.levelled = true;
        out
    }

    /// How far apart `positions` put the loop's two passes: the RMS
    /// distance from its query poses (at most 64, evenly spread) to the
    /// nearest of its match poses, as `rmse` with no motion between them.
    pub fn apart(&self, positions: &[Vector3<f64>]) -> f64 {
        misfit(
            &positions[self.query_range[0]..=self.query_range[1]],
            &positions[self.match_range[0]..=self.match_range[1]],
            &Similarity3::identity(),
        )
    }

    /// The loop as a rigid motion, for a graph whose scale does not
    /// drift: the search's similarity with its scale set to 1 about the
    /// match range's centroid, or that motion refined on the poses
    /// ([`crate::align::polish()`] with [`Fit::Rigid`]; `raw` indexes
    /// `path`'s poses), whichever misses less. The search fits shapes up to
    /// scale, and a few percent of scale over a long range moves its ends
    /// by metres, which the rigid graph would read as drift.
    pub fn rigid(&self, path: &Trajectory, raw: &RawPath) -> Result<Self> {
        let positions = path.positions();
        let [m0, m1] = self.match_range;
        let centroid = positions[m0..=m1].iter().sum::<Vector3<f64>>() / (m1 - m0 + 1) as f64;
        let start = self.query_T_match.rigid_about(&centroid);
        let polished = polish(
            raw,
            search_window(self.query_range),
            &positions,
            self.match_range,
            &start,
            Fit::Rigid,
        );
        let [a, b] = [start, polished].map(|sim| {
            Self::new(
                path,
                self.query_range,
                self.match_range,
                Some(sim),
                self.score,
                self.reversed,
            )
        });
        let (a, b) = (a?, b?);
        Ok(if b.rmse <= a.rmse { b } else { a })
    }

    /// The loop of a search hypothesis (`a` the query, `b` the match part).
    pub fn from_hypothesis(path: &Trajectory, h: &Hypothesis) -> Result<Self> {
        Self::new(
            path,
            h.a_range,
            h.b_range,
            Some(h.similarity()),
            h.score,
            h.reversed,
        )
    }

    /// Loops from the object `loops --json` prints (`loops` entries with
    /// `query_range`, `match_range` and optionally `scale`, `rotation`,
    /// `translation`, `score`, `reversed`).
    pub fn from_json(path: &Trajectory, text: &str, source: &str) -> Result<Vec<Self>> {
        let bad = |m: String| Error::input(source, m);
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| bad(format!("not JSON: {e}")))?;
        let list = v
            .get("loops")
            .and_then(|l| l.as_array())
            .ok_or_else(|| bad("no \"loops\" list".into()))?;
        list.iter()
            .enumerate()
            .map(|(k, e)| {
                let range = |key: &str| -> Result<[usize; 2]> {
                    let r = e
                        .get(key)
                        .and_then(|r| r.as_array())
                        .ok_or_else(|| bad(format!("loop {k}: no {key}")))?;
                    match r.as_slice() {
                        [a, b] => match (a.as_u64(), b.as_u64()) {
                            (Some(a), Some(b)) => Ok([a as usize, b as usize]),
                            _ => Err(bad(format!("loop {k}: {key} is not two pose indices"))),
                        },
                        _ => Err(bad(format!("loop {k}: {key} is not two pose indices"))),
                    }
                };
                let sim = similarity(e).map_err(|m| bad(format!("loop {k}: {m}")))?;
                let score = e.get("score").and_then(|s| s.as_f64()).unwrap_or(1.0);
                let reversed = e.get("reversed").and_then(|s| s.as_bool()).unwrap_or(false);
                Self::new(
                    path,
                    range("query_range")?,
                    range("match_range")?,
                    sim,
                    score,
                    reversed,
                )
                .map_err(|err| bad(format!("loop {k}: {err}")))
            })
            .collect()
    }
}

/// The similarity of a JSON loop entry, `None` when it has none.
fn similarity(e: &serde_json::Value) -> std::result::Result<Option<Similarity3>, String> {
    let (Some(s), Some(r), Some(t)) = (e.get("scale"), e.get("rotation"), e.get("translation"))
    else {
        return Ok(None);
    };
    let num = |v: &serde_json::Value| v.as_f64().filter(|x| x.is_finite());
    let scale = num(s).ok_or("scale is not a number")?;
    let rows: Vec<Vec<f64>> = r
        .as_array()
        .map(|rows| {
            rows.iter()
                .filter_map(|row| row.as_array().map(|c| c.iter().filter_map(num).collect()))
                .collect()
        })
        .unwrap_or_default();
    if rows.len() != 3 || rows.iter().any(|r| r.len() != 3) {
        return Err("rotation is not a 3x3 matrix".into());
    }
    let rotation = Matrix3::from_fn(|i, j| rows[i][j]);
    if ((rotation * rotation.transpose()) - Matrix3::identity()).norm() > 1e-3
        || rotation.determinant() < 0.0
    {
        return Err("rotation is not a rotation".into());
    }
    let t: Vec<f64> = t
        .as_array()
        .map(|c| c.iter().filter_map(num).collect())
        .unwrap_or_default();
    if t.len() != 3 {
        return Err("translation is not 3 numbers".into());
    }
    Ok(Some(Similarity3 {
        scale,
        rotation,
        translation: Vector3::new(t[0], t[1], t[2]),
    }))
}

/// Similarity of `matched` onto `query`, pairing the two at equal fractions
/// of their arc length, the way the search fits a loop: in the best-fit
/// plane of the whole path (`positions`), lifted, and refined in 3D only
/// within the tilt a road's plane allows ([`crate::align::refine_lift`]).
/// A 3D fit alone takes any rotation about a straight's line, and a road
/// driven both ways fits a half turn about its centre line best, the two
/// lanes swapped, which the graph would read as a roll of 180 degrees.
pub(super) fn fit_ranges(
    positions: &[Vector3<f64>],
    query: &[Vector3<f64>],
    matched: &[Vector3<f64>],
    reversed: bool,
) -> Option<Similarity3> {
    let (sq, sm) = (arc_length(query), arc_length(matched));
    let (lq, lm) = (*sq.last()?, *sm.last()?);
    if lq <= 0.0 || lm <= 0.0 {
        return None;
    }
    let samples = 50.min(query.len().max(matched.len())).max(3);
    let at = |p: &[Vector3<f64>], s: &[f64], f: f64| {
        let target = f * s[s.len() - 1];
        let k = s.partition_point(|&x| x < target).min(p.len() - 1);
        p[k]
    };
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> = (0..samples)
        .map(|k| {
            let f = k as f64 / (samples - 1) as f64;
            let m = at(matched, &sm, if reversed { 1.0 - f } else { f });
            (at(query, &sq, f), m)
        })
        .collect();
    let plane = Plane::fit(positions);
    let flat: Vec<(Vector2<f64>, Vector2<f64>)> = pairs
        .iter()
        .map(|(q, m)| (plane.to_2d(q), plane.to_2d(m)))
        .collect();
    let lifted = plane.lift(&plane, &Similarity2::fit(&flat, None)?);
    let mut fit = refine_lift(&lifted, &pairs);
    // The lift moves nothing along the plane's normal; the passes' mean
    // height difference (drift, a ramp) is the loop's too. (A 3D fit maps
    // the centroids onto each other already.)
    fit.translation += pairs
        .iter()
        .map(|(q, m)| q - fit.apply(m))
        .sum::<Vector3<f64>>()
        / pairs.len() as f64;
    Some(fit)
}

/// Median grade (rise over run, along `normal` over across it) of a path's
/// stretches of `GRADE_PIECES`-th of its length below which it keeps to
/// a surface and its passes over one place lie at one height (`level`).
/// Roads are built to grades of a few percent: KITTI's ground truth has
/// medians of 0.3-3 %, its LiDAR odometry, tilted by its drift, up to 6 %;
/// a flight climbs and sinks (EuRoC's VIO: 10-31 %), and its passes over
/// one track may be a metre apart in height.
pub const SURFACE_GRADE: f64 = 0.08;

/// Pieces of a path whose grades [`SURFACE_GRADE`] takes the median of: a
/// hundred, short enough that drift does not tilt one, long enough that a
/// hand's or a vehicle's jitter does not set its grade.
const GRADE_PIECES: usize = 100;

/// [`SURFACE_GRADE`]'s median grade of `positions` about `normal`; NaN for
/// a path that never moves.
fn median_grade(positions: &[Vector3<f64>], normal: &Vector3<f64>) -> f64 {
    let arc = arc_length(positions);
    let length = arc.last().copied().unwrap_or(0.0);
    let mut grades: Vec<f64> = (0..GRADE_PIECES)
        .filter_map(|k| {
            let at = |f: f64| arc.partition_point(|&a| a < f * length).min(arc.len() - 1);
            let (a, b) = (
                at(k as f64 / GRADE_PIECES as f64),
                at((k + 1) as f64 / GRADE_PIECES as f64),
            );
            let d = positions[b] - positions[a];
            let rise = normal.dot(&d);
            let run = (d - normal * rise).norm();
            (run > 0.0).then(|| rise.abs() / run)
        })
        .collect();
    if grades.is_empty() {
        return f64::NAN;
    }
    grades.sort_by(f64::total_cmp);
    grades[grades.len() / 2]
}

/// [`LoopClosure::level`]: the path's normal times the median height of
/// the query poses over their nearest moved match pose (a query range that
/// runs on past the overlap pairs its ends with the match's, and a ramp
/// there must not set the level), where the path keeps to a surface.
pub(super) fn level(
    positions: &[Vector3<f64>],
    query: &[Vector3<f64>],
    matched: &[Vector3<f64>],
    query_T_match: &Similarity3,
) -> Vector3<f64> {
    let normal = Plane::fit(positions).world_R_plane.column(2).into_owned();
    let grade = median_grade(positions, &normal);
    if grade.is_nan() || grade > SURFACE_GRADE {
        return Vector3::zeros();
    }
    let moved: Vec<Vector3<f64>> = matched.iter().map(|p| query_T_match.apply(p)).collect();
    let step = query.len().div_ceil(64).max(1);
    let mut up: Vec<f64> = query
        .iter()
        .step_by(step)
        .filter_map(|q| {
            moved
                .iter()
                .min_by(|a, b| (*a - q).norm_squared().total_cmp(&(*b - q).norm_squared()))
                .map(|m| normal.dot(&(q - m)))
        })
        .collect();
    if up.is_empty() || up.iter().any(|x| !x.is_finite()) {
        return Vector3::zeros();
    }
    up.sort_by(f64::total_cmp);
    normal * up[up.len() / 2]
}

/// RMS distance from each query pose (at most 64, evenly spread) to the
/// nearest moved match pose.
pub(super) fn misfit(
    query: &[Vector3<f64>],
    matched: &[Vector3<f64>],
    query_T_match: &Similarity3,
) -> f64 {
    let moved: Vec<Vector3<f64>> = matched.iter().map(|p| query_T_match.apply(p)).collect();
    let step = query.len().div_ceil(64).max(1);
    let d2: Vec<f64> = query
        .iter()
        .step_by(step)
        .map(|q| {
            moved
                .iter()
                .map(|m| (m - q).norm_squared())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    (d2.iter().sum::<f64>() / d2.len().max(1) as f64).sqrt()
}

/// Whether the rigid motion that lays the passes best onto each other
/// misfits them [`SCALE_SHOWN`] times as badly as the best similarity, or
/// more: both refined from `query_T_match` on the query's own poses
/// ([`crate::align::polish()`], point to line, so that points slide along a
/// road where its shape does not hold them), the rigid one from the
/// similarity with its scale set to 1 about the match's centroid. The
/// similarity's misfit is floored at [`super::LoopNoise::fit_floor`] of the
/// query's length (an exact fit on ground truth still places the passes
/// that far apart), so that centimetres do not count as a scale.
pub(super) fn shows_scale(
    query: &[Vector3<f64>],
    matched: &[Vector3<f64>],
    query_T_match: &Similarity3,
) -> bool {
    if query.len() < 3 || matched.len() < 3 {
        return false;
    }
    let raw = RawPath::new(query);
    let (window, range) = ([0.0, (query.len() - 1) as f64], [0, matched.len() - 1]);
    let refined = |start: &Similarity3, fit: Fit| {
        misfit(
            query,
            matched,
            &polish(&raw, window, matched, range, start, fit),
        )
    };
    let centroid = matched.iter().sum::<Vector3<f64>>() / matched.len() as f64;
    let length = arc_length(query).last().copied().unwrap_or(0.0);
    let floor = super::LoopNoise::default().fit_floor * length;
    let similar = refined(query_T_match, Fit::Similarity).max(floor);
    let rigid = refined(&query_T_match.rigid_about(&centroid), Fit::Rigid);
    rigid >= SCALE_SHOWN * similar && rigid > 0.0
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::{CorrectConfig, Group, PoseGraph};
    use super::*;

    /// Points every unit along the polyline through `corners`.
    pub(in crate::correct) fn walk(corners: &[[f64; 2]]) -> Vec<Vector3<f64>> {
        let mut out = Vec::new();
        for w in corners.windows(2) {
            let (a, b) = (Vector2::from(w[0]), Vector2::from(w[1]));
            let n = (b - a).norm().round().max(1.0) as usize;
            for k in 0..n {
                let p = a + (b - a) * (k as f64 / n as f64);
                out.push(Vector3::new(p.x, p.y, 0.0));
            }
        }
        let last = corners[corners.len() - 1];
        out.push(Vector3::new(last[0], last[1], 0.0));
        out
    }

    /// A path of `first`, a stretch elsewhere, then `second`: the loop's
    /// match range and query range.
    pub(in crate::correct) fn two_passes(
        first: &[Vector3<f64>],
        second: &[Vector3<f64>],
    ) -> (Trajectory, [usize; 2], [usize; 2]) {
        let away = walk(&[[0.0, 300.0], [400.0, 300.0]]);
        let points: Vec<Vector3<f64>> = first.iter().chain(&away).chain(second).copied().collect();
        let m = [0, first.len() - 1];
        let q0 = first.len() + away.len();
        (
            Trajectory::from_positions("passes", &points),
            [q0, q0 + second.len() - 1],
            m,
        )
    }

    /// Regression: the loops of a drone's VIO (EuRoC MH_04), short arcs and
    /// single corners, fitted at scales 0.67-1.26, made `auto` take Sim(3)
    /// for a metric path, whose correction then went wrong. One corner
    /// fits at any scale about its apex: such a loop shows no scale, and
    /// leaves the graph rigid.
    #[test]
    fn a_loop_whose_shape_fixes_no_scale_leaves_the_graph_rigid() {
        // One corner, passed twice; the earlier pass runs further on both
        // legs, so a similarity shrinking it about the apex fits as well.
        let corner = walk(&[[0.0, -100.0], [0.0, 0.0], [100.0, 0.0]]);
        let longer = walk(&[[0.0, -125.0], [0.0, 0.0], [125.0, 0.0]]);
        let (path, q, m) = two_passes(&longer, &corner);
        let shrink = Similarity3 {
            scale: 0.8,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        };
        let l = LoopClosure::new(&path, q, m, Some(shrink), 1.0, false).unwrap();
        assert!(l.rmse < 1.0, "the shrunk corner misfits by {}", l.rmse);
        assert!(!l.scale_shown, "one corner showed a scale");
        assert_eq!(Group::Auto.resolve(&[l]), Group::Se3);
    }

    /// Corners of a U-turn on the plane z = 0.
    const U_TURN: [[f64; 2]; 4] = [[0.0, 0.0], [100.0, 0.0], [100.0, 60.0], [0.0, 60.0]];

    /// A move by `x` along the x axis.
    fn shift_x(x: f64) -> Similarity3 {
        Similarity3 {
            scale: 1.0,
            rotation: Matrix3::identity(),
            translation: Vector3::new(x, 0.0, 0.0),
        }
    }

    /// Regression: the search lifts its planar fit without moving anything
    /// along the normal, so a loop kept the odometry's height drift between
    /// its passes (1.5 m at KITTI 05's revisits in LiDAR odometry), and the
    /// graph held the drift as the truth. A path that keeps to a surface
    /// has its passes levelled, loose by the height they were apart.
    #[test]
    fn passes_apart_in_height_on_a_road_are_levelled_and_loose_by_it() {
        let first = walk(&U_TURN);
        let raised: Vec<Vector3<f64>> = walk(&U_TURN.map(|[x, y]| [x + 500.0, y]))
            .into_iter()
            .map(|p| p + Vector3::new(0.0, 0.0, 10.0))
            .collect();
        let (path, q, m) = two_passes(&first, &raised);
        let along = shift_x(500.0);
        let search = LoopClosure::new(&path, q, m, Some(along), 1.0, false).unwrap();
        assert!(search.rmse > 9.0, "the fit's own misfit {}", search.rmse);
        let l = search.levelled(&path.positions());
        assert!((l.height() - 10.0).abs() < 0.01, "height {}", l.height());
        // Within 3 % of the raise: the raised pass tilts the path's plane,
        // whose normal the levelling follows, by about a degree.
        assert!(l.rmse < 0.3, "levelled passes misfit by {}", l.rmse);
        let moved = l.query_T_match.apply(&first[0]);
        assert!((moved - raised[0]).norm() < 0.3, "{moved:?}");
        // The graph's loop edges leave that height loose, square to the road.
        let config = CorrectConfig::default();
        let graph = PoseGraph::build(&path, std::slice::from_ref(&l), &config).unwrap();
        for e in graph.loop_edges(0) {
            let (h, s) = (e.sigmas.height.unwrap(), e.sigmas.slide.unwrap());
            assert!(h.axis.dot(&s.axis).abs() < 1e-9);
            assert!(h.sigma > e.sigmas.translation);
        }
    }

    /// A flight climbs and sinks: its passes over one track may be apart in
    /// height, and a loop keeps the height its fit found.
    #[test]
    fn passes_of_a_climbing_path_are_not_levelled() {
        let climb = |p: Vec<Vector3<f64>>| -> Vec<Vector3<f64>> {
            p.into_iter()
                .enumerate()
                .map(|(k, p)| p + Vector3::new(0.0, 0.0, 0.3 * (k % 40) as f64))
                .collect()
        };
        let first = climb(walk(&U_TURN));
        let again: Vec<Vector3<f64>> = first
            .iter()
            .map(|p| p + Vector3::new(500.0, 0.0, 2.0))
            .collect();
        let (path, q, m) = two_passes(&first, &again);
        let along = shift_x(500.0);
        let l = LoopClosure::new(&path, q, m, Some(along), 1.0, false)
            .unwrap()
            .levelled(&path.positions());
        assert_eq!(l.height(), 0.0);
        assert_eq!(l.query_T_match, along);
    }

    /// Two turns a pass apart fix its scale: a second pass 30 % larger
    /// (a monocular path's drift) shows it, and the graph takes Sim(3).
    #[test]
    fn a_loop_over_two_turns_at_another_scale_shows_it() {
        let u = [[0.0, 0.0], [100.0, 0.0], [100.0, 60.0], [0.0, 60.0]];
        let first = walk(&u);
        let larger = walk(&u.map(|[x, y]| [1.3 * x + 500.0, 1.3 * y]));
        let (path, q, m) = two_passes(&first, &larger);
        let l = LoopClosure::new(&path, q, m, None, 1.0, false).unwrap();
        assert!(
            (l.query_T_match.scale - 1.3).abs() < 0.02,
            "scale {}",
            l.query_T_match.scale
        );
        assert!(l.scale_shown, "two turns 30 % apart showed no scale");
        assert_eq!(Group::Auto.resolve(&[l]), Group::Sim3);
        // The same pass at the same scale shows none.
        let again = walk(&u.map(|[x, y]| [x + 500.0, y]));
        let (path, q, m) = two_passes(&first, &again);
        let l = LoopClosure::new(&path, q, m, None, 1.0, false).unwrap();
        assert_eq!(Group::Auto.resolve(&[l]), Group::Se3);
    }
}
