//! Systematic drift: odometry that turns, and whose scale grows, at one
//! rate along the path (a gyro's bias about the vertical, wheels of
//! unequal radii or a LiDAR's calibration slightly off, a monocular
//! odometry's scale running away; not a wheel base off, whose error is a
//! share of each turn: EVALUATION.md, "A wheel base off"), measured from
//! the chosen loops and taken out of the odometry before the final solve.
//!
//! The graph's odometry prior is a random walk: it spreads a loop's miss
//! over the path between the loop's passes and leaves the rest of the path
//! as it was. A bias is the same all along, so the loops that show it also
//! say how the stretches no loop spans have drifted. With the bias
//! `(θ, σ)` (radians and ln(scale) over the whole path), node `k`, at the
//! fraction `f_k` of the path's length, is turned back by `θ f_k` about the
//! path's normal `n`, and its step to the next node scaled by
//! `exp(-σ f_k)`:
//!
//! ```text
//! p'_{k+1} = p'_k + exp(-σ f_k) R(n, -θ f_k) (p_{k+1} - p_k),   R'_k = R(n, -θ f_k) R_k
//! ```
//!
//! (in a Sim(3) graph the node's scale is `exp(-σ f_k)` and its steps, in
//! its own units, stay as measured). The bias taken is the one under which
//! the chosen loops are most likely, at the most likely drift factor
//! (`drift::most_likely_right`), each rate only where it raises that
//! likelihood beyond chance at three sigmas, within the prior's three
//! sigmas over the path, on three loops or more, and where the loops, each
//! left out in turn, are more likely under the bias the others show than
//! under none: a path without a bias keeps its odometry as measured, and a
//! random walk read at a few loops is not taken for a rate.

use nalgebra::{Rotation3, Unit, Vector3};

use super::config::Group;
use super::drift;
use super::graph::PoseGraph;
use crate::geometry::plane::Plane;
use crate::geometry::Similarity3;

/// Twice the rise of the log-likelihood each rate of a bias must bring:
/// the χ² quantile of one degree of freedom at three sigmas (3², p =
/// 0.0027), the gate the loops themselves pass
/// ([`super::CorrectConfig::reject_above`]).
const SHOWN: f64 = 9.0;

/// Loops a bias needs, so that each left out is predicted by at least two
/// others: one loop's rate is its own stretch's random walk, two that
/// agree on it are a rate.
const MIN_LOOPS: usize = 3;

/// The log-likelihood the loops left out in turn must gain, together,
/// under the bias the others show: ln 2, twice as likely as under none.
/// On KITTI's LiDAR odometry the biases taken gain 1.3-19 (A-LOAM and
/// MULLS 00, MULLS 05); random-walk drift read as a rate at three loops
/// gains 0.1-0.3, and corrects worse for it.
const HELD_OUT: f64 = std::f64::consts::LN_2;

/// First step of the search, in radians and ln(scale) over the path: half
/// a radian of heading and a factor 1.6 of scale over the path, beyond what
/// metric odometry drifts (KITTI's LiDAR estimates: under 0.1 rad) and
/// near what a monocular one does (ORB-SLAM2 08: 1.5-2 between passes).
const FIRST_STEP: f64 = 0.5;

/// Last step of the search: a thousandth of a radian, or of ln(scale), over
/// the path moves its far end by a thousandth of the path's length, below
/// any loop's own noise.
const LAST_STEP: f64 = 1e-3;

/// A constant turn and scale growth along a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bias {
    /// The axis the path turns about: its plane's normal.
    pub normal: Vector3<f64>,
    /// Radians the odometry turned by over the whole path, about `normal`,
    /// beyond the way it went.
    pub turn: f64,
    /// ln of the factor the odometry's steps grew by over the whole path.
    pub log_scale: f64,
}

impl Bias {
    /// As `correct --json` and `stream`'s `corrected` event report it: the
    /// turn in degrees and the factor of scale over the whole path.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "turn_degrees": self.turn.to_degrees(),
            "scale": self.log_scale.exp(),
        })
    }

    /// `poses` (nodes of one path, in order) with the bias taken out.
    pub fn remove(&self, poses: &[Similarity3], group: Group) -> Vec<Similarity3> {
        let fraction = fractions(poses);
        let normal = Unit::new_normalize(self.normal);
        let turn = |f: f64| Rotation3::from_axis_angle(&normal, -self.turn * f).into_inner();
        let mut at = poses.first().map_or_else(Vector3::zeros, |p| p.translation);
        let mut out = Vec::with_capacity(poses.len());
        for (k, pose) in poses.iter().enumerate() {
            if k > 0 {
                let f = fraction[k - 1];
                let step = pose.translation - poses[k - 1].translation;
                at += (-self.log_scale * f).exp() * (turn(f) * step);
            }
            let f = fraction[k];
            out.push(Similarity3 {
                scale: match group {
                    Group::Sim3 => (-self.log_scale * f).exp(),
                    _ => 1.0,
                },
                rotation: turn(f) * pose.rotation,
                translation: at,
            });
        }
        out
    }
}

/// Each node's distance along the path (its chords), over the whole.
fn fractions(poses: &[Similarity3]) -> Vec<f64> {
    let mut s = Vec::with_capacity(poses.len());
    let mut total = 0.0;
    for (k, p) in poses.iter().enumerate() {
        if k > 0 {
            total += (p.translation - poses[k - 1].translation).norm();
        }
        s.push(total);
    }
    if total > 0.0 {
        s.iter_mut().for_each(|x| *x /= total);
    }
    s
}

/// The bias the loops in `active` show on `graph`'s path, if they show one
/// beyond chance ([`SHOWN`]) and the loops, each left out in turn, are more
/// likely under the bias the others show than under none ([`HELD_OUT`]): a
/// random walk's heading drift, read at two or three loops, also looks like
/// a rate there, but not one that holds elsewhere (taken out, it corrects
/// KITTI 02's truth under a random walk to 36.9 m instead of 24.2 m).
pub(super) fn measure(graph: &PoseGraph, active: &[bool], gate: f64) -> Option<Bias> {
    let ids: Vec<usize> = (0..active.len())
        .filter(|&id| active[id] && graph.loop_edges(id).next().is_some())
        .collect();
    if ids.len() < MIN_LOOPS {
        return None;
    }
    // The odometry prior bounds drift: a rate beyond `gate` of its sigmas
    // over the whole path is no bias it allows.
    let odometry = graph.edges.iter().filter(|e| e.loop_id.is_none());
    let (turns, scales) = odometry.fold((0.0, 0.0), |(r, s), e| {
        (
            r + e.sigmas.rotation.powi(2),
            s + e.sigmas.log_scale.powi(2),
        )
    });
    let bound = [gate * f64::sqrt(turns), gate * f64::sqrt(scales)];
    let chains: Vec<drift::Misses> = ids.iter().map(|&id| drift::chain(graph, id)).collect();
    let points: Vec<Vector3<f64>> = graph.poses.iter().map(|p| p.translation).collect();
    let normal = Plane::fit(&points).world_R_plane.column(2).into_owned();
    let bias = |b: [f64; 2]| Bias {
        normal,
        turn: b[0],
        log_scale: b[1],
    };
    let misses_at = |b: [f64; 2]| -> Vec<drift::Misses> {
        let at = bias(b).remove(&graph.poses, graph.group);
        ids.iter()
            .zip(&chains)
            .map(|(&id, c)| c.at(graph, &at, id))
            .collect()
    };
    // An SE(3) graph is metric odometry, whose loops show no scale drift
    // (Group::resolve): only its turn is measured. Its loops slide along
    // the road, and their misses across it fix no scale: a growth fitted
    // to them bends streamed KITTI MULLS 06 from 0.28 to 6.39 m.
    let scale = graph.group == Group::Sim3;
    // The most likely drift factor and its likelihood for the loops `of`.
    let likely =
        |m: &[drift::Misses], of: &[usize]| drift::most_likely_right(of.iter().map(|&i| &m[i]));
    // The rates the loops `of` show: each enters only where it explains
    // them beyond chance, the turn first, then the scale growth beside it.
    let fit = |of: &[usize]| -> [f64; 2] {
        let likelihood = |b: [f64; 2]| likely(&misses_at(b), of).1;
        let none = likelihood([0.0, 0.0]);
        let (turned, turn) = search(&likelihood, [0.0, 0.0], none, 1, bound);
        let (grown, both) = match scale {
            true => search(&likelihood, turn, turned, 2, bound),
            false => (turned, turn),
        };
        if 2.0 * (grown - turned) > SHOWN {
            both
        } else if 2.0 * (turned - none) > SHOWN {
            turn
        } else {
            [0.0, 0.0]
        }
    };
    let all: Vec<usize> = (0..ids.len()).collect();
    let rates = fit(&all);
    if rates == [0.0, 0.0] {
        return None;
    }
    let unbiased = misses_at([0.0, 0.0]);
    let mut gain = 0.0;
    for left in 0..ids.len() {
        let others: Vec<usize> = all.iter().copied().filter(|&i| i != left).collect();
        let shown = fit(&others);
        let biased = misses_at(shown);
        let (k, _) = likely(&biased, &others);
        let (k0, _) = likely(&unbiased, &others);
        gain += biased[left].ln_p(k) - unbiased[left].ln_p(k0);
    }
    (gain > HELD_OUT).then(|| bias(rates))
}

/// A pattern search from `from` (where `likelihood` is `at`) over the
/// first `axes` rates: the likelihood's drift factor moves in tenths of a
/// decade, so it has no gradient to follow, but it is smooth enough in
/// the rates.
fn search(
    likelihood: &impl Fn([f64; 2]) -> f64,
    from: [f64; 2],
    at: f64,
    axes: usize,
    bound: [f64; 2],
) -> (f64, [f64; 2]) {
    let (mut best, mut rates) = (at, from);
    let mut step = FIRST_STEP;
    while step >= LAST_STEP {
        let mut moved = false;
        for axis in 0..axes {
            for sign in [-1.0, 1.0] {
                let mut b = rates;
                b[axis] += sign * step;
                if b[axis].abs() > bound[axis] {
                    continue;
                }
                let l = likelihood(b);
                if l > best {
                    (best, rates, moved) = (l, b, true);
                }
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    (best, rates)
}

impl PoseGraph {
    /// The graph with `bias` taken out of its odometry: its odometry edges
    /// between the nodes as [`Bias::remove`] puts them, `at_rest` there;
    /// its loop edges, measured on the path as it is, and its `poses`, the
    /// path's own, stay.
    pub fn without(&self, bias: &Bias) -> PoseGraph {
        let at_rest = bias.remove(&self.poses, self.group);
        let mut edges = self.edges.clone();
        for e in edges.iter_mut().filter(|e| e.loop_id.is_none()) {
            e.from_T_to = at_rest[e.from].inverse().compose(&at_rest[e.to]);
        }
        PoseGraph {
            keyframes: self.keyframes.clone(),
            poses: self.poses.clone(),
            at_rest,
            edges,
            group: self.group,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nodes along a square's sides, heading along each side, scale 1.
    fn square() -> Vec<Similarity3> {
        let mut out = Vec::new();
        let mut at = Vector3::new(3.0, -1.0, 2.0);
        for side in 0..4 {
            let heading = side as f64 * std::f64::consts::FRAC_PI_2;
            let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), heading).into_inner();
            for _ in 0..10 {
                out.push(Similarity3 {
                    scale: 1.0,
                    rotation,
                    translation: at,
                });
                at += rotation * Vector3::new(0.7, 0.0, 0.0);
            }
        }
        out
    }

    fn bias(turn: f64, log_scale: f64) -> Bias {
        Bias {
            normal: Vector3::z(),
            turn,
            log_scale,
        }
    }

    #[test]
    fn a_turn_taken_out_and_put_back_leaves_the_path() {
        let path = square();
        for group in [Group::Se3, Group::Sim3] {
            let out = bias(0.4, 0.0).remove(&path, group);
            let back = bias(-0.4, 0.0).remove(&out, group);
            for (a, b) in path.iter().zip(&back) {
                assert!((a.translation - b.translation).norm() < 1e-12);
                assert!((a.rotation - b.rotation).norm() < 1e-12);
            }
            // The first node stays, the last is turned back by the whole turn.
            assert!((out[0].translation - path[0].translation).norm() < 1e-12);
            let last = out.last().unwrap().rotation * path.last().unwrap().rotation.transpose();
            let angle = Rotation3::from_matrix_unchecked(last).angle();
            assert!((angle - 0.4).abs() < 1e-9, "{angle}");
        }
    }

    /// In SE(3) a scale growth is taken out of the steps' lengths; in Sim(3)
    /// it goes into the nodes' scales and the steps in each node's own
    /// units stay as measured.
    #[test]
    fn a_scale_growth_shrinks_the_steps_or_goes_into_the_scales() {
        let path = square();
        let se3 = bias(0.0, 0.5).remove(&path, Group::Se3);
        let sim3 = bias(0.0, 0.5).remove(&path, Group::Sim3);
        let f = fractions(&path);
        for k in 0..path.len() - 1 {
            let step = (path[k + 1].translation - path[k].translation).norm();
            let shrunk = (se3[k + 1].translation - se3[k].translation).norm();
            assert!((shrunk - step * (-0.5 * f[k]).exp()).abs() < 1e-12);
            assert_eq!(se3[k].scale, 1.0);
            assert!((sim3[k].scale - (-0.5 * f[k]).exp()).abs() < 1e-12);
            let measured = path[k].inverse().compose(&path[k + 1]).translation;
            let own = sim3[k].inverse().compose(&sim3[k + 1]).translation;
            assert!((measured - own).norm() < 1e-12);
        }
    }
}
