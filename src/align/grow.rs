//! Grow, then refit: a rough seed similarity is extended along both paths as
//! far as the mapped query stays on the target, then refitted on every
//! matched point with robust weights. Repeating this turns a seed of a few
//! percent into sub-degree, sub-percent alignments.

use nalgebra::Vector2;

use crate::geometry::{Polyline2, Similarity2};
use crate::track::Track;

/// Largest factor by which growing may change the seed's scale.
pub const MAX_SCALE_CHANGE: f64 = 1.5;

/// Settings of growing and refitting.
#[derive(Debug, Clone, Copy)]
pub struct GrowConfig {
    /// A mapped query point is on the target when closer than this fraction
    /// of the matched length.
    pub tolerance: f64,
    /// Tightest tolerance, as a fraction of the matched length.
    pub min_tolerance: f64,
    /// Grow/refit rounds.
    pub rounds: usize,
    /// Points used per seed (the query is strided to about this many).
    pub points_per_seed: usize,
    /// The points a round re-projects inside the grown range are strided
    /// to about this many (0: the seed's stride). A grown overlap holds a
    /// few times the seed's points; a few dozen fix the refit as well.
    pub points_per_round: usize,
    /// Misses in a row that end the growth.
    pub max_misses: usize,
    /// The rounds stop once a refit moves no matched point by more than
    /// this fraction of the tolerance (0: only when the range and residual
    /// stop changing): the next round would find the same points.
    pub settle: f64,
}

impl Default for GrowConfig {
    fn default() -> Self {
        GrowConfig {
            tolerance: 0.03,
            min_tolerance: 0.01,
            rounds: 8,
            points_per_seed: 120,
            points_per_round: 0,
            max_misses: 3,
            settle: 0.0,
        }
    }
}

/// The grown common part of a query and a target track.
#[derive(Debug, Clone)]
#[allow(non_snake_case)]
pub struct Overlap {
    /// Final similarity, query (b) to target (a), in 2D.
    pub a_T_b: Similarity2,
    /// Inclusive query grid range.
    pub query: [usize; 2],
    /// Inclusive target grid range (from the projections).
    pub target: [f64; 2],
    /// Matched (target grid index, query grid index) pairs.
    pub pairs: Vec<(f64, usize)>,
    /// RMS distance of the matched pairs (target units).
    pub rmse: f64,
    /// Matched length along the target (target units).
    pub target_length: f64,
    /// Matched length along the query times the scale (target units).
    pub query_length: f64,
    /// The target runs backwards along the query.
    pub reversed: bool,
}

/// Grows the seed `[g0, g1]` of `query` (2D points `query_xy`, the query
/// track's own points, mirrored if need be) on `target`.
/// `allowed(query_grid, target_grid)` rejects trivial self-matches.
///
/// Each round: project the current range onto the target, keep the points
/// that agree on one alignment line (target arc = c ± s · query arc), grow
/// outwards while the mapped query stays within tolerance of the target
/// *near where the line predicts* (so the growth follows the road instead of
/// jumping to a crossing one), then refit with Huber weights.
///
/// `promising` is asked once, after the first round, whether the overlap is
/// worth the rounds that follow (they cost most): `None` when it is not.
/// The rounds are the same either way, so an overlap that goes on growing
/// ends as it would without the question (`&|_| true`).
#[allow(non_snake_case)]
#[allow(clippy::too_many_arguments)]
pub fn grow_and_refit(
    target: &Track,
    target_poly: &Polyline2,
    query: &Track,
    query_xy: &[Vector2<f64>],
    seed: [usize; 2],
    a_T_b: Similarity2,
    config: &GrowConfig,
    allowed: &dyn Fn(usize, f64) -> bool,
    promising: &dyn Fn(&Overlap) -> bool,
) -> Option<Overlap> {
    let n = query_xy.len();
    if n < 2 || seed[1] <= seed[0] {
        return None;
    }
    let stride = ((seed[1] - seed[0]) / config.points_per_seed).max(1);
    let arc_of = |v: f64| Track::interp(&target.s, v);
    let last_vertex = target.xy.len().saturating_sub(1) as f64;
    let mut sim = a_T_b;
    let mut range = [seed[0], seed[1].min(n - 1)];
    let mut result = None;
    let mut last_rmse = f64::INFINITY;
    for round in 0..config.rounds {
        let length = sim.scale * (query.s[range[1]] - query.s[range[0]]);
        // The first round accepts the seed's rough fit; later rounds tighten
        // to a few times the residual reached, so the fit converges like ICP
        // instead of averaging over a wide band.
        let tol =
            (config.tolerance * length).min((4.0 * last_rmse).max(config.min_tolerance * length));
        if !(tol > 0.0 && tol.is_finite()) {
            return result;
        }
        let sim_at = sim.applier();
        let project = |g: usize, predicted: Option<(f64, f64)>| -> Option<Match> {
            let p = sim_at(&query_xy[g]);
            let proj = match predicted {
                // Growth knows where along the target the point must land:
                // only the segments within that arc window are looked at.
                Some((arc, w)) => target_poly.project_along(
                    &p,
                    tol,
                    segments_within(&target.s, arc - w, arc + w),
                    &target.s,
                    arc,
                    |v| allowed(g, v) && (arc_of(v) - arc).abs() <= w,
                ),
                None => target_poly.project_within(&p, tol, |v| allowed(g, v)),
            }?;
            // A point whose nearest target point is the target's first or
            // last sample lies beyond the target, not on it: near an end
            // that nearest point is still within tolerance, and such pairs
            // drag the refit along (a path that ends inside a U-turn pulls
            // in the other leg of the turn).
            if proj.vertex <= 0.0 || proj.vertex >= last_vertex {
                return None;
            }
            // The target's own arc length (a window of a longer path starts
            // where that path is, not at 0), as the predictions use.
            Some(Match {
                query: g,
                vertex: proj.vertex,
                arc: arc_of(proj.vertex),
                distance: proj.distance,
            })
        };
        // Points of the current range that agree on one alignment line.
        let inside_stride = match config.points_per_round {
            0 => stride,
            n => stride.max((range[1] - range[0]) / n),
        };
        let mut inside = Vec::with_capacity((range[1] - range[0]) / inside_stride + 1);
        let mut g = range[0];
        while g <= range[1] {
            inside.extend(project(g, None));
            g += inside_stride;
        }
        let Some((sign, mut matched)) = consistent_line(inside, query, sim.scale, 2.0 * tol) else {
            return result;
        };
        // Grow outwards on both sides, following the line.
        for dir in [-1i64, 1] {
            let edge = if dir < 0 {
                matched.iter().min_by_key(|m| m.query)
            } else {
                matched.iter().max_by_key(|m| m.query)
            };
            let Some(mut last) = edge.copied() else {
                break;
            };
            let mut misses = 0;
            let mut g = last.query as i64;
            while misses < config.max_misses {
                g += dir * stride as i64;
                if g < 0 || g >= n as i64 {
                    break;
                }
                let ds = sim.scale * (query.s[g as usize] - query.s[last.query]);
                let predicted = last.arc + sign * ds;
                let window = tol + 0.2 * ds.abs();
                match project(g as usize, Some((predicted, window))) {
                    Some(m) => {
                        matched.push(m);
                        last = m;
                        misses = 0;
                    }
                    None => misses += 1,
                }
            }
        }
        if matched.len() < 6 {
            return result;
        }
        matched.sort_by_key(|m| m.query);
        range = [matched[0].query, matched[matched.len() - 1].query];
        // Robust refit: Huber weights on the distance.
        let huber = tol / 3.0;
        let pairs: Vec<(Vector2<f64>, Vector2<f64>)> = matched
            .iter()
            .map(|m| (target.point_at(m.vertex), query_xy[m.query]))
            .collect();
        let weights: Vec<f64> = matched
            .iter()
            .map(|m| {
                if m.distance <= huber {
                    1.0
                } else {
                    huber / m.distance
                }
            })
            .collect();
        let Some(refit) = Similarity2::fit(&pairs, Some(&weights)) else {
            return result;
        };
        // Refitting refines a seed by a few percent; a scale running away
        // means the points collapsed onto a small part of the target.
        if (refit.scale / a_T_b.scale).ln().abs() > MAX_SCALE_CHANGE.ln() {
            return result;
        }
        let moved = matched
            .iter()
            .map(|m| (refit.apply(&query_xy[m.query]) - sim.apply(&query_xy[m.query])).norm())
            .fold(0.0, f64::max);
        sim = refit;
        let residuals: Vec<f64> = pairs
            .iter()
            .map(|(a, b)| (sim.apply(b) - a).norm())
            .collect();
        let rmse = (residuals.iter().map(|d| d * d).sum::<f64>() / residuals.len() as f64).sqrt();
        let converged = ((last_rmse - rmse).abs() <= 0.02 * rmse
            && result.as_ref().is_some_and(|r: &Overlap| r.query == range))
            || (result.is_some() && moved <= config.settle * tol);
        last_rmse = rmse;
        let (tmin, tmax) = matched
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| {
                (a.min(m.vertex), b.max(m.vertex))
            });
        result = Some(Overlap {
            a_T_b: sim,
            query: range,
            target: [tmin, tmax],
            pairs: matched.iter().map(|m| (m.vertex, m.query)).collect(),
            rmse,
            target_length: arc_of(tmax) - arc_of(tmin),
            query_length: sim.scale * (query.s[range[1]] - query.s[range[0]]),
            reversed: sign < 0.0,
        });
        if converged {
            break;
        }
        if round == 0 && !result.as_ref().is_some_and(promising) {
            return None;
        }
    }
    result
}

/// The segments (segment `i` joins samples `i` and `i + 1`) holding a point
/// whose arc length `s` lies in `[lo, hi]` (`s` non-decreasing).
fn segments_within(s: &[f64], lo: f64, hi: f64) -> std::ops::Range<usize> {
    let first = s.partition_point(|&x| x < lo).saturating_sub(1);
    let end = s.partition_point(|&x| x <= hi);
    first..end.max(first)
}

/// One query grid sample matched to a point of the target.
#[derive(Debug, Clone, Copy)]
struct Match {
    query: usize,
    vertex: f64,
    /// Arc length of the target track at `vertex`.
    arc: f64,
    distance: f64,
}

/// The matches that agree on one line `target arc = c + sign · s · query arc`
/// (within `width`), for the sign that keeps more of them.
fn consistent_line(
    matches: Vec<Match>,
    query: &Track,
    scale: f64,
    width: f64,
) -> Option<(f64, Vec<Match>)> {
    if matches.len() < 3 {
        return None;
    }
    let mut best: Option<(f64, Vec<Match>)> = None;
    for sign in [1.0, -1.0] {
        let offset = |m: &Match| m.arc - sign * scale * query.s[m.query];
        let mut c: Vec<f64> = matches.iter().map(offset).collect();
        c.sort_by(f64::total_cmp);
        let median = c[c.len() / 2];
        // Room for the growth that follows (it pushes onto these).
        let mut kept = Vec::with_capacity(2 * matches.len());
        kept.extend(matches.iter().copied().filter(|m| {
            (offset(m) - median).abs()
                <= width.max(0.1 * scale * (query.s[m.query] - query.s[matches[0].query]).abs())
        }));
        if best.as_ref().is_none_or(|(_, b)| kept.len() > b.len()) {
            best = Some((sign, kept));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `query` grown on `target` from `seed` and `start`, every pair allowed.
    fn grow(
        target: &Track,
        query: &Track,
        seed: [usize; 2],
        start: Similarity2,
        config: &GrowConfig,
    ) -> Option<Overlap> {
        let polyline = Polyline2::new(&target.xy);
        grow_and_refit(
            target,
            &polyline,
            query,
            &query.xy,
            seed,
            start,
            config,
            &|_, _| true,
            &|_| true,
        )
    }

    /// [`grow`] from the identity with the default settings.
    fn grow_from_identity(target: &Track, query: &Track, seed: [usize; 2]) -> Option<Overlap> {
        grow(
            target,
            query,
            seed,
            Similarity2::identity(),
            &GrowConfig::default(),
        )
    }

    /// A racetrack's leg and U-turn, then its other leg `width` away, as
    /// samples 1 apart: straight up x = 0 from y = `y0` to 300, a U-turn to
    /// x = -`width`, straight down to y = 0, then `bottom` radians of the
    /// bottom U-turn and `up` more of road back up x = 0.
    fn racetrack(y0: f64, width: f64, bottom: f64, up: f64) -> Vec<Vector2<f64>> {
        let step = 1.0;
        let r = width / 2.0;
        let mut out = Vec::new();
        let mut y = y0;
        while y < 300.0 {
            out.push(Vector2::new(0.0, y));
            y += step;
        }
        let turn = |out: &mut Vec<Vector2<f64>>, cy: f64, from: f64, to: f64| {
            let n = ((to - from).abs() * r / step).ceil() as usize;
            for k in 0..n {
                let a = from + (to - from) * k as f64 / n as f64;
                out.push(Vector2::new(-r + r * a.cos(), cy + r * a.sin()));
            }
        };
        turn(&mut out, 300.0, 0.0, std::f64::consts::PI);
        let mut y = 300.0;
        while y > 0.0 {
            out.push(Vector2::new(-width, y));
            y -= step;
        }
        turn(
            &mut out,
            0.0,
            std::f64::consts::PI,
            std::f64::consts::PI + bottom,
        );
        let mut y = 0.0;
        while y < up {
            out.push(Vector2::new(0.0, y));
            y += step;
        }
        out
    }

    /// KITTI 06: A ended a third into the racetrack's bottom U-turn, B went
    /// round it and up the other leg. Growing past A's end, B's poses found
    /// A's last sample within tolerance, the refit followed them, and the
    /// overlap ended 20 % off in scale with a 4.4 m residual.
    #[test]
    fn growth_does_not_take_in_road_beyond_the_target_end() {
        let third = std::f64::consts::PI / 3.0;
        let target = Track::build(&racetrack(150.0, 16.0, third, 0.0)).expect("moving");
        let query =
            Track::build(&racetrack(150.0, 16.0, std::f64::consts::PI, 100.0)).expect("moving");
        let seed = [0, target.xy.len() - 1];
        let overlap =
            grow_from_identity(&target, &query, seed).expect("the query lies on the target");
        assert!(
            (overlap.a_T_b.scale - 1.0).abs() < 1e-3 && overlap.rmse < 0.05,
            "scale {}, rmse {}",
            overlap.a_T_b.scale,
            overlap.rmse
        );
    }

    /// A window cut from the online history keeps the history's arc
    /// lengths, so its first sample is far from arc 0. Growth predicted
    /// along the polyline's own arc (from 0) and checked against the
    /// track's: every step missed, and overlaps stayed at their seeds.
    #[test]
    fn growth_follows_the_road_on_a_window_of_a_longer_path() {
        let road: Vec<Vector2<f64>> = (0..400)
            .map(|i| {
                let t = i as f64 * 0.5;
                Vector2::new(t, 10.0 * (t / 15.0).sin())
            })
            .collect();
        let mut target = Track::build(&road).expect("a moving path");
        for s in &mut target.s {
            *s += 1.0e4;
        }
        let n = target.xy.len();
        let seed = [n / 2 - 10, n / 2 + 10];
        let overlap =
            grow_from_identity(&target, &target, seed).expect("the seed lies on the road");
        assert!(
            overlap.query[0] < n / 4 && overlap.query[1] > 3 * n / 4,
            "grown {:?} of {n} samples from {seed:?}",
            overlap.query
        );
    }

    /// 400 units of a road winding at two wavelengths, samples half a unit
    /// apart.
    fn winding_road() -> Vec<Vector2<f64>> {
        (0..800)
            .map(|i| {
                let t = i as f64 * 0.5;
                Vector2::new(t, 10.0 * (t / 15.0).sin() + 4.0 * (t / 7.0).cos())
            })
            .collect()
    }

    /// Striding a round's inside points (`points_per_round`) must not cost
    /// the fit: a copy of a winding road under a similarity, seeded slightly
    /// off, grows over the whole road and recovers the similarity.
    #[test]
    #[allow(non_snake_case)]
    fn a_capped_round_still_recovers_the_similarity() {
        let road = winding_road();
        let target = Track::build(&road).expect("a moving path");
        let a_T_b = Similarity2 {
            scale: 2.0,
            angle: 0.3,
            translation: Vector2::new(5.0, -3.0),
        };
        let b_T_a = a_T_b.inverse();
        let copy: Vec<Vector2<f64>> = road.iter().map(|p| b_T_a.apply(p)).collect();
        let query = Track::build(&copy).expect("a moving path");
        let n = query.xy.len();
        let rough = Similarity2 {
            scale: 2.002,
            angle: 0.3005,
            ..a_T_b
        };
        let config = GrowConfig {
            points_per_round: 20,
            ..GrowConfig::default()
        };
        let overlap = grow(&target, &query, [n / 2 - 20, n / 2 + 20], rough, &config)
            .expect("the seed lies on the road");
        assert!(
            overlap.query[0] < n / 10 && overlap.query[1] > 9 * n / 10,
            "{:?}",
            overlap.query
        );
        assert!(
            (overlap.a_T_b.scale / 2.0 - 1.0).abs() < 1e-3,
            "{:?}",
            overlap.a_T_b
        );
        assert!(
            (overlap.a_T_b.angle - 0.3).abs() < 1e-3,
            "{:?}",
            overlap.a_T_b
        );
    }

    /// The question after the first round is asked once, and only stops the
    /// rounds: answered no, there is no overlap; answered yes, the road.
    #[test]
    fn the_first_round_question_is_asked_once_and_stops_the_rounds() {
        let road = winding_road();
        let target = Track::build(&road).expect("a moving path");
        let polyline = Polyline2::new(&target.xy);
        let n = target.xy.len();
        let rough = Similarity2 {
            scale: 1.002,
            angle: 0.0005,
            ..Similarity2::identity()
        };
        let grow_asking = |answer: bool| {
            let asked = std::cell::Cell::new(0);
            let overlap = grow_and_refit(
                &target,
                &polyline,
                &target,
                &target.xy,
                [n / 2 - 20, n / 2 + 20],
                rough,
                &GrowConfig::default(),
                &|_, _| true,
                &|_| {
                    asked.set(asked.get() + 1);
                    answer
                },
            );
            (overlap, asked.get())
        };
        let (yes, asked) = grow_asking(true);
        let yes = yes.expect("the seed lies on the road");
        assert_eq!(asked, 1);
        assert!(
            yes.query[0] < n / 10 && yes.query[1] > 9 * n / 10,
            "{:?}",
            yes.query
        );
        let (no, asked) = grow_asking(false);
        assert!(no.is_none());
        assert_eq!(asked, 1);
    }
}
