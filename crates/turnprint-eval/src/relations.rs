//! Relative-pose errors against measured relations, the metric of Kümmerle
//! et al., "On measuring the accuracy of SLAM algorithms" (2009), for logs
//! whose truth is a set of relations rather than a path: pairs of times and
//! the planar motion between them, as the Freiburg SLAM evaluation ships for
//! the Radish logs (`carmen/more/aces.relations`).
//!
//! A relation's error is the difference between the motion the path shows
//! between the two times (the second pose in the first one's frame) and the
//! measured motion: its translation's length and its heading's absolute
//! angle. Revisits are the relations that close a loop: the path between
//! their two poses is over [`REVISIT_DETOUR`] times as long as the measured
//! distance between them and over [`REVISIT_SHARE`] of the whole path.

// Frame names as in Sophus: `a_T_b` maps points from b to a.
#![allow(non_snake_case)]

use std::path::Path;

use nalgebra::{Vector2, Vector3};
use turnprint::Pose;

/// How much longer than the distance between its two poses the path
/// between them must be for a relation to close a loop: ten times, where a
/// relation between poses a second apart is about as long as its path.
pub const REVISIT_DETOUR: f64 = 10.0;

/// Least share of the whole path's length between a revisit's two poses: a
/// hundredth, so that a robot turning on the spot (a path of centimetres
/// between poses millimetres apart) is no revisit.
pub const REVISIT_SHARE: f64 = 0.01;

/// The measured motion from the pose at `t[0]` to the pose at `t[1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Relation {
    /// The two times, in seconds.
    pub t: [f64; 2],
    /// The second pose's position in the first one's frame.
    pub translation: Vector2<f64>,
    /// The second pose's heading less the first's, in radians.
    pub yaw: f64,
}

/// Reads a relations file: one relation per line, `t1 t2 x y z roll pitch
/// yaw`; blank and `#` lines skipped.
pub fn read(path: &Path) -> Result<Vec<Relation>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{}:{}: {e}", path.display(), n + 1))?;
        if v.len() != 8 || v.iter().any(|x| !x.is_finite()) {
            return Err(format!(
                "{}:{}: expected 8 finite numbers (t1 t2 x y z roll pitch yaw)",
                path.display(),
                n + 1
            ));
        }
        out.push(Relation {
            t: [v[0], v[1]],
            translation: Vector2::new(v[2], v[3]),
            yaw: v[7],
        });
    }
    Ok(out)
}

/// Mean errors over a set of relations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// Relations within the path's time span.
    pub count: usize,
    /// Mean translation error, in the path's units.
    pub translation: f64,
    /// Mean heading error, in radians.
    pub rotation: f64,
}

/// The errors of `poses` (timed, each with an orientation, in time order)
/// on every relation within their time span, and on the revisits alone;
/// `None` when a pose has no time or no orientation.
pub fn errors(poses: &[Pose], relations: &[Relation]) -> Option<(Errors, Errors)> {
    let times: Vec<f64> = poses.iter().map(|p| p.t).collect::<Option<_>>()?;
    let yaws: Vec<f64> = poses
        .iter()
        .map(|p| {
            p.orientation.map(|q| {
                let x = q * Vector3::x();
                x.y.atan2(x.x)
            })
        })
        .collect::<Option<_>>()?;
    let positions: Vec<Vector3<f64>> = poses.iter().map(|p| p.position).collect();
    let arc = crate::revisits::arc_lengths(&positions);
    let total = arc.last().copied().unwrap_or(0.0);
    // Pose at time t: positions and (unwrapped) headings interpolated.
    let at = |t: f64| -> Option<(Vector2<f64>, f64, f64)> {
        let (a, b, w) = bracket(&times, t)?;
        let p = poses[a].position.lerp(&poses[b].position, w);
        let turn = wrap(yaws[b] - yaws[a]);
        Some((p.xy(), yaws[a] + w * turn, arc[a] + w * (arc[b] - arc[a])))
    };
    let mut all = Sums::default();
    let mut revisits = Sums::default();
    for r in relations {
        let (Some((p1, y1, s1)), Some((p2, y2, s2))) = (at(r.t[0]), at(r.t[1])) else {
            continue;
        };
        let d = p2 - p1;
        let (c, s) = (y1.cos(), y1.sin());
        let local = Vector2::new(c * d.x + s * d.y, -s * d.x + c * d.y);
        let et = (local - r.translation).norm();
        let er = wrap(y2 - y1 - r.yaw).abs();
        all.add(et, er);
        if is_revisit(s2 - s1, r.translation.norm(), total) {
            revisits.add(et, er);
        }
    }
    Some((all.mean(), revisits.mean()))
}

/// How far a loop misses where the relations between its passes put them:
/// for each relation from a pose of `match_range` to a pose of
/// `query_range` (each the pose nearest its time in `poses`, timed and in
/// order), its index and the distance from where the loop's
/// `query_T_match` and the measured motion place the query pose to the
/// nearest pose of the query pass. Nearest, not the relation's own: along
/// a straight a loop fixes no position along the road (the pose graph
/// leaves it free there), only across it. A right loop misses by the
/// odometry's local error; a look-alike by the distance between the places
/// it confuses. Empty where no relation joins the two ranges.
pub fn loop_misses(
    poses: &[Pose],
    relations: &[Relation],
    query_range: [usize; 2],
    match_range: [usize; 2],
    query_T_match: &turnprint::geometry::Similarity3,
) -> Vec<(usize, f64)> {
    let Some(nearest) = Nearest::new(poses) else {
        return Vec::new();
    };
    let inside = |i: usize, r: [usize; 2]| i >= r[0] && i <= r[1];
    relations
        .iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let [m, q] = nearest.pair(r)?;
            if !inside(m, match_range) || !inside(q, query_range) {
                return None;
            }
            let world_R_m = poses[m].orientation?;
            let offset = world_R_m * Vector3::new(r.translation.x, r.translation.y, 0.0);
            let placed = query_T_match.apply(&(poses[m].position + offset));
            let miss = poses[query_range[0]..=query_range[1].min(poses.len() - 1)]
                .iter()
                .map(|p| (placed - p.position).norm())
                .fold(f64::INFINITY, f64::min);
            Some((k, miss))
        })
        .collect()
}

/// A place revisited, as the relations measured it: revisits (module doc)
/// whose later poses follow one another and whose earlier poses lie
/// together.
#[derive(Debug, Clone, PartialEq)]
pub struct RevisitEvent {
    /// The later pass: first and last pose a relation names.
    pub query: [usize; 2],
    /// The earlier pass: first and last pose a relation names.
    pub matched: [usize; 2],
    /// Indices of its relations.
    pub relations: Vec<usize>,
}

/// The revisit events of `poses` (timed, in time order): the revisits among
/// `relations`, each from the pose nearest its first time to the pose
/// nearest its second, taken in order of their later pose; one joins an
/// event when its later pose is at most `join` of road past the event's
/// last later pose and its earlier pose within `join` of road of the
/// event's earlier pass. A revisit is judged on the measured distance
/// between its poses, so that drift does not make or unmake one, and
/// must have at least `apart` of road between its poses.
pub fn revisit_events(
    poses: &[Pose],
    relations: &[Relation],
    join: f64,
    apart: f64,
) -> Vec<RevisitEvent> {
    let Some(nearest) = Nearest::new(poses) else {
        return Vec::new();
    };
    let positions: Vec<Vector3<f64>> = poses.iter().map(|p| p.position).collect();
    let arc = crate::revisits::arc_lengths(&positions);
    let total = arc.last().copied().unwrap_or(0.0);
    let mut revisits: Vec<(usize, usize, usize)> = relations
        .iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let [a, b] = nearest.pair(r)?;
            let (m, q) = (a.min(b), a.max(b));
            let path = arc[q] - arc[m];
            (is_revisit(path, r.translation.norm(), total) && path >= apart).then_some((q, m, k))
        })
        .collect();
    revisits.sort();
    let mut events: Vec<RevisitEvent> = Vec::new();
    for (q, m, k) in revisits {
        let joins = |e: &RevisitEvent| {
            arc[q] - arc[e.query[1]] <= join
                && arc[m] >= arc[e.matched[0]] - join
                && arc[m] <= arc[e.matched[1]] + join
        };
        match events.iter_mut().find(|e| joins(e)) {
            Some(e) => {
                e.query[1] = q;
                e.matched = [e.matched[0].min(m), e.matched[1].max(m)];
                e.relations.push(k);
            }
            None => events.push(RevisitEvent {
                query: [q, q],
                matched: [m, m],
                relations: vec![k],
            }),
        }
    }
    events
}

/// Whether a relation closes a loop: the path between its poses is over
/// [`REVISIT_DETOUR`] times their distance and over [`REVISIT_SHARE`] of
/// the whole path.
fn is_revisit(path_between: f64, distance: f64, total: f64) -> bool {
    let path = path_between.abs();
    path > REVISIT_DETOUR * distance && path > REVISIT_SHARE * total
}

/// The pose nearest a time, among timed poses.
struct Nearest(Vec<f64>);

impl Nearest {
    /// `None` when a pose has no time.
    fn new(poses: &[Pose]) -> Option<Self> {
        poses
            .iter()
            .map(|p| p.t)
            .collect::<Option<_>>()
            .map(Nearest)
    }

    /// The poses nearest a relation's two times; `None` outside the span.
    fn pair(&self, r: &Relation) -> Option<[usize; 2]> {
        let at = |t: f64| bracket(&self.0, t).map(|(a, b, w)| if w < 0.5 { a } else { b });
        Some([at(r.t[0])?, at(r.t[1])?])
    }
}

/// Where time `t` falls among increasing `times`: the poses before and
/// after it and its fraction of the way between them; `None` outside their
/// span.
fn bracket(times: &[f64], t: f64) -> Option<(usize, usize, f64)> {
    let (first, last) = (*times.first()?, *times.last()?);
    if t < first || t > last {
        return None;
    }
    let b = times
        .partition_point(|x| *x < t)
        .max(1)
        .min(times.len() - 1);
    let a = b.saturating_sub(1);
    let span = times[b] - times[a];
    let w = if span > 0.0 {
        ((t - times[a]) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Some((a, b, w))
}

/// An angle in (-π, π].
fn wrap(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let w = a.rem_euclid(two_pi);
    if w > std::f64::consts::PI {
        w - two_pi
    } else {
        w
    }
}

#[derive(Default)]
struct Sums {
    n: usize,
    t: f64,
    r: f64,
}

impl Sums {
    fn add(&mut self, t: f64, r: f64) {
        self.n += 1;
        self.t += t;
        self.r += r;
    }

    fn mean(&self) -> Errors {
        let n = self.n.max(1) as f64;
        Errors {
            count: self.n,
            translation: self.t / n,
            rotation: self.r / n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// A robot driving a unit circle counter-clockwise, one pose per
    /// second, heading along the circle.
    fn circle(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 40.0;
                Pose {
                    t: Some(i as f64),
                    position: Vector3::new(a.cos(), a.sin(), 0.0),
                    orientation: Some(UnitQuaternion::from_axis_angle(
                        &Vector3::z_axis(),
                        a + std::f64::consts::FRAC_PI_2,
                    )),
                }
            })
            .collect()
    }

    /// The relation from pose `a` to pose `b`, measured on `poses`.
    fn measured(poses: &[Pose], a: usize, b: usize) -> Relation {
        let (pa, pb) = (&poses[a], &poses[b]);
        let qa = pa.orientation.unwrap();
        Relation {
            t: [a as f64, b as f64],
            translation: (qa.inverse() * (pb.position - pa.position)).xy(),
            yaw: (qa.inverse() * pb.orientation.unwrap()).euler_angles().2,
        }
    }

    #[test]
    fn a_path_that_agrees_with_its_relations_has_no_error_and_a_shifted_one_has_its_shift() {
        let poses = circle(81);
        // Quarter turns and a full lap (a revisit), measured from the path.
        let relation = |a, b| measured(&poses, a, b);
        let relations = vec![relation(0, 10), relation(10, 20), relation(5, 45)];
        let (all, revisits) = errors(&poses, &relations).unwrap();
        assert_eq!((all.count, revisits.count), (3, 1));
        assert!(all.translation < 1e-9 && all.rotation < 1e-9, "{all:?}");
        // The second lap 0.5 to the side: only the revisit shows it.
        let mut moved = poses.clone();
        for p in &mut moved[40..] {
            p.position.x += 0.5;
        }
        let (all, revisits) = errors(&moved, &relations).unwrap();
        assert!((revisits.translation - 0.5).abs() < 1e-9, "{revisits:?}");
        assert!((all.translation - 0.5 / 3.0).abs() < 1e-9, "{all:?}");
        // Relations outside the path's time are left out; no orientation,
        // no errors.
        let late = vec![Relation {
            t: [70.0, 90.0],
            translation: Vector2::zeros(),
            yaw: 0.0,
        }];
        assert_eq!(errors(&poses, &late).unwrap().0.count, 0);
        let mut bare = poses.clone();
        bare[3].orientation = None;
        assert!(errors(&bare, &relations).is_none());
    }

    /// Regression: a path of one pose panicked on a relation at its time
    /// (the pair of poses around a time was sought among one).
    #[test]
    fn a_path_of_one_pose_judges_a_relation_at_its_time_without_panicking() {
        let poses = circle(1);
        let relations = vec![Relation {
            t: [0.0, 0.0],
            translation: Vector2::zeros(),
            yaw: 0.0,
        }];
        let (all, revisits) = errors(&poses, &relations).unwrap();
        assert_eq!((all.count, revisits.count), (1, 0));
        assert!(all.translation == 0.0 && all.rotation == 0.0, "{all:?}");
        let identity = turnprint::geometry::Similarity3::identity();
        assert_eq!(
            loop_misses(&poses, &relations, [0, 0], [0, 0], &identity),
            vec![(0, 0.0)]
        );
        assert!(revisit_events(&poses, &relations, 1.0, 0.0).is_empty());
    }

    #[test]
    fn a_loop_misses_by_how_far_it_moves_the_passes_off_their_relations() {
        let poses = circle(81);
        // Lap 2 (poses 40-80) lies on lap 1 (0-40): its relations say so.
        let relation = |a: usize, b: usize| Relation {
            t: [a as f64, b as f64],
            translation: Vector2::zeros(),
            yaw: 0.0,
        };
        let relations = vec![relation(5, 45), relation(12, 52), relation(3, 20)];
        let identity = turnprint::geometry::Similarity3::identity();
        let right = loop_misses(&poses, &relations, [41, 60], [1, 20], &identity);
        assert_eq!(
            right.iter().map(|m| m.0).collect::<Vec<_>>(),
            vec![0, 1],
            "only the relations joining the two passes"
        );
        assert!(right.iter().all(|m| m.1 < 1e-9), "{right:?}");
        // Scaled 1.5 about the centre: each placed pose lies 0.5 outside
        // the query pass.
        let mut shifted = identity;
        shifted.scale = 1.5;
        let off = loop_misses(&poses, &relations, [41, 60], [1, 20], &shifted);
        assert!(off.iter().all(|m| (m.1 - 0.5).abs() < 1e-9), "{off:?}");
        // Turned by two poses' angle about the centre: slid along the road,
        // which a loop does not fix, so no miss.
        let slid = turnprint::geometry::Similarity3 {
            rotation: *nalgebra::Rotation3::from_axis_angle(
                &Vector3::z_axis(),
                2.0 * std::f64::consts::TAU / 40.0,
            )
            .matrix(),
            ..identity
        };
        let along = loop_misses(&poses, &relations, [41, 60], [1, 20], &slid);
        assert!(along.iter().all(|m| m.1 < 1e-9), "{along:?}");
        assert!(loop_misses(&poses, &relations, [61, 80], [21, 39], &identity).is_empty());
    }

    #[test]
    fn revisits_that_follow_one_another_make_one_event_and_local_relations_none() {
        // Three laps of a circle (0.157 of road per pose).
        let poses = circle(121);
        let relation = |a, b| measured(&poses, a, b);
        let relations = vec![
            relation(5, 45),
            relation(3, 20), // along the path: no revisit
            relation(6, 46),
            relation(7, 47),
            relation(25, 105), // two laps back, elsewhere
        ];
        let events = revisit_events(&poses, &relations, 0.5, 1.0);
        assert_eq!(
            events,
            vec![
                RevisitEvent {
                    query: [45, 47],
                    matched: [5, 7],
                    relations: vec![0, 2, 3],
                },
                RevisitEvent {
                    query: [105, 105],
                    matched: [25, 25],
                    relations: vec![4],
                },
            ]
        );
        // Passes must be `apart` of road apart: one lap is 6.28.
        let far = revisit_events(&poses, &relations, 0.5, 10.0);
        assert_eq!(far.len(), 1);
        assert_eq!(far[0].relations, vec![4]);
    }

    #[test]
    fn a_relations_file_with_a_bad_line_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.relations");
        std::fs::write(&path, "1 2 0.1 0 0 0 0 0.2\n\n3 4 nan 0 0 0 0 0\n").unwrap();
        let e = read(&path).unwrap_err();
        assert!(e.contains(":3:"), "{e}");
        std::fs::write(&path, "# t1 t2 x y z r p y\n1 2 0.1 0 0 0 0 0.2\n").unwrap();
        let r = read(&path).unwrap();
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].translation, Vector2::new(0.1, 0.0));
        assert_eq!(r[0].yaw, 0.2);
    }
}
