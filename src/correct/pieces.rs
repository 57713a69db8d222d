//! A loop cut into pieces for the final solve: one similarity over a long
//! revisit takes the drift between its passes as constant along it, its
//! pieces fitted each on its own let the graph follow the drift.

use std::cmp::Ordering;

use nalgebra::Vector3;

use super::graph::arc_length;
use super::loops::{fit_ranges, level, misfit, shows_scale};
use super::LoopClosure;
use crate::geometry::Similarity3;

/// Fewest poses of a piece of a loop ([`LoopClosure::pieces`]): a similarity
/// is fitted to no fewer than three points; a loop too short to give each
/// piece as many stays whole.
pub const PIECE_POSES: usize = 3;

/// Misfit of a loop's one similarity over that of its pieces fitted each
/// on its own ([`LoopClosure::pieces`]) from which the drift between the
/// passes is taken to vary along the loop. Pieces fit better anyway, each
/// taking up the road's own wiggles: on a path without drift (KITTI's
/// ground truth streamed) five fit 1.9-2.9 times better than one
/// similarity, and at twice the stream's loops moved ground truth 02 by
/// 0.94 m (0.35 m whole). Three: the long revisits of drifting LiDAR
/// odometry, whose drift bends one pass away from the other, fit 2.5-10
/// times better in pieces (`evaluate_correct`).
pub const PIECES_SHOWN: f64 = 3.0;

impl LoopClosure {
    /// The loop cut along its query range into `count` pieces of equal
    /// length, each fitted on its own (the loop's similarity, or a fit of
    /// the piece's two ranges paired along their arc length at the loop's
    /// scale unless the piece's shape shows its own, whichever misses less)
    /// and sharing the loop's information ([`LoopClosure::share`]); the
    /// loop whole, levelled, where the pieces do not fit at least
    /// [`PIECES_SHOWN`] times better or would hold fewer than
    /// [`PIECE_POSES`] poses each. One similarity over a long
    /// revisit takes the drift between the two passes as constant along
    /// it; where the pieces fit far better, the drift varies along it and
    /// the pieces let the graph follow. A loop travelled the other way stays
    /// whole: a local fit of a road driven both ways lays its two lanes onto
    /// each other. The match piece of each query piece is the match range
    /// between the poses its ends land nearest to.
    pub fn pieces(&self, positions: &[Vector3<f64>], count: usize) -> Vec<Self> {
        let whole = self.levelled(positions);
        let [q0, q1] = self.query_range;
        if self.reversed || count < 2 || q1 + 1 - q0 < PIECE_POSES * count {
            return vec![whole];
        }
        let arc = arc_length(&positions[q0..=q1]);
        let total = arc.last().copied().unwrap_or(0.0);
        let [m0, m1] = self.match_range;
        let moved: Vec<Vector3<f64>> = positions[m0..=m1]
            .iter()
            .map(|p| whole.query_T_match.apply(p))
            .collect();
        let nearest = |q: usize| -> usize {
            let p = positions[q];
            m0 + (0..moved.len())
                .min_by(|&a, &b| {
                    (moved[a] - p)
                        .norm_squared()
                        .total_cmp(&(moved[b] - p).norm_squared())
                })
                .unwrap_or(0)
        };
        let mut out = Vec::with_capacity(count);
        let mut start = q0;
        for k in 1..=count {
            let end = match k == count {
                true => q1,
                false => q0 + arc.partition_point(|&s| s < total * k as f64 / count as f64),
            };
            let (a, b) = (nearest(start), nearest(end));
            let matched = [a.min(b), a.max(b)];
            if end > start + 1 && matched[1] > matched[0] + 1 {
                if let Some(piece) = whole.piece(positions, [start, end], matched) {
                    out.push(piece);
                }
            }
            start = end;
        }
        let misfit =
            (out.iter().map(|l| l.rmse * l.rmse).sum::<f64>() / out.len().max(1) as f64).sqrt();
        let better = (misfit * PIECES_SHOWN).partial_cmp(&whole.rmse) == Some(Ordering::Less);
        if out.len() < count || !better {
            return vec![whole];
        }
        for l in &mut out {
            l.share = count;
            l.scale_shown = self.scale_shown;
        }
        out
    }

    /// One piece of the (levelled) loop `self` over the given ranges: the
    /// loop's similarity or the ranges' own fit, whichever misses less, the
    /// fit at the loop's scale (about the match piece's centre) unless the
    /// piece's shape shows its own. `None` where the ranges fit nothing.
    fn piece(
        &self,
        positions: &[Vector3<f64>],
        query_range: [usize; 2],
        match_range: [usize; 2],
    ) -> Option<Self> {
        let query = &positions[query_range[0]..=query_range[1]];
        let matched = &positions[match_range[0]..=match_range[1]];
        // As `new` takes them: a fit of the ranges lays the passes'
        // centroids on each other, level already.
        let at = |(sim, fitted): (Similarity3, bool)| {
            Self {
                query_range,
                match_range,
                query_T_match: sim,
                rmse: misfit(query, matched, &sim),
                level: match fitted {
                    true => Vector3::zeros(),
                    false => level(positions, query, matched, &sim),
                },
                levelled: false,
                share: 1,
                ..self.clone()
            }
            .levelled(positions)
        };
        let own = fit_ranges(positions, query, matched, false)?;
        let own = match shows_scale(query, matched, &own) {
            true => (own, true),
            false => {
                let c = matched.iter().sum::<Vector3<f64>>() / matched.len() as f64;
                let s = self.query_T_match.scale;
                let sim = Similarity3 {
                    scale: s,
                    rotation: own.rotation,
                    translation: own.apply(&c) - s * (own.rotation * c),
                };
                (sim, false)
            }
        };
        let [a, b] = [(self.query_T_match, false), own].map(at);
        Some(if b.rmse < a.rmse { b } else { a })
    }
}

#[cfg(test)]
mod tests {
    use super::super::loops::tests::{two_passes, walk};
    use super::super::{CorrectConfig, PoseGraph};
    use super::*;

    /// A zig-zag of `n` legs of 40 units, corners alternating left and
    /// right.
    fn zig_zag(n: usize) -> Vec<[f64; 2]> {
        (0..=n)
            .map(|k| [40.0 * k as f64, if k % 2 == 0 { 0.0 } else { 25.0 }])
            .collect()
    }

    /// The points of `pass` turned about the origin by an angle growing
    /// along them to `turn` radians at the end: a heading drift that bends
    /// the later pass away from the earlier one along the loop.
    fn bent(pass: &[Vector3<f64>], turn: f64) -> Vec<Vector3<f64>> {
        let last = (pass.len() - 1).max(1) as f64;
        pass.iter()
            .enumerate()
            .map(|(k, p)| {
                let a = turn * k as f64 / last;
                Vector3::new(
                    a.cos() * p.x - a.sin() * p.y,
                    a.sin() * p.x + a.cos() * p.y,
                    0.0,
                )
            })
            .collect()
    }

    /// `points` moved by `by`.
    fn moved(points: &[Vector3<f64>], by: Vector3<f64>) -> Vec<Vector3<f64>> {
        points.iter().map(|p| p + by).collect()
    }

    /// One similarity over a long revisit takes the drift between its
    /// passes as constant; where the later pass bends away along it, the
    /// loop's pieces each fit far better, and share its information.
    #[test]
    fn a_loop_whose_passes_bend_apart_is_cut_into_pieces() {
        let first = walk(&zig_zag(10));
        let second = moved(&bent(&first, 0.15), Vector3::new(0.0, 500.0, 0.0));
        let (path, q, m) = two_passes(&first, &second);
        let l = LoopClosure::new(&path, q, m, None, 1.0, false).unwrap();
        let positions = path.positions();
        let pieces = l.pieces(&positions, 5);
        assert_eq!(
            pieces.len(),
            5,
            "the bent loop stayed whole (misfit {})",
            l.rmse
        );
        let misfit = pieces.iter().map(|p| p.rmse).fold(0.0, f64::max);
        assert!(
            misfit * PIECES_SHOWN < l.rmse,
            "pieces misfit {misfit}, whole {}",
            l.rmse
        );
        assert!(pieces.iter().all(|p| p.share == 5 && p.levelled));
        assert_eq!(pieces[0].query_range[0], q[0]);
        assert_eq!(pieces[4].query_range[1], q[1]);
        assert!(pieces
            .windows(2)
            .all(|w| w[0].query_range[1] == w[1].query_range[0]));
        // The pieces share the loop's edges: no more edges, each as loose
        // as the loop's share of its information makes it.
        let config = CorrectConfig::default();
        let edges = |loops: &[LoopClosure]| {
            let graph = PoseGraph::build(&path, loops, &config).unwrap();
            (0..loops.len())
                .map(|id| graph.loop_edges(id).count())
                .sum::<usize>()
        };
        assert_eq!(edges(&pieces), edges(std::slice::from_ref(&l)));
    }

    /// A loop its one similarity fits (the later pass moved as a whole)
    /// stays whole, and so does one travelled the other way.
    #[test]
    fn a_loop_one_similarity_fits_or_travelled_back_stays_whole() {
        let first = walk(&zig_zag(10));
        let (path, q, m) = two_passes(&first, &moved(&first, Vector3::new(3.0, 500.0, 0.0)));
        let l = LoopClosure::new(&path, q, m, None, 1.0, false).unwrap();
        let positions = path.positions();
        assert_eq!(l.pieces(&positions, 5).len(), 1);
        let mut back = moved(&bent(&first, 0.15), Vector3::new(0.0, 500.0, 0.0));
        back.reverse();
        let (path, q, m) = two_passes(&first, &back);
        let l = LoopClosure::new(&path, q, m, None, 1.0, true).unwrap();
        let whole = l.pieces(&path.positions(), 5);
        assert_eq!(whole.len(), 1);
        assert_eq!(whole[0].share, 1);
    }

    /// Regression: a loop of 12 poses (MULLS 07 with loop closure, its
    /// return to the start fitted at scale 0.4) was cut into pieces of two
    /// poses, one of which the final solve kept, moving the path 0.34 ->
    /// 0.40 m. A loop too short for [`PIECE_POSES`] in each piece stays
    /// whole.
    #[test]
    fn a_loop_too_short_for_its_pieces_stays_whole() {
        let sparse = |p: &[Vector3<f64>]| p.iter().step_by(40).copied().collect::<Vec<_>>();
        let first = walk(&zig_zag(10));
        let second = moved(&bent(&first, 0.15), Vector3::new(0.0, 500.0, 0.0));
        let (path, q, m) = two_passes(&sparse(&first), &sparse(&second));
        assert!(q[1] + 1 - q[0] < PIECE_POSES * 5);
        let l = LoopClosure::new(&path, q, m, None, 1.0, false).unwrap();
        assert_eq!(l.pieces(&path.positions(), 5).len(), 1);
    }
}
