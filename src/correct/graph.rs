//! The pose graph of one path: keyframe nodes, odometry edges between
//! consecutive keyframes, loop edges from loop closures.
//!
//! A node is the pose `world_T_node` of one keyframe. An edge `from -> to`
//! measures `from_T_to = world_T_from⁻¹ · world_T_to`. A loop that says "the
//! match part, moved by `query_T_match`, lies on the query part" becomes, for
//! a query keyframe `i` and the match keyframe `j` it lands on,
//!
//! ```text
//! j_T_i = world_T_j⁻¹ · match_T_query · world_T_i,   match_T_query = query_T_match⁻¹
//! ```
//!
//! because the drift that `query_T_match` undoes is the one between the two
//! passes: where the path is right, `i` and `j` are at the same place and
//! `j_T_i` is their true relative pose.

use super::config::{CorrectConfig, Group};
use super::loops::LoopClosure;
use crate::geometry::plane::Plane;
use crate::geometry::{nearest_rotation, Similarity3};
use crate::trajectory::Trajectory;
use crate::{Error, Result};
use nalgebra::{DMatrix, Matrix3, Vector3};

/// Standard deviations of one edge, in its `from` node's units and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sigmas {
    /// Translation, each axis (each axis across the road where the edge
    /// has a slide).
    pub translation: f64,
    /// Rotation, each axis (radians; each axis but the roll's where the
    /// edge has one).
    pub rotation: f64,
    /// Natural log of the scale (Sim(3) graphs only).
    pub log_scale: f64,
    /// A loop edge's freedom along the road; `None`: isotropic translation.
    ///
    /// Two passes over one road fit each other across it, but along it only
    /// as far as the road bends: on a straight their fit can slide by tens
    /// of metres with no misfit at all. A loop edge therefore measures where
    /// its pose lies across the earlier pass, and along it only to within
    /// the overlap's length; edges spread along a bend, whose directions
    /// differ, then pin the loop along the road together where the shape
    /// does.
    pub slide: Option<Loose>,
    /// A loop edge's freedom along the path's normal, across the road's
    /// surface; `None`: none beyond the other axes'.
    ///
    /// A levelled loop lays its passes at one height, but only to within
    /// the height difference that took ([`LoopClosure::height()`]): where the
    /// odometry drifts in height the loop pulls its passes together, where
    /// it does not (the passes truly apart, or a ground truth's own height
    /// error) the odometry holds them.
    pub height: Option<Loose>,
    /// A loop edge's freedom to turn about the road; `None`: isotropic
    /// rotation.
    ///
    /// A fit of two passes fixes rotation about an axis only as far as the
    /// points spread around that axis: about a straight road, whose points
    /// lie on one line, not at all, and a rigid fit then takes whatever
    /// roll its noise suggests (radians of it on a flat straight). The edge
    /// measures rotation about the axis its points spread least around only
    /// as well as that spread allows (`roll_axis`).
    pub roll: Option<Loose>,
}

/// An axis along which (translation) or about which (rotation) an edge
/// pins its node more loosely than on the others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Loose {
    /// Unit axis in the `to` node's frame (the frame of the residual).
    pub axis: Vector3<f64>,
    /// Sigma on it.
    pub sigma: f64,
}

/// The square root of the information of one block whose sigma is `sigma`
/// on every axis but the `loose` ones' (orthogonal to each other):
/// `(I - Σ a aᵀ) / σ + Σ a aᵀ / σ_a`. The projections are orthogonal, so its
/// square is the information `(I - Σ a aᵀ) / σ² + Σ a aᵀ / σ_a²`.
fn block(sigma: f64, loose: &[Option<Loose>]) -> Matrix3<f64> {
    let mut w = Matrix3::identity() / sigma;
    for l in loose.iter().flatten() {
        let aat = l.axis * l.axis.transpose();
        w += aat / l.sigma - aat / sigma;
    }
    w
}

impl Sigmas {
    /// `W` with `Wᵀ W` the information of the edge's residual
    /// `[t (3), ω (3), ln s (Sim(3) only)]`: the translation and rotation
    /// blocks of `block`, the scale's sigma.
    pub fn sqrt_information(&self, sim3: bool) -> DMatrix<f64> {
        let n = if sim3 { 7 } else { 6 };
        let mut w = DMatrix::zeros(n, n);
        let t = self.translation_sqrt_information();
        let r = self.rotation_sqrt_information();
        for i in 0..3 {
            for j in 0..3 {
                w[(i, j)] = t[(i, j)];
                w[(3 + i, 3 + j)] = r[(i, j)];
            }
        }
        if sim3 {
            w[(6, 6)] = 1.0 / self.log_scale;
        }
        w
    }

    /// The translation block of [`Sigmas::sqrt_information`].
    pub fn translation_sqrt_information(&self) -> Matrix3<f64> {
        block(self.translation, &[self.slide, self.height])
    }

    /// The rotation block of [`Sigmas::sqrt_information`].
    pub fn rotation_sqrt_information(&self) -> Matrix3<f64> {
        block(self.rotation, &[self.roll])
    }

    /// Whether the information is the same on every axis of each block.
    pub fn isotropic(&self) -> bool {
        self.slide.is_none() && self.height.is_none() && self.roll.is_none()
    }

    /// A translation residual (in the frame of the edge's `to` node) in
    /// its sigmas: the norm of the whitened residual.
    pub fn translation_misses(&self, r: &Vector3<f64>) -> f64 {
        (self.translation_sqrt_information() * r).norm()
    }

    /// A rotation residual (rotation vector in the frame of the edge's `to`
    /// node) in its sigmas.
    pub fn rotation_misses(&self, w: &Vector3<f64>) -> f64 {
        (self.rotation_sqrt_information() * w).norm()
    }
}

/// One relative-pose measurement between two nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    /// Node the measurement is expressed in.
    pub from: usize,
    /// Node measured.
    pub to: usize,
    /// `from_T_to` as measured (scale 1 in an SE(3) graph).
    pub from_T_to: Similarity3,
    /// Its uncertainty.
    pub sigmas: Sigmas,
    /// Index of the loop closure this edge comes from; `None` for odometry.
    pub loop_id: Option<usize>,
}

/// Nodes and edges of one path's graph, before optimisation.
#[derive(Debug, Clone)]
pub struct PoseGraph {
    /// Pose index of each node, increasing; the first and last pose are nodes.
    pub keyframes: Vec<usize>,
    /// `world_T_node` of each node as the path has it (scale 1).
    pub poses: Vec<Similarity3>,
    /// Where the odometry edges alone put the nodes: `poses`, or `poses`
    /// with a systematic drift taken out ([`PoseGraph::without`]).
    pub at_rest: Vec<Similarity3>,
    /// Odometry edges first (node k to k + 1), then loop edges.
    pub edges: Vec<Edge>,
    /// Sim(3) nodes (scale drifts) or SE(3).
    pub group: Group,
}

impl PoseGraph {
    /// Builds the graph of `path` with the given loop closures.
    ///
    /// Loops whose ranges hold no keyframe are left without edges (their
    /// verdict is then "rejected: no keyframe").
    pub fn build(path: &Trajectory, loops: &[LoopClosure], config: &CorrectConfig) -> Result<Self> {
        let n = path.len();
        if n < 2 {
            return Err(Error::input(
                &path.source,
                format!("{n} poses: a pose graph needs at least 2"),
            ));
        }
        let positions = path.positions();
        if let Some(i) = positions
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(Error::input(
                &path.source,
                format!("pose {i} is not finite"),
            ));
        }
        let arc = arc_length(&positions);
        let length = arc[n - 1];
        if length.is_nan() || length <= 0.0 {
            return Err(Error::input(
                &path.source,
                "the path never moves: nothing to correct",
            ));
        }
        let world_R_body = orientations(path);
        let keyframes = keyframes(n, loops, config);
        let poses: Vec<Similarity3> = keyframes
            .iter()
            .map(|&k| Similarity3 {
                scale: 1.0,
                rotation: world_R_body[k],
                translation: positions[k],
            })
            .collect();
        let group = config.group.resolve(loops);
        let mut edges = Vec::with_capacity(keyframes.len() + loops.len() * config.edges_per_loop);
        // Stationary stretches give zero steps: a tenth of the mean step keeps
        // their information finite without letting them bend the path.
        let floor = 0.1 * length / (n - 1) as f64;
        for k in 0..keyframes.len() - 1 {
            let d = (arc[keyframes[k + 1]] - arc[keyframes[k]]).max(floor);
            let between = poses[k].inverse().compose(&poses[k + 1]);
            edges.push(Edge {
                from: k,
                to: k + 1,
                from_T_to: between,
                sigmas: config.odometry.sigmas(d, length),
                loop_id: None,
            });
        }
        for (id, l) in loops.iter().enumerate() {
            edges.extend(loop_edges(
                &keyframes, &poses, &positions, &arc, l, id, group, config,
            ));
        }
        Ok(PoseGraph {
            keyframes,
            at_rest: poses.clone(),
            poses,
            edges,
            group,
        })
    }

    /// The loop edges of loop `id`.
    pub fn loop_edges(&self, id: usize) -> impl Iterator<Item = &Edge> {
        self.edges.iter().filter(move |e| e.loop_id == Some(id))
    }
}

/// Pose indices of the nodes: `max_nodes` spread evenly over the path, the
/// first and last pose, and `edges_per_loop` spread over each range of each
/// loop, so that a loop shorter than the even spacing still gets its edges
/// (on a grid [`LOOP_GRID`] times finer than the even spacing).
fn keyframes(n: usize, loops: &[LoopClosure], config: &CorrectConfig) -> Vec<usize> {
    let stride = n.div_ceil(config.max_nodes.max(2)).max(1);
    let mut keyframes: Vec<usize> = (0..n).step_by(stride).collect();
    keyframes.push(n - 1);
    let fine = (stride / LOOP_GRID).max(1);
    for l in loops {
        for r in [l.query_range, l.match_range] {
            let (a, b) = (r[0].min(n - 1), r[1].min(n - 1));
            keyframes.extend(
                spread(b.saturating_sub(a) + 1, edges(l, config))
                    .map(|k| on_grid(a + k, a, b, fine)),
            );
        }
    }
    keyframes.sort_unstable();
    keyframes.dedup();
    keyframes
}

/// Pose `i` of the range `a..=b` moved to the nearest multiple of `fine`,
/// kept within the range.
fn on_grid(i: usize, a: usize, b: usize, fine: usize) -> usize {
    ((i + fine / 2) / fine * fine).clamp(a, b)
}

/// Positions a loop's keyframes may take between two even nodes
/// ([`keyframes`]). A stream that laps a hall finds each revisit again at
/// every probe (UZH-FPV forward 6: 809 loops), and with keyframes of
/// each loop's own its graph would hold some 5 400 nodes; on a grid, loops
/// of one revisit share them. Ten: a keyframe moves by at most a twentieth of the even
/// spacing, less than a loop's own edges lie apart (five over its range);
/// on paths of under twenty times `max_nodes` poses (KITTI's drives and
/// EuRoC's estimates, up to 4 661) the grid is every pose.
const LOOP_GRID: usize = 10;

/// `picks` indices into `0..len` spread evenly, the first and the last
/// among them; one pick is the middle.
fn spread(len: usize, picks: usize) -> impl Iterator<Item = usize> {
    let last = len.saturating_sub(1);
    (0..picks).map(move |q| match picks {
        1 => last / 2,
        _ => (q * last) / (picks - 1),
    })
}

/// Edges of loop `l`: `edges_per_loop`, shared among the pieces of a loop
/// cut into pieces ([`LoopClosure::pieces`]), at least one each, so that a
/// loop in pieces adds no more nodes and edges than the loop whole.
fn edges(l: &LoopClosure, config: &CorrectConfig) -> usize {
    (config.edges_per_loop / l.share.max(1)).max(1)
}

/// Edges of one loop: up to `edges_per_loop` query keyframes spread over the
/// query range, each tied to the match keyframe its point lands nearest to.
#[allow(clippy::too_many_arguments)]
fn loop_edges(
    keyframes: &[usize],
    poses: &[Similarity3],
    positions: &[Vector3<f64>],
    arc: &[f64],
    l: &LoopClosure,
    id: usize,
    group: Group,
    config: &CorrectConfig,
) -> Vec<Edge> {
    let nodes_in = |r: [usize; 2]| -> Vec<usize> {
        (0..keyframes.len())
            .filter(|&k| keyframes[k] >= r[0] && keyframes[k] <= r[1])
            .collect()
    };
    let (query, matched) = (nodes_in(l.query_range), nodes_in(l.match_range));
    if query.is_empty() || matched.is_empty() {
        return Vec::new();
    }
    let match_T_query = l.query_T_match.inverse();
    let picks = edges(l, config).min(query.len());
    let chosen: Vec<usize> = spread(query.len(), picks).map(|k| query[k]).collect();
    let length = (arc[l.query_range[1]] - arc[l.query_range[0]]).max(f64::EPSILON);
    // Each edge a share of its loop's information, each piece of a loop
    // a share of the loop's (`LoopClosure::share`).
    let shares = picks * l.share.max(1);
    let sigmas = config.loop_noise.sigmas(l.rmse, length, shares);
    let slide = |i: usize| -> Option<Loose> {
        // The direction of travel at keyframe `i`, in its own frame.
        let world = travel(positions, keyframes[i]);
        (world.norm() > 0.0).then(|| Loose {
            axis: poses[i].rotation.transpose() * world.normalize(),
            sigma: config.loop_noise.slide * length * (shares as f64).sqrt(),
        })
    };
    // Along the levelling move (the path's normal) square to the direction
    // of travel, so that the two loose axes are orthogonal; at least as
    // loose as the other axes.
    let height = |i: usize| -> Option<Loose> {
        let along = slide(i).map_or_else(Vector3::zeros, |s| poses[i].rotation * s.axis);
        let up = l.level.try_normalize(0.0)?;
        let world = up - along * along.dot(&up);
        let sigma = l.height() * (shares as f64).sqrt();
        (world.norm() > 0.0 && sigma > sigmas.translation).then(|| Loose {
            axis: poses[i].rotation.transpose() * world.normalize(),
            sigma,
        })
    };
    let lever = config
        .rigid_loops
        .then(|| roll_axis(&positions[l.query_range[0]..=l.query_range[1]]))
        .flatten();
    let roll = |i: usize| -> Option<Loose> {
        let (axis, ratio) = lever?;
        Some(Loose {
            axis: poses[i].rotation.transpose() * axis,
            sigma: config.loop_noise.roll(sigmas.rotation, ratio, shares),
        })
    };
    chosen
        .into_iter()
        .filter_map(|i| {
            let target = match_T_query.apply(&poses[i].translation);
            let j = *matched.iter().min_by(|&&a, &&b| {
                (poses[a].translation - target)
                    .norm_squared()
                    .total_cmp(&(poses[b].translation - target).norm_squared())
            })?;
            if i == j {
                return None;
            }
            let mut j_T_i = poses[j]
                .inverse()
                .compose(&match_T_query)
                .compose(&poses[i]);
            if group == Group::Se3 {
                j_T_i.scale = 1.0;
            }
            Some(Edge {
                from: j,
                to: i,
                from_T_to: j_T_i,
                sigmas: Sigmas {
                    slide: slide(i),
                    height: height(i),
                    roll: roll(i),
                    ..sigmas
                },
                loop_id: Some(id),
            })
        })
        .collect()
}

/// The axis (world frame) about which `points` spread least, and how much
/// less than about the axis they spread most around: `√(λ_max / λ_min)` of
/// `H = tr(C) I - C`, `C` their covariance. `H` is the curvature of a rigid
/// fit's misfit under a small rotation of the points about their centroid
/// (`Σ |ω × p|² = ωᵀ H ω` per point), so a fit fixes rotation about each
/// eigen-axis to the misfit over the root of its eigenvalue: the points' RMS
/// lever about it. `None` for fewer than two distinct points.
fn roll_axis(points: &[Vector3<f64>]) -> Option<(Vector3<f64>, f64)> {
    let n = points.len() as f64;
    let mean = points.iter().sum::<Vector3<f64>>() / n;
    let c = points
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum::<Matrix3<f64>>()
        / n;
    let h = Matrix3::identity() * c.trace() - c;
    let eig = nalgebra::SymmetricEigen::new(h);
    let (most, least) = (eig.eigenvalues.max(), eig.eigenvalues.imin());
    if most.is_nan() || most <= 0.0 {
        return None;
    }
    let ratio = (most / eig.eigenvalues[least].max(0.0)).sqrt();
    Some((eig.eigenvectors.column(least).into_owned(), ratio))
}

/// The step across pose `i` (from the pose before it to the one after):
/// the direction of travel there, zero where the path stands still.
fn travel(positions: &[Vector3<f64>], i: usize) -> Vector3<f64> {
    let n = positions.len();
    positions[(i + 1).min(n - 1)] - positions[i.saturating_sub(1)]
}

/// Cumulative arc length at each pose.
pub fn arc_length(positions: &[Vector3<f64>]) -> Vec<f64> {
    let mut s = Vec::with_capacity(positions.len());
    let mut acc = 0.0;
    for (i, p) in positions.iter().enumerate() {
        if i > 0 {
            acc += (p - positions[i - 1]).norm();
        }
        s.push(acc);
    }
    s
}

/// `world_R_body` of every pose: the path's own where it has them, else a
/// frame along the direction of travel (x forward, z the normal of the
/// path's best-fit plane), held through stationary stretches.
pub fn orientations(path: &Trajectory) -> Vec<Matrix3<f64>> {
    if path.poses.iter().all(|p| p.orientation.is_some()) {
        return path
            .poses
            .iter()
            .map(|p| {
                p.orientation
                    .map(|q| *q.to_rotation_matrix().matrix())
                    .unwrap_or_default()
            })
            .collect();
    }
    let positions = path.positions();
    let n = positions.len();
    let up = Plane::fit(&positions).world_R_plane.column(2).into_owned();
    let mut out: Vec<Option<Matrix3<f64>>> = vec![None; n];
    for (i, slot) in out.iter_mut().enumerate() {
        let forward = travel(&positions, i);
        let forward = forward - up * up.dot(&forward);
        if forward.norm() > 0.0 {
            let x = forward.normalize();
            let y = up.cross(&x);
            *slot = Some(Matrix3::from_columns(&[x, y, up]));
        }
    }
    let first = out
        .iter()
        .flatten()
        .next()
        .copied()
        .unwrap_or_else(Matrix3::identity);
    let mut last = first;
    out.into_iter()
        .map(|r| {
            last = r.unwrap_or(last);
            // Re-orthonormalise: the rows above are exact up to rounding.
            *nearest_rotation(&last).matrix()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::loops::tests::walk;
    use super::*;
    use crate::geometry::Similarity3;

    /// Regression: a stream that laps a hall finds each revisit again at
    /// every probe, a few poses on, and each such loop's keyframes were
    /// nodes of their own (UZH-FPV forward 6: 5 400 nodes, 41 s for the
    /// last re-optimisation). On a path of 10 000 poses (even nodes every
    /// 40, a loop's on every 4th pose) four loops of one revisit, a pose
    /// apart, share their keyframes inside their ranges.
    #[test]
    fn loops_of_one_revisit_found_a_few_poses_apart_share_their_keyframes() {
        let path = Trajectory::from_positions(
            "square",
            &walk(&[
                [0.0, 0.0],
                [2500.0, 0.0],
                [2500.0, 2500.0],
                [0.0, 2500.0],
                [0.0, 0.0],
            ]),
        );
        let n = path.len();
        let config = CorrectConfig::default();
        let twin = |d: usize| {
            LoopClosure::new(
                &path,
                [6003 + d, 6403 + d],
                [1003 + d, 1403 + d],
                Some(Similarity3::identity()),
                1.0,
                false,
            )
            .unwrap()
        };
        let loops: Vec<LoopClosure> = (0..4).map(twin).collect();
        let even = keyframes(n, &[], &config);
        let one = keyframes(n, &loops[..1], &config).len() - even.len();
        let with_four = keyframes(n, &loops, &config);
        let four = with_four.len() - even.len();
        // Each range's two ends stay each loop's own (16 in all); the three
        // keyframes between them fall on the grid, a pick of four loops a
        // pose apart on at most two of its points (12), against 40 apart.
        assert!(one >= 8, "one loop added {one} keyframes");
        assert!(
            four <= 16 + 12,
            "four loops a pose apart added {four}, one {one}"
        );
        // Every keyframe the loops add that is not an end of a range lies
        // on the grid.
        let ends: Vec<usize> = loops
            .iter()
            .flat_map(|l| [l.query_range, l.match_range])
            .flatten()
            .collect();
        for k in with_four {
            if !even.contains(&k) && !ends.contains(&k) {
                assert_eq!(k % 4, 0, "keyframe {k} off the grid");
            }
        }
    }
}
