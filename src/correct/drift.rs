//! How far a path drifts, measured from its loops' misses: the
//! maximum-likelihood factor on the odometry prior that explains them, and
//! each loop's distance from the path under that prior.

use super::config::Group;
use super::graph::{self, PoseGraph};
use crate::geometry::Similarity3;
use nalgebra::Rotation3;

/// Least drift scale searched: at a ten-thousandth of the prior's sigmas
/// the odometry is rigid next to any loop, which is the answer when the
/// loops show no drift beyond their own noise.
const MIN_DRIFT_SCALE: f64 = 1e-4;

/// Maximum-likelihood factor `k` in (0, 1] on the odometry prior's sigmas,
/// from the loops in `active`, and the loops that drift explains.
///
/// Each loop's misses against the uncorrected path are modelled per axis as
/// zero-mean: its translation miss across the road `d` (its edges' mean
/// squared miss on the `a` axes a slide, [`graph::Sigmas::slide`], leaves)
/// with variance `k² (V_t + V_l) / 3 + σ_t²`, and its rotation miss `ρ` on
/// each axis with variance `k² V_r / 3 + σ_r²` (`σ_r` the roll's sigma about
/// its axis, [`graph::Sigmas::roll`]), and in a Sim(3) graph its miss of
/// ln(scale) with variance `k² V_s + σ_s²`, where the loop is right; `σ` are
/// the loop's own sigmas, `V_t`, `V_r` and `V_s` the prior's translation,
/// rotation and scale variances of the odometry chain between its two poses
/// and `V_l` the rotation's lever to the far pose. Where the loop is
/// wrong, its misses are anywhere the prior reaches (`k = 1`), at even odds.
/// `k` maximises the mixture's likelihood `Σ max(ln p_right, ln p_wrong)` on
/// a log grid of tenths of a decade, and a loop more likely wrong than right
/// at it leaves the set: a loop that needs far more drift than the others
/// show (two parallel roads of one shape on a path that does not drift) is
/// turned away, however much drift the prior would allow. `k` is 1 when no
/// loop is active.
pub(super) fn drift_scale(graph: &PoseGraph, active: &[bool]) -> (f64, Vec<bool>) {
    let mut samples: Vec<(usize, Misses)> = Vec::new();
    for (id, _) in active.iter().enumerate().filter(|(_, &a)| a) {
        samples.push((id, misses(graph, &graph.at_rest, id)));
    }
    let mut kept = vec![false; active.len()];
    if samples.is_empty() {
        return (1.0, kept);
    }
    let (k, _) = most_likely(samples.iter().map(|(_, m)| m));
    for (id, m) in &samples {
        kept[*id] = m.ln_p(k) >= m.ln_p(1.0);
    }
    (k, kept)
}

/// The factor `k` that maximises the likelihood of the loops' `misses`,
/// all of them right, and that likelihood.
pub(super) fn most_likely_right<'a>(
    misses: impl Iterator<Item = &'a Misses> + Clone,
) -> (f64, f64) {
    grid_max(|k| misses.clone().map(|m| m.ln_p(k)).sum())
}

/// The factor on the log grid of [`drift_scale`] that maximises
/// `log_likelihood`, and its value.
fn grid_max(log_likelihood: impl Fn(f64) -> f64) -> (f64, f64) {
    let steps = (MIN_DRIFT_SCALE.log10().abs() * 10.0).round() as i32;
    (0..=steps)
        .map(|i| {
            let k = 10f64.powf(-(i as f64) / 10.0);
            (k, log_likelihood(k))
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((1.0, 0.0))
}

/// The factor `k` that maximises the likelihood of the loops' `misses`,
/// each right or anywhere the prior reaches ([`drift_scale`]), and that
/// likelihood.
fn most_likely<'a>(misses: impl Iterator<Item = &'a Misses> + Clone) -> (f64, f64) {
    grid_max(|k| misses.clone().map(|m| m.ln_p(k).max(m.ln_p(1.0))).sum())
}

/// The misses of loop `id`'s edges at `solution` and the variances the
/// prior's odometry chain between its passes and its own noise give them
/// ([`drift_scale`]).
pub(super) fn misses(graph: &PoseGraph, solution: &[Similarity3], id: usize) -> Misses {
    chain(graph, id).at(graph, solution, id)
}

/// The variances the prior's odometry chain between loop `id`'s passes
/// gives its misses, with no miss yet ([`Misses::at`]): they do not depend
/// on where the nodes lie.
pub(super) fn chain(graph: &PoseGraph, id: usize) -> Misses {
    let sim3 = graph.group == Group::Sim3;
    let edges: Vec<&graph::Edge> = graph.loop_edges(id).collect();
    let n = edges.len().max(1) as f64;
    let mut m = Misses {
        sim3,
        ..Misses::default()
    };
    for e in &edges {
        let far = graph.poses[e.to].translation;
        let (a, b) = (e.from.min(e.to), e.from.max(e.to));
        for o in &graph.edges[a..b] {
            let lever = (far - graph.poses[o.from].translation).norm_squared();
            m.chain_translation += 3.0 * o.sigmas.translation.powi(2) / n;
            m.chain_lever += 2.0 * o.sigmas.rotation.powi(2) * lever / n;
            m.chain_rotation += 3.0 * o.sigmas.rotation.powi(2) / n;
            if sim3 {
                m.chain_scale += o.sigmas.log_scale.powi(2) / n;
            }
        }
    }
    m
}

/// One loop's misses at a solution and the variances that
/// explain them ([`drift_scale`]).
#[derive(Debug, Default)]
pub(super) struct Misses {
    /// Mean squared translation miss across the road.
    translation: f64,
    /// Axes it is measured on.
    axes: f64,
    /// Mean squared rotation miss (radians²) off the roll's axis (3 axes,
    /// 2 where the edges have a roll), and about it.
    rotation: f64,
    roll: f64,
    /// The loop's own translation and rotation variances, per axis, and
    /// what the roll's axis adds to the rotation's.
    own_translation: f64,
    own_rotation: f64,
    own_roll: f64,
    /// The prior's chain variances (summed over 3 axes): translation, the
    /// rotation's lever, rotation.
    chain_translation: f64,
    chain_lever: f64,
    chain_rotation: f64,
    /// In a Sim(3) graph: the squared miss of ln(scale), the loop's own
    /// variance of it and the prior's over the chain.
    sim3: bool,
    scale: f64,
    own_scale: f64,
    chain_scale: f64,
}

impl Misses {
    /// These chain variances (from [`chain`]) with loop `id`'s misses at
    /// `solution` and its own variances.
    pub(super) fn at(&self, graph: &PoseGraph, solution: &[Similarity3], id: usize) -> Misses {
        let sim3 = self.sim3;
        let edges: Vec<&graph::Edge> = graph.loop_edges(id).collect();
        let n = edges.len().max(1) as f64;
        let mut m = Misses {
            sim3,
            chain_translation: self.chain_translation,
            chain_lever: self.chain_lever,
            chain_rotation: self.chain_rotation,
            chain_scale: self.chain_scale,
            ..Misses::default()
        };
        for e in &edges {
            let (r, w) = miss(solution, e);
            // Misses along a loose axis (a slide, a height) are the loop's own
            // freedom, not drift.
            let (mut across, mut a) = (r, 3.0);
            for l in [e.sigmas.slide, e.sigmas.height].iter().flatten() {
                across -= l.axis * l.axis.dot(&across);
                a -= 1.0;
            }
            m.translation += across.norm_squared() / n;
            m.axes += a / n;
            // The loop's own variance: its edges share one measurement.
            m.own_translation += e.sigmas.translation.powi(2) / (n * n);
            let (turn, roll) = match e.sigmas.roll {
                Some(roll) => (w - roll.axis * roll.axis.dot(&w), roll.axis.dot(&w)),
                None => (w, 0.0),
            };
            m.rotation += turn.norm_squared() / n;
            m.roll += roll * roll / n;
            m.own_rotation += e.sigmas.rotation.powi(2) / (n * n);
            m.own_roll += e
                .sigmas
                .roll
                .map_or(0.0, |r| r.sigma.powi(2) - e.sigmas.rotation.powi(2))
                / (n * n);
            if sim3 {
                let predicted = solution[e.from].scale * e.from_T_to.scale;
                m.scale += (predicted / solution[e.to].scale).ln().powi(2) / n;
                m.own_scale += e.sigmas.log_scale.powi(2) / (n * n);
            }
        }
        m
    }

    /// Log-likelihood of the misses with the prior's sigmas times `k`.
    pub(super) fn ln_p(&self, k: f64) -> f64 {
        let v = self.variances(k);
        -0.5 * (self.axes * v.translation.ln() + 2.0 * v.rotation.ln() + v.roll.ln())
            - 0.5 * self.chi2(k)
            - if self.sim3 { 0.5 * v.scale.ln() } else { 0.0 }
    }

    /// The squared misses in their variances with the prior's sigmas times
    /// `k`: the loop's Mahalanobis distance from the path.
    pub(super) fn chi2(&self, k: f64) -> f64 {
        let v = self.variances(k);
        self.translation / v.translation
            + self.rotation / v.rotation
            + self.roll / v.roll
            + if self.sim3 { self.scale / v.scale } else { 0.0 }
    }

    /// Per-axis variances of the misses with the prior's sigmas times `k`.
    fn variances(&self, k: f64) -> MissVariances {
        let translation =
            k * k * (self.chain_translation + self.chain_lever) / 3.0 + self.own_translation;
        let rotation = k * k * self.chain_rotation / 3.0 + self.own_rotation;
        MissVariances {
            translation,
            rotation,
            // Without a roll its axis is one of the others: its term then
            // adds the third axis's share at the same variance.
            roll: rotation + self.own_roll,
            scale: k * k * self.chain_scale + self.own_scale,
        }
    }
}

/// [`Misses::variances`].
struct MissVariances {
    translation: f64,
    rotation: f64,
    roll: f64,
    scale: f64,
}

/// The misses of loop edge `e` at `solution`, in the frame of its `to`
/// node (the frame of its residual, its slide and its roll): translation,
/// in that node's units, and rotation, as a rotation vector.
pub(super) fn miss(
    solution: &[Similarity3],
    e: &graph::Edge,
) -> (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>) {
    let predicted = solution[e.from].compose(&e.from_T_to);
    let actual = &solution[e.to];
    (
        actual.rotation.transpose() * (predicted.translation - actual.translation) / actual.scale,
        Rotation3::from_matrix_unchecked(actual.rotation.transpose() * predicted.rotation)
            .scaled_axis(),
    )
}
