//! One path through the stages up to its segments: plane, track, signature,
//! boundaries, and the polyline index used by alignment.

use nalgebra::{Vector2, Vector3};

use super::Config;
use crate::geometry::{Plane, Polyline2};
use crate::segments::boundaries;
use crate::signature::Signature;
use crate::track::{ChordParam, Smoother, Track};
use crate::{Error, Result, Trajectory};

/// Fewest poses the method can work with.
pub const MIN_POSES: usize = 4;

/// A path ready for matching.
pub struct PreparedPath {
    /// Best-fit plane (3D <-> 2D).
    pub plane: Plane,
    /// Smoothed track on a uniform grid.
    pub track: Track,
    /// Curvature on the uniform K grid.
    pub signature: Signature,
    /// Segment boundaries (signature samples).
    pub bounds: Vec<usize>,
    /// The track as a polyline for nearest-point queries.
    pub polyline: Polyline2,
    /// Number of poses in the input.
    pub poses: usize,
    /// The input positions: their heights above the plane (which the 2D
    /// stages drop) lift overlaps to 3D, and `match` polishes on them.
    pub positions: Vec<Vector3<f64>>,
}

impl PreparedPath {
    /// Runs plane fit, track, signature and segmentation.
    pub fn new(trajectory: &Trajectory, config: &Config) -> Result<PreparedPath> {
        let name = &trajectory.source;
        let n = trajectory.len();
        if n < MIN_POSES {
            return Err(Error::input(
                name,
                format!("{n} poses; the method needs at least {MIN_POSES}"),
            ));
        }
        if let Some(i) = trajectory
            .poses
            .iter()
            .position(|p| !p.position.iter().all(|v| v.is_finite()))
        {
            return Err(Error::input(
                name,
                format!("pose {i} has a non-finite position"),
            ));
        }
        let positions = trajectory.positions();
        let plane = Plane::fit(&positions);
        let track = Track::build(&plane_points(&plane, &positions)).ok_or_else(|| {
            Error::input(
                name,
                "the path does not move (fewer than 3 distinct positions)",
            )
        })?;
        Ok(Self::from_track(plane, track, positions, config))
    }

    /// The same path smoothed with `bandwidth` (units of the path) instead
    /// of the bandwidth chosen from its poses: its plane and poses kept.
    pub fn smoothed_with(&self, bandwidth: f64, config: &Config) -> Option<PreparedPath> {
        let chord = ChordParam::new(&plane_points(&self.plane, &self.positions))?;
        let track = Track::from_smoother(&chord, &Smoother { bandwidth });
        Some(Self::from_track(
            self.plane,
            track,
            self.positions.clone(),
            config,
        ))
    }

    /// Signature, segments and polyline of a track.
    fn from_track(
        plane: Plane,
        track: Track,
        positions: Vec<Vector3<f64>>,
        config: &Config,
    ) -> PreparedPath {
        let signature = Signature::build(&track, &config.signature);
        let bounds = boundaries(&signature, &config.segments);
        let polyline = Polyline2::new(&track.xy);
        PreparedPath {
            plane,
            track,
            signature,
            bounds,
            polyline,
            poses: positions.len(),
            positions,
        }
    }

    /// 3D position of a fractional grid index: the smoothed track in the
    /// plane, at the height of the poses there.
    pub fn point3_at(&self, grid: f64) -> Vector3<f64> {
        let xy = self.track.point_at(grid);
        let height = self.height_at(Track::interp(&self.track.pose, grid));
        self.plane.origin + self.plane.world_R_plane * Vector3::new(xy.x, xy.y, height)
    }

    /// Height above the plane at a fractional pose index (0 without the
    /// input positions, as in the online history's windows).
    fn height_at(&self, pose: f64) -> f64 {
        let n = self.positions.len();
        if n == 0 {
            return 0.0;
        }
        let i = (pose.max(0.0).floor() as usize).min(n - 1);
        let f = (pose - i as f64).clamp(0.0, 1.0);
        let p = self.positions[i] + f * (self.positions[(i + 1).min(n - 1)] - self.positions[i]);
        self.plane.local(&p).z
    }

    /// The track's points, mirrored (`y -> -y`) when asked: the path seen
    /// from the other side of its plane.
    pub fn points(&self, mirrored: bool) -> Vec<Vector2<f64>> {
        if mirrored {
            self.track
                .xy
                .iter()
                .map(|p| Vector2::new(p.x, -p.y))
                .collect()
        } else {
            self.track.xy.clone()
        }
    }

    /// The plane matching [`PreparedPath::points`].
    pub fn plane(&self, mirrored: bool) -> crate::geometry::Plane {
        if mirrored {
            self.plane.mirrored()
        } else {
            self.plane
        }
    }

    /// Nearest pose index of a fractional grid index.
    pub fn pose_of_grid(&self, grid: f64) -> usize {
        let p = Track::interp(&self.track.pose, grid).round();
        (p.max(0.0) as usize).min(self.poses - 1)
    }

    /// Turning (radians of K) between two grid indices.
    pub fn turning_between(&self, g0: f64, g1: f64) -> f64 {
        let g = &self.signature.grid;
        let i0 = g.partition_point(|&x| x < g0.min(g1));
        let i1 = g.partition_point(|&x| x <= g0.max(g1));
        i1.saturating_sub(i0) as f64 * self.signature.dk
    }
}

/// The positions in the plane's 2D coordinates.
fn plane_points(plane: &Plane, positions: &[Vector3<f64>]) -> Vec<Vector2<f64>> {
    positions.iter().map(|p| plane.to_2d(p)).collect()
}
