//! The measured drift checked by the loops themselves
//! (`CorrectConfig::check_drift`): each kept loop is left out in turn and
//! the others predict where its two passes lie, at the measured odometry
//! and at a looser and a stiffer one. Drift that one loop shows is also
//! where the others put it; misses that are a loop's own (a lane's offset,
//! a flight's passes a metre apart) are not. A looser odometry brings the
//! left-out passes closer where the path drifts more than the misses alone
//! said, a stiffer one where the misses were the loops' own and the
//! measured drift bent the path to fit them.

use super::graph::PoseGraph;
use super::{carry, pieces_of, solve, LoopClosure};
use crate::geometry::Similarity3;
use crate::trajectory::Trajectory;
use crate::Result;
use nalgebra::Vector3;

/// The factor on the measured odometry noise the check tries either way:
/// half a decade, the measured factor's own uncertainty from a handful of
/// loops (measured factors of one estimate vary 2-5x with the loops
/// chosen). A full decade looser went too far on KITTI (MULLS 00 1.39 ->
/// 1.60 m, GICP 02 20.0 -> 24.3 m).
const STEP: f64 = 3.0;

/// How much closer, in sum, the left-out loops' passes must come at
/// another odometry than at the measured one: 2 %, past the few
/// centimetres a re-solved path moves by where nothing changed.
const SHOWN: f64 = 0.98;

/// A graph, the loop pieces its solve keeps, and its nodes.
pub(super) type Solved = (PoseGraph, Vec<bool>, Vec<Similarity3>);

/// The final solve's result, to leave loops out of.
pub(super) struct Check<'a> {
    /// The path corrected, carried along by each left-out solve.
    pub path: &'a Trajectory,
    /// The final solve's nodes, where each left-out solve starts.
    pub solution: &'a [Similarity3],
    /// The loop pieces kept by the final solve.
    pub active: &'a [bool],
    /// The loop each piece is of.
    pub owner: &'a [usize],
    /// Each loop whole, whose passes are measured.
    pub levelled: &'a [LoopClosure],
    /// Iterations of each left-out solve.
    pub max_iterations: usize,
}

impl Check<'_> {
    /// The final solve checked: `None` where the graph at the measured
    /// factor `k`, `graph`, stands, or the graph at another factor
    /// (`at(factor)`) and its solution (`settle(graph)`, from the final
    /// one and the loops it kept) where the left-out loops say so.
    pub fn checked(
        &self,
        graph: &PoseGraph,
        k: f64,
        at: impl Fn(f64) -> Result<PoseGraph>,
        settle: impl Fn(&PoseGraph) -> Result<(Vec<bool>, Vec<Similarity3>)>,
    ) -> Result<Option<Solved>> {
        let ids: Vec<usize> = (0..self.levelled.len())
            .filter(|&id| pieces_of(self.owner, id).iter().any(|&p| self.active[p]))
            .collect();
        if ids.len() < 2 {
            return Ok(None);
        }
        let measured = self.apart_sum(graph, &ids)?;
        // More drift than measured is asked first, then less: where the
        // left-out loops come closer either way, the looser odometry has
        // them agree on drift, which is what loops are for; the stiffer one
        // only says that their misses are their own.
        if k < 1.0 {
            let looser = at(k * STEP)?;
            if self.closer(&looser, &ids, measured)? {
                let (active, solution) = settle(&looser)?;
                return Ok(Some((looser, active, solution)));
            }
        }
        let stiffer = at(k / STEP)?;
        if self.closer(&stiffer, &ids, measured)? {
            let (active, solution) = settle(&stiffer)?;
            // A stiffer odometry claims the loops' misses are their own:
            // where it turns some of them away, they are not.
            if active == self.active {
                return Ok(Some((stiffer, active, solution)));
            }
        }
        Ok(None)
    }

    /// The sum over the loops `ids`, each left out of `graph` in turn, of
    /// how far apart the others put its passes ([`LoopClosure::apart`]).
    fn apart_sum(&self, graph: &PoseGraph, ids: &[usize]) -> Result<f64> {
        // Every left-out solve is independent: spread over the cores. Each
        // costs its set-up more than its iterations, so a lower cap than
        // the configured one would save little.
        let distances = crate::parallel::map(ids, |&id| {
            let mut without = self.active.to_vec();
            for p in pieces_of(self.owner, id) {
                without[p] = false;
            }
            let solved = solve::optimise(graph, self.solution, &without, self.max_iterations);
            Some(solved.map(|s| {
                let carried: Vec<Vector3<f64>> = carry(self.path, graph, &s)
                    .iter()
                    .map(|p| p.position)
                    .collect();
                self.levelled[id].apart(&carried)
            }))
        });
        distances.into_iter().sum()
    }

    /// Whether `graph` brings the left-out passes closer than the sum
    /// `measured` (at the measured odometry) by [`SHOWN`].
    fn closer(&self, graph: &PoseGraph, ids: &[usize], measured: f64) -> Result<bool> {
        Ok(self.apart_sum(graph, ids)? < SHOWN * measured)
    }
}
