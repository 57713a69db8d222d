//! Turn-pair candidates: a second, independent way to propose alignments.
//!
//! The ZNCC search aligns signatures in `K`, where straights have no
//! length, so two look-alike stretches of a city grid can win over the true
//! one when the overlap is short. Here each path is reduced to its turns
//! (runs of one turning direction between straights), each with its signed
//! angle and its apex (the point halfway through its turning). Two
//! consecutive turns of the query matched to two of the target with the
//! same angles fix a similarity exactly (two points); the proposal is kept
//! when the query's other turns land on target turns of the same angle.
//! Everything is in radians and ratios: scale-free.

use nalgebra::Vector2;

use crate::geometry::Similarity2;
use crate::signature::Signature;
use crate::track::Track;

/// One turn of a path.
#[derive(Debug, Clone, Copy)]
pub struct Turn {
    /// Signed turning (radians, left positive).
    pub angle: f64,
    /// Apex position (track frame).
    pub apex: Vector2<f64>,
    /// Apex grid index on the track.
    pub grid: f64,
    /// First and last grid index of the turn.
    pub span: [f64; 2],
}

/// Settings of turn extraction and turn-pair proposals.
#[derive(Debug, Clone, Copy)]
pub struct TurnConfig {
    /// Turns smaller than this (radians) are ignored.
    pub min_angle: f64,
    /// A step of `K` whose arc length exceeds this multiple of the turn's
    /// median step ends the turn (a straight).
    pub straight_ratio: f64,
    /// Two turn angles agree within this ratio or this many radians.
    pub angle_ratio: f64,
    /// Two turn angles agree within this many radians.
    pub angle_abs: f64,
    /// A mapped apex supports a proposal when this close to a target apex,
    /// as a fraction of the proposal's own apex distance.
    pub support_radius: f64,
    /// Proposals kept for geometric verification.
    pub proposals: usize,
}

impl Default for TurnConfig {
    fn default() -> Self {
        TurnConfig {
            min_angle: 30f64.to_radians(),
            straight_ratio: 6.0,
            angle_ratio: 0.3,
            angle_abs: 20f64.to_radians(),
            support_radius: 0.15,
            proposals: 12,
        }
    }
}

/// The turns of a path, in travel order.
pub fn turns(track: &Track, sig: &Signature, config: &TurnConfig) -> Vec<Turn> {
    let n = sig.len();
    let mut out = Vec::new();
    if n < 2 {
        return out;
    }
    let dir = |j: usize| sig.value[j].signum();
    let mut start = 0;
    let mut j = 1;
    while j <= n {
        let end_run = j == n || dir(j) != dir(start) || {
            // A straight: a step much longer than this run's typical step.
            let steps: Vec<f64> = (start + 1..=j).map(|k| sig.s[k] - sig.s[k - 1]).collect();
            let mut sorted = steps.clone();
            sorted.sort_by(f64::total_cmp);
            let median = sorted[sorted.len() / 2].max(f64::MIN_POSITIVE);
            j - start >= 3 && sig.s[j] - sig.s[j - 1] > config.straight_ratio * median
        };
        if end_run {
            let count = j - start;
            let angle = dir(start) * count as f64 * sig.dk;
            if angle.abs() >= config.min_angle {
                let mid = start + count / 2;
                out.push(Turn {
                    angle,
                    apex: track.point_at(sig.grid[mid]),
                    grid: sig.grid[mid],
                    span: [sig.grid[start], sig.grid[j - 1]],
                });
            }
            start = j;
        }
        j += 1;
    }
    out
}

/// A proposal: the query's turns `i0, i1` on the target's `k0, k1`.
#[derive(Debug, Clone, Copy)]
#[allow(non_snake_case)]
pub struct TurnProposal {
    /// Similarity query -> target (query points already mirrored if asked).
    pub a_T_b: Similarity2,
    /// Query seen from the other side of its plane.
    pub mirrored: bool,
    /// Query grid range spanned by the supporting turns.
    pub seed: [usize; 2],
    /// Query turns landing on target turns of the same angle.
    pub support: usize,
}

fn agree(a: f64, b: f64, config: &TurnConfig) -> bool {
    a.signum() == b.signum()
        && ((a - b).abs() <= config.angle_abs
            || (a - b).abs() <= config.angle_ratio * a.abs().max(b.abs()))
}

/// Proposals from pairs of nearby query turns matched to pairs of target
/// turns, both directions of travel and both sides, best supported first.
pub fn propose(target: &[Turn], query: &[Turn], config: &TurnConfig) -> Vec<TurnProposal> {
    let mut out: Vec<TurnProposal> = Vec::new();
    for mirrored in [false, true] {
        let m = if mirrored { -1.0 } else { 1.0 };
        let q: Vec<Turn> = query
            .iter()
            .map(|t| Turn {
                angle: m * t.angle,
                apex: Vector2::new(t.apex.x, m * t.apex.y),
                ..*t
            })
            .collect();
        for i0 in 0..q.len() {
            for i1 in i0 + 1..(i0 + 3).min(q.len()) {
                for k0 in 0..target.len() {
                    for k1 in k0.saturating_sub(2)..(k0 + 3).min(target.len()) {
                        if k1 == k0 {
                            continue;
                        }
                        // Same direction of travel: angles as they are, order kept;
                        // the other direction: order reversed and signs flipped.
                        let reversed = k1 < k0;
                        let s = if reversed { -1.0 } else { 1.0 };
                        if !agree(s * q[i0].angle, target[k0].angle, config)
                            || !agree(s * q[i1].angle, target[k1].angle, config)
                        {
                            continue;
                        }
                        let Some(t) = Similarity2::from_two(
                            &target[k0].apex,
                            &target[k1].apex,
                            &q[i0].apex,
                            &q[i1].apex,
                        ) else {
                            continue;
                        };
                        let radius =
                            config.support_radius * (target[k0].apex - target[k1].apex).norm();
                        // The seed is the pair's own stretch: growing extends it.
                        let (lo, hi) = (q[i0].span[0], q[i1].span[1]);
                        let support = q
                            .iter()
                            .filter(|qt| {
                                let p = t.apply(&qt.apex);
                                target.iter().any(|tt| {
                                    agree(s * qt.angle, tt.angle, config)
                                        && (tt.apex - p).norm() < radius
                                })
                            })
                            .count();
                        out.push(TurnProposal {
                            a_T_b: t,
                            mirrored,
                            seed: [lo.floor().max(0.0) as usize, hi.ceil() as usize],
                            support,
                        });
                    }
                }
            }
        }
    }
    out.sort_by_key(|p| std::cmp::Reverse(p.support));
    // Near-identical proposals are one.
    let mut kept: Vec<TurnProposal> = Vec::new();
    for p in out {
        if kept.len() >= config.proposals {
            break;
        }
        let dup = kept.iter().any(|k| {
            k.mirrored == p.mirrored
                && (k.a_T_b.scale / p.a_T_b.scale).ln().abs() < 0.05
                && (k.a_T_b.angle - p.a_T_b.angle).sin().abs() < 0.05
                && (k.a_T_b.translation - p.a_T_b.translation).norm()
                    < 0.05 * k.a_T_b.scale * 1.0f64.max((k.seed[1] - k.seed[0]) as f64)
        });
        if !dup && p.support >= 2 {
            kept.push(p);
        }
    }
    kept
}
