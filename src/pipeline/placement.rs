//! Many paths into one frame: every pair matched, each best overlap an edge
//! of a graph of paths, and every path placed in the first path's frame
//! through the strongest overlap whose placement the path's other overlaps
//! with placed paths do not contradict (a wrong pairwise merge disagrees
//! with the cycles it closes). A path that overlaps no placed path is left
//! out, never forced. The placement is then refined jointly over all the
//! overlaps it agrees with ([`super::refine`]).
//!
//! With `first_T_u` the placement of a placed path `u` and `u_T_v` an
//! overlap's similarity (`p_u = s R p_v + t`), path `v` is placed at
//! `first_T_v = first_T_u · u_T_v`.

use nalgebra::Vector3;

use super::{match_across_rates, Config, PreparedPath};
use crate::geometry::Similarity3;
use crate::matching::turn_index::TurnIndex;
use crate::{Hypothesis, Result, Trajectory};

/// Weakest best score that makes an overlap an edge. Over every kind of
/// path (`evaluate_kinds`, seed 1) 94 % of the pairs with no common road
/// rank-1 below it, and 94 % of the correct rank-1 overlaps above.
pub const MIN_OVERLAP_SCORE: f64 = 0.1;

/// Best score that places a path through one overlap alone; a weaker one
/// places it only when another overlap with a placed path agrees. None of
/// the 240 pairs with no common road (`evaluate_kinds`, seed 1) reaches it,
/// 86 % of the correct rank-1 overlaps do. Matched against many others, a
/// stranger meets a look-alike between the two scores now and then (one
/// pair in twenty), and a stranger once placed would place more.
pub const STRONG_OVERLAP_SCORE: f64 = 0.2;

/// Two placements of one path agree when its poses land within this
/// fraction of the path's placed extent of each other (median): errors of
/// a chain of overlaps add up, a wrong overlap misplaces a path by about
/// its own size.
pub const AGREEMENT: f64 = 0.05;

/// The best overlap of two paths: `hypothesis` maps path `b` into path
/// `a`'s frame.
#[derive(Debug, Clone)]
pub struct Overlap {
    /// Index of the reference path.
    pub a: usize,
    /// Index of the path mapped into `a`'s frame.
    pub b: usize,
    /// The best hypothesis of the pair.
    pub hypothesis: Hypothesis,
}

impl Overlap {
    /// `from_T_to` of the overlap seen from path `from` (one of its ends).
    pub fn seen_from(&self, from: usize) -> Similarity3 {
        let a_t_b = self.hypothesis.similarity();
        if from == self.a {
            a_t_b
        } else {
            a_t_b.inverse()
        }
    }

    /// The other end of the overlap.
    pub fn other(&self, end: usize) -> usize {
        if end == self.a {
            self.b
        } else {
            self.a
        }
    }
}

/// Where each path sits in the first path's frame.
#[derive(Debug, Clone)]
pub struct Placement {
    /// Per path, `first_T_path` (`p_first = s R p + t`), `None` when the
    /// path overlaps none of the placed paths.
    pub frames: Vec<Option<Similarity3>>,
    /// Per placed path other than the first, the path it was placed
    /// through.
    pub via: Vec<Option<usize>>,
    /// The overlaps that placed a path, in the order they did.
    pub used: Vec<Overlap>,
    /// Overlaps between placed paths that agree with the placement (each
    /// path's other overlaps, beside the one that placed it).
    pub agreeing: Vec<Overlap>,
    /// Overlaps whose placement contradicted the one chosen.
    pub contradicted: Vec<Overlap>,
}

/// Partners each path is matched with at least: the ones sharing the most
/// turn triples with it ([`TurnIndex`]). 4: a placement needs one right
/// overlap per path and a second to corroborate a weak one, and a path's
/// overlaps with others are usually also reached through them; every
/// extra partner costs a full match per path. Sets of up to five paths
/// are matched in every pair.
pub const PARTNERS: usize = 4;

/// Places every path of `paths` in the frame of the first (see the module
/// doc). Fails when a path cannot be prepared (too short, no motion).
pub fn merge_many(paths: &[Trajectory], config: &Config) -> Result<Placement> {
    let prepared = crate::parallel::map(paths, |p| Some(PreparedPath::new(p, config)))
        .into_iter()
        .collect::<Result<Vec<_>>>()?;
    let pairs = pairs_to_match(&prepared, config);
    // Only a pair's best overlap is an edge: only it is ranked and polished.
    let best_only = Config {
        top_k: 1,
        ..config.clone()
    };
    let edges = crate::parallel::map(&pairs, |&(a, b)| {
        match_across_rates(&paths[a], &paths[b], &prepared[a], &prepared[b], &best_only)
            .into_iter()
            .next()
            .filter(|h| h.score >= MIN_OVERLAP_SCORE)
            .map(|hypothesis| Overlap { a, b, hypothesis })
    });
    let mut placement = place(paths, edges);
    let overlaps: Vec<&Overlap> = placement.used.iter().chain(&placement.agreeing).collect();
    placement.frames = super::refine::refine(paths, &placement.frames, &overlaps);
    Ok(placement)
}

/// The pairs worth a full match, `a < b`, in order: each path with its
/// [`PARTNERS`] partners sharing the most turn triples (then pairs of
/// turns: what ranks paths of fewer than three turns).
pub fn pairs_to_match(prepared: &[PreparedPath], config: &Config) -> Vec<(usize, usize)> {
    let n = prepared.len();
    let turns: Vec<_> = prepared
        .iter()
        .map(|p| crate::matching::turns::turns(&p.track, &p.signature, &config.turns))
        .collect();
    let index = TurnIndex::new(&turns);
    let votes: Vec<Vec<usize>> = (0..n).map(|p| index.votes(p)).collect();
    let pair_votes: Vec<Vec<usize>> = (0..n).map(|p| index.pair_votes(p)).collect();
    let mut chosen = std::collections::BTreeSet::new();
    for a in 0..n {
        let mut partners: Vec<usize> = (0..n).filter(|&b| b != a).collect();
        // Both directions' votes, each path's triples found in the other;
        // pairs of turns break ties (and rank paths of few turns).
        partners.sort_by_key(|&b| {
            std::cmp::Reverse((
                votes[a][b] + votes[b][a],
                pair_votes[a][b] + pair_votes[b][a],
            ))
        });
        for &b in partners.iter().take(PARTNERS) {
            chosen.insert((a.min(b), a.max(b)));
        }
    }
    chosen.into_iter().collect()
}

/// The placement through `edges` (see the module doc): strongest first,
/// each checked against the path's other overlaps with placed paths.
fn place(paths: &[Trajectory], mut edges: Vec<Overlap>) -> Placement {
    let n = paths.len();
    let mut placement = Placement {
        frames: vec![None; n],
        via: vec![None; n],
        used: Vec::new(),
        agreeing: Vec::new(),
        contradicted: Vec::new(),
    };
    if n == 0 {
        return placement;
    }
    placement.frames[0] = Some(Similarity3::identity());
    edges.sort_by(|x, y| y.hypothesis.score.total_cmp(&x.hypothesis.score));
    let frame_through = |frames: &[Option<Similarity3>], e: &Overlap, v: usize| {
        let u = e.other(v);
        frames[u]
            .as_ref()
            .map(|first_t_u| first_t_u.compose(&e.seen_from(u)))
    };
    // Weak overlaps not yet corroborated, looked at again once another
    // path is placed.
    let mut deferred: Vec<Overlap> = Vec::new();
    // Each round, the strongest overlap between a placed and an unplaced path.
    while let Some(k) = edges
        .iter()
        .position(|e| placement.frames[e.a].is_some() != placement.frames[e.b].is_some())
    {
        let e = edges.remove(k);
        let v = if placement.frames[e.a].is_none() {
            e.a
        } else {
            e.b
        };
        let Some(first_t_v) = frame_through(&placement.frames, &e, v) else {
            continue;
        };
        // The path's other overlaps with placed paths, each a placement
        // of its own: the strongest is kept unless those that disagree
        // with it outweigh it and those that agree, by score, so that one
        // weak look-alike (often with a path that shares no road with this
        // one) cannot outvote a strong overlap.
        let points = sample(&paths[v]);
        let (mut agree, mut disagree) = (Vec::new(), Vec::new());
        for (i, other) in edges.iter().enumerate() {
            if other.a != v && other.b != v {
                continue;
            }
            if let Some(alt) = frame_through(&placement.frames, other, v) {
                if agrees(&points, &first_t_v, &alt) {
                    agree.push(i);
                } else {
                    disagree.push(i);
                }
            }
        }
        let weight = |ids: &[usize]| ids.iter().map(|&i| edges[i].hypothesis.score).sum::<f64>();
        if weight(&disagree) > e.hypothesis.score + weight(&agree) {
            placement.contradicted.push(e);
            continue;
        }
        if e.hypothesis.score < STRONG_OVERLAP_SCORE && agree.is_empty() {
            deferred.push(e);
            continue;
        }
        // The overlaps that agree are used up; those that disagree are wrong.
        let mut gone: Vec<usize> = agree.iter().chain(&disagree).copied().collect();
        gone.sort_unstable();
        for &i in gone.iter().rev() {
            let other = edges.remove(i);
            if disagree.contains(&i) {
                placement.contradicted.push(other);
            } else {
                placement.agreeing.push(other);
            }
        }
        placement.via[v] = Some(e.other(v));
        placement.frames[v] = Some(first_t_v);
        placement.used.push(e);
        edges.append(&mut deferred);
        edges.sort_by(|x, y| y.hypothesis.score.total_cmp(&x.hypothesis.score));
    }
    placement
}

/// Most poses of a path compared between two placements.
const SAMPLES: usize = 200;

/// Up to [`SAMPLES`] poses of `path`, evenly spread.
fn sample(path: &Trajectory) -> Vec<Vector3<f64>> {
    let step = path.len().div_ceil(SAMPLES).max(1);
    path.poses
        .iter()
        .step_by(step)
        .map(|p| p.position)
        .collect()
}

/// Whether two placements of `points` agree (see [`AGREEMENT`]).
pub fn agrees(points: &[Vector3<f64>], x: &Similarity3, y: &Similarity3) -> bool {
    if points.is_empty() {
        return true;
    }
    let placed: Vec<Vector3<f64>> = points.iter().map(|p| x.apply(p)).collect();
    let extent = crate::geometry::extent(&placed);
    let mut d: Vec<f64> = points
        .iter()
        .zip(&placed)
        .map(|(p, q)| (y.apply(p) - q).norm())
        .collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2] <= AGREEMENT * extent
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// `positions` under `p -> s R p + t`.
    fn moved(positions: &[Vector3<f64>], s: f64, angle: f64, t: Vector3<f64>) -> Vec<Vector3<f64>> {
        let r = Rotation3::from_axis_angle(&Vector3::z_axis(), angle);
        positions.iter().map(|p| s * (r * p) + t).collect()
    }

    /// Median distance between `truth` and `positions` placed by `frame`.
    fn placed_error(
        frame: &Similarity3,
        positions: &[Vector3<f64>],
        truth: &[Vector3<f64>],
    ) -> f64 {
        let mut d: Vec<f64> = positions
            .iter()
            .zip(truth)
            .map(|(p, q)| (frame.apply(p) - q).norm())
            .collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    }

    /// A path of `n` unit steps turning by a piecewise constant curvature
    /// (up to 0.05 rad per step, changed every 30-90 steps), from `seed`.
    fn wander(seed: u64, n: usize) -> Vec<Vector3<f64>> {
        let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut p, mut heading, mut turn, mut left) = (Vector3::zeros(), 0.0, 0.0, 0);
        (0..n)
            .map(|_| {
                if left == 0 {
                    turn = 0.1 * (next() - 0.5);
                    left = 30 + (60.0 * next()) as usize;
                }
                left -= 1;
                heading += turn;
                p += Vector3::new(f64::cos(heading), f64::sin(heading), 0.0);
                p
            })
            .collect()
    }

    /// Three windows of one path in three frames, the third sharing no
    /// road with the first, and ten paths of their own: the windows are
    /// placed (the third through the second), the strangers are left out.
    #[test]
    fn a_chain_of_windows_is_placed_through_its_links_and_strangers_are_left_out() {
        let drive = wander(7, 6000);
        let windows = [0..2400, 1800..4200, 3600..6000];
        let moves = [
            (1.0, 0.0, Vector3::zeros()),
            (0.05, 1.1, Vector3::new(3.0, -2.0, 0.0)),
            (20.0, -2.5, Vector3::new(-500.0, 90.0, 0.0)),
        ];
        let mut paths: Vec<Trajectory> = windows
            .iter()
            .zip(&moves)
            .map(|(w, &(s, a, t))| {
                Trajectory::from_positions("w", &moved(&drive[w.clone()], s, a, t))
            })
            .collect();
        for seed in 100..110 {
            paths.push(Trajectory::from_positions("stranger", &wander(seed, 2400)));
        }
        let placement = merge_many(&paths, &Config::for_matching()).expect("placement");
        for (k, w) in windows.iter().enumerate() {
            let frame = placement.frames[k]
                .as_ref()
                .unwrap_or_else(|| panic!("{k} not placed"));
            let err = placed_error(frame, &paths[k].positions(), &drive[w.clone()]);
            // 2 % of a window of 2400 units.
            assert!(err < 48.0, "window {k} placed {err} units off");
        }
        assert_eq!(placement.via[..3], [None, Some(0), Some(1)]);
        let strangers = placement.frames[3..].iter().filter(|f| f.is_some()).count();
        assert_eq!(strangers, 0, "strangers placed");
    }

    /// The overlap of `b` into `a` with this score, shifting `b` by `shift`.
    fn overlap(a: usize, b: usize, score: f64, shift: f64) -> Overlap {
        let mut hypothesis = Hypothesis::scored(score, [0, 10], [0, 10], false);
        hypothesis.translation = Vector3::new(shift, 0.0, 0.0);
        Overlap { a, b, hypothesis }
    }

    /// Regression: a path's strong right overlap (score 0.4) was turned
    /// away because one weak look-alike with another placed path (0.15)
    /// disagreed and none agreed: overlaps were counted, not weighed.
    #[test]
    fn a_single_weak_look_alike_does_not_turn_a_strong_overlap_away() {
        let drive = wander(3, 900);
        let paths: Vec<Trajectory> = [0..400, 250..650, 500..900]
            .into_iter()
            .map(|w| Trajectory::from_positions("w", &drive[w]))
            .collect();
        let edges = vec![
            overlap(0, 1, 0.5, 0.0),
            overlap(1, 2, 0.4, 0.0),
            overlap(0, 2, 0.15, 1000.0),
        ];
        let placement = place(&paths, edges);
        assert_eq!(placement.via, [None, Some(0), Some(1)]);
        assert_eq!(placement.frames[2], Some(Similarity3::identity()));
        assert_eq!(placement.contradicted.len(), 1);
    }

    /// A window turned a little off its overlaps (within the agreement of
    /// two placements) is pulled back by the joint refinement; the first
    /// stays where it is.
    #[test]
    fn a_path_turned_off_its_overlaps_is_pulled_back_by_the_refinement() {
        let drive = wander(11, 5000);
        let windows = [0..3200, 1500..4000, 2400..5000];
        let moves = [
            (1.0, 0.0, Vector3::zeros()),
            (3.0, 0.7, Vector3::new(40.0, 10.0, 0.0)),
            (0.2, -1.9, Vector3::new(-5.0, 9.0, 0.0)),
        ];
        let paths: Vec<Trajectory> = windows
            .iter()
            .zip(&moves)
            .map(|(w, &(s, a, t))| {
                Trajectory::from_positions("w", &moved(&drive[w.clone()], s, a, t))
            })
            .collect();
        let placement = merge_many(&paths, &Config::for_matching()).expect("placement");
        assert!(placement.frames.iter().all(Option::is_some), "all placed");
        let overlaps: Vec<&Overlap> = placement.used.iter().chain(&placement.agreeing).collect();
        assert!(overlaps.len() >= 3, "the third window overlaps both others");
        // The last window turned by 1° about the first window's origin.
        let mut frames = placement.frames.clone();
        let turn = Similarity3 {
            scale: 1.0,
            rotation: *Rotation3::from_axis_angle(&Vector3::z_axis(), 1f64.to_radians()).matrix(),
            translation: Vector3::zeros(),
        };
        frames[2] = Some(turn.compose(&frames[2].unwrap()));
        let error = |frames: &[Option<Similarity3>], k: usize| {
            placed_error(
                frames[k].as_ref().unwrap(),
                &paths[k].positions(),
                &drive[windows[k].clone()],
            )
        };
        let off = error(&frames, 2);
        let refined = super::super::refine::refine(&paths, &frames, &overlaps);
        assert!(
            error(&refined, 2) < 0.25 * off,
            "{} of {off}",
            error(&refined, 2)
        );
        assert_eq!(refined[0], frames[0]);
    }
}
