//! A trajectory as read from a file: poses in file order, positions in the
//! file's own (unknown) frame and scale.

use nalgebra::{UnitQuaternion, Vector3};

/// One pose: position, optional timestamp (seconds) and orientation.
#[derive(Debug, Clone, PartialEq)]
pub struct Pose {
    /// Timestamp in seconds, when the format has one.
    pub t: Option<f64>,
    /// Position in the trajectory's frame.
    pub position: Vector3<f64>,
    /// Orientation (world_R_body), when the format has one.
    pub orientation: Option<UnitQuaternion<f64>>,
}

impl Pose {
    /// A pose with a position only.
    pub fn at(position: Vector3<f64>) -> Self {
        Pose {
            t: None,
            position,
            orientation: None,
        }
    }
}

/// Poses in file order; a pose index is a position in `poses`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// Where the poses came from (a file path or a name), for messages.
    pub source: String,
    /// The poses, in file order.
    pub poses: Vec<Pose>,
}

impl Trajectory {
    /// A trajectory from bare positions.
    pub fn from_positions(source: impl Into<String>, positions: &[Vector3<f64>]) -> Self {
        Trajectory {
            source: source.into(),
            poses: positions.iter().map(|p| Pose::at(*p)).collect(),
        }
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// True when there are no poses.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The positions, in order.
    pub fn positions(&self) -> Vec<Vector3<f64>> {
        self.poses.iter().map(|p| p.position).collect()
    }
}
