//! Settings of drift correction, grouped by stage. Every tolerance is a
//! ratio, a fraction of a length or an angle: none is in metres.

use super::loops::LoopClosure;
use crate::pipeline::Config;

/// Which group the nodes live in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// Decide from the loops: Sim(3) when their median scale, weighted by
    /// score, is off by more than [`Group::SCALE_DRIFT`], else SE(3). A
    /// loop whose shape fixes no scale ([`LoopClosure::scale_shown`]) counts
    /// as scale 1, whatever its fit took: the short arcs and single corners
    /// of a drone's revisits fit at scales 0.67-1.26 and made metric VIO
    /// Sim(3), where its corrections went wrong (EuRoC MH_04 0.17 -> 0.37 m
    /// instead of 0.19 m). The weights keep the many weak look-alikes of a
    /// search, whose scales scatter both ways, from outvoting its few strong
    /// revisits.
    Auto,
    /// Rigid poses: metric odometry (stereo, LiDAR, wheels, VIO).
    Se3,
    /// Poses with a scale: monocular odometry, whose scale drifts.
    Sim3,
}

impl Group {
    /// |ln scale| of the loops' median above which scale is taken to drift.
    /// A metric odometry's revisits fit within about 1 % of scale (KITTI
    /// LiDAR and stereo estimates: median under 0.01); a monocular one's
    /// pass twice through the same road 10-50 % apart.
    pub const SCALE_DRIFT: f64 = 0.05;

    /// Degrees of freedom of a node, and of a relative motion between two:
    /// 7 in Sim(3) (rotation, translation, scale), 6 otherwise.
    pub fn dof(self) -> usize {
        match self {
            Group::Sim3 => 7,
            _ => 6,
        }
    }

    /// The concrete group for these loops.
    pub fn resolve(self, loops: &[LoopClosure]) -> Group {
        match self {
            Group::Auto => {
                let mut s: Vec<(f64, f64)> = loops
                    .iter()
                    .map(|l| {
                        let off = l.query_T_match.scale.ln().abs();
                        (if l.scale_shown { off } else { 0.0 }, l.score.max(0.0))
                    })
                    .collect();
                s.sort_by(|a, b| a.0.total_cmp(&b.0));
                let total: f64 = s.iter().map(|x| x.1).sum();
                let mut acc = 0.0;
                let median = s
                    .iter()
                    .find(|x| {
                        acc += x.1;
                        acc >= 0.5 * total
                    })
                    .map(|x| x.0);
                // With no score at all, the plain median.
                let median = if total > 0.0 {
                    median
                } else {
                    s.get(s.len() / 2).map(|x| x.0)
                };
                if median.is_some_and(|m| m > Self::SCALE_DRIFT) {
                    Group::Sim3
                } else {
                    Group::Se3
                }
            }
            g => g,
        }
    }

    /// Name in reports and g2o files.
    pub fn name(self) -> &'static str {
        match self {
            Group::Auto => "auto",
            Group::Se3 => "SE3",
            Group::Sim3 => "Sim3",
        }
    }
}

impl std::str::FromStr for Group {
    type Err = String;

    /// `auto`, `se3` or `sim3`, in any case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(Group::Auto),
            "se3" => Ok(Group::Se3),
            "sim3" => Ok(Group::Sim3),
            _ => Err(format!("'{s}' is not a group (auto, se3, sim3)")),
        }
    }
}

/// Odometry noise as a random walk over the whole path: an edge of length
/// `d` on a path of length `L` gets variances that sum, over the path, to the
/// totals below, whatever the keyframe spacing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryNoise {
    /// Translation drift over the whole path as a fraction of its length.
    /// 2 %: KITTI's LiDAR and stereo odometry drift 0.5-3 %.
    pub translation: f64,
    /// Heading drift over the whole path (radians). 0.2 rad (11°) against
    /// 2 % of translation: a correction bends the path (heading drift, the
    /// usual cause of lost revisits) before it stretches it.
    pub rotation: f64,
    /// Drift of ln(scale) over the whole path (Sim(3) graphs). 0.5: monocular
    /// estimates drift by tens of percent in scale along a drive.
    pub log_scale: f64,
}

impl Default for OdometryNoise {
    fn default() -> Self {
        OdometryNoise {
            translation: 0.02,
            rotation: 0.2,
            log_scale: 0.5,
        }
    }
}

impl OdometryNoise {
    /// The same noise with every sigma times `k`.
    pub fn scaled(&self, k: f64) -> Self {
        OdometryNoise {
            translation: self.translation * k,
            rotation: self.rotation * k,
            log_scale: self.log_scale * k,
        }
    }

    /// Sigmas of an edge of length `d` on a path of length `length`.
    pub fn sigmas(&self, d: f64, length: f64) -> super::graph::Sigmas {
        super::graph::Sigmas {
            translation: self.translation * (d * length).sqrt(),
            rotation: self.rotation * (d / length).sqrt(),
            log_scale: self.log_scale * (d / length).sqrt(),
            slide: None,
            height: None,
            roll: None,
        }
    }
}

/// Loop noise from the loop's own misfit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopNoise {
    /// Least translation sigma as a fraction of the loop's query length:
    /// a loop fitted exactly (ground truth, one road twice in one lane)
    /// still places its two passes only to about the width of a lane over a
    /// stretch a hundred times as long.
    pub floor: f64,
    /// The floor once the loops are chosen and the odometry's drift is
    /// measured from them, as a fraction of the query length: 0.2 %, the
    /// placement error of an exact fit over curves resampled at a few tenths
    /// of a percent of their length. The wider [`LoopNoise::floor`] only
    /// keeps the choice of loops tolerant; the final solve trusts each loop
    /// as far as its own misfit says.
    pub fit_floor: f64,
    /// Rotation sigma = this times translation sigma over the query length:
    /// a misfit `e` spread along a stretch of length `l` tilts a line fitted
    /// through it by about `e / (l / 4)` (the lever of a uniform spread).
    pub rotation_lever: f64,
    /// Translation sigma along the road, as a fraction of the query length
    /// ([`super::graph::Sigmas::slide`]): 1, the overlap's own length. A fit that
    /// slid further would no longer overlap; within it, only the road's
    /// bends place the two passes along each other.
    pub slide: f64,
}

impl Default for LoopNoise {
    fn default() -> Self {
        LoopNoise {
            floor: 0.01,
            fit_floor: 0.002,
            rotation_lever: 4.0,
            slide: 1.0,
        }
    }
}

impl LoopNoise {
    /// Sigmas of one of `edges` edges of a loop with misfit `rmse` over a
    /// query stretch of length `length`. The loop counts as one measurement,
    /// so each edge's variance is multiplied by the number of edges.
    pub fn sigmas(&self, rmse: f64, length: f64, edges: usize) -> super::graph::Sigmas {
        let t = rmse.max(self.floor * length);
        let share = (edges.max(1) as f64).sqrt();
        super::graph::Sigmas {
            translation: t * share,
            rotation: (self.rotation_lever * t / length).min(1.0) * share,
            log_scale: (self.rotation_lever * t / length).min(1.0) * share,
            slide: None,
            height: None,
            roll: None,
        }
    }

    /// Sigma of the rotation about the axis a loop's points spread least
    /// around ([`super::graph::Sigmas::roll`]): the edge's `rotation` sigma
    /// times `ratio`, the lever arm about the axis they spread most around
    /// over the lever about this one, at most one radian per loop (shared
    /// by its `edges` like the other sigmas), the same bound as the other
    /// axes': beyond it a rotation is no longer small and the edge says
    /// nothing about it.
    pub fn roll(&self, rotation: f64, ratio: f64, edges: usize) -> f64 {
        let share = (edges.max(1) as f64).sqrt();
        (rotation * ratio).min(share).max(rotation)
    }
}

/// Settings of `correct`.
#[derive(Debug, Clone)]
pub struct CorrectConfig {
    // --- loops: the one loop search of `loops` and the online detector.
    /// Loop search settings ([`Config::for_loops`]).
    pub loops: Config,
    // --- graph: 250 nodes and a few per loop, SE(3) or Sim(3) from the loops.
    /// Node group.
    pub group: Group,
    /// Keyframes spread evenly over the path; each loop adds
    /// `edges_per_loop` in each of its ranges, and the other poses follow
    /// their keyframes. 250: the correction may bend the path every 0.4 %
    /// of its length, finer than drift varies between loops (of 118 KITTI
    /// runs, batch and online, all but two correct to the same APE within
    /// 0.1 m with 2000 nodes, those two within 0.5 m), and a solve takes
    /// tens of milliseconds instead of a hundred.
    pub max_nodes: usize,
    /// Edges per loop: 5 spread over its query range tie the two passes
    /// along their length, not at one point.
    pub edges_per_loop: usize,
    /// Pieces the final solve cuts each chosen loop into where they fit
    /// it far better than its one similarity ([`LoopClosure::pieces`]),
    /// each sharing the loop's information; below 2 keeps loops whole. 5,
    /// one for each of a loop's edges ([`CorrectConfig::edges_per_loop`]):
    /// the graph may then follow the drift between the passes wherever an
    /// edge ties them.
    pub loop_pieces: usize,
    /// Take each loop as the rigid motion that lays its poses onto each
    /// other (SE(3) graphs, loops travelled the same way:
    /// [`LoopClosure::rigid`]) instead of the search's similarity, with its
    /// edges free to turn about the axis their points spread least around
    /// ([`super::graph::Sigmas::roll`]: a rigid fit on a straight fixes no
    /// roll). Off by default: on KITTI's drifting LiDAR and stereo
    /// odometry it corrects further (A-LOAM 05 1.97 -> 0.96 m, S-PTAM 00
    /// 2.51 -> 2.26 m), but streamed on ground truth the many short loops'
    /// rigid fits lay the passes' lanes onto each other and bend the path by
    /// up to 1 m (KITTI 02; EVALUATION.md, "Drift correction").
    pub rigid_loops: bool,
    /// Check the measured drift against the loops themselves: each kept
    /// loop is left out in turn, and where the others bring its two passes
    /// closer at a looser odometry (the measured factor times 3), or else
    /// at a stiffer one (over 3) that keeps every loop, the final solve
    /// takes that. The factor is measured from each loop's misses alone,
    /// and misses that are the loops' own (a lane's offset, a flight's
    /// passes a metre apart) look like drift as much as drift does; only
    /// drift that one loop shows is also where the others put it
    /// (EVALUATION.md, "Drift correction"). It costs two or three solves
    /// per kept loop, spread over the cores, so the stream's worker, with
    /// its budget per re-optimisation, does without it.
    pub check_drift: bool,
    /// Measure a drift the same all along the path (a constant turn and
    /// scale growth per unit of path: a gyro's bias, wheels of unequal
    /// radii or a LiDAR's calibration off, a monocular odometry's scale
    /// running away) from the chosen loops, and take it out of the odometry
    /// before the final solve ([`super::bias`]): the random-walk prior
    /// alone corrects only the stretches between a loop's passes. Taken
    /// only where the loops show it beyond chance.
    pub systematic: bool,
    /// Odometry edge noise.
    pub odometry: OdometryNoise,
    /// Loop edge noise.
    pub loop_noise: LoopNoise,
    // --- robustness: a loop that raises the cost beyond a three-sigma χ²
    // bound, or misses by more than 3 of its sigmas after the final solve,
    // is switched off.
    /// The gate in sigmas: 3, the usual three-sigma gate, both for the
    /// rise of the cost a loop brings (the χ² quantile of a normal variable
    /// within 3 sigmas) and for a loop's normalised residual in the final
    /// solve.
    pub reject_above: f64,
    /// Levenberg-Marquardt iterations per solve, at most.
    pub max_iterations: usize,
}

impl Default for CorrectConfig {
    fn default() -> Self {
        CorrectConfig {
            loops: Config::for_loops(),
            group: Group::Auto,
            max_nodes: 250,
            edges_per_loop: 5,
            rigid_loops: false,
            check_drift: true,
            systematic: true,
            loop_pieces: 5,
            odometry: OdometryNoise::default(),
            loop_noise: LoopNoise::default(),
            reject_above: 3.0,
            max_iterations: 50,
        }
    }
}
