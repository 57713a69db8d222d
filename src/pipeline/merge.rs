//! Merging: B brought into A's frame by a hypothesis, appended after A.

use crate::{Hypothesis, Pose, Trajectory};

/// A's poses, then B's poses mapped by `p_A = s R p_B + t` (orientations
/// rotated by `R`), as one trajectory.
pub fn merge(a: &Trajectory, b: &Trajectory, h: &Hypothesis) -> Trajectory {
    let rotation = nalgebra::UnitQuaternion::from_rotation_matrix(
        &crate::geometry::nearest_rotation(&h.rotation),
    );
    let mut poses = a.poses.clone();
    poses.extend(b.poses.iter().map(|p| Pose {
        t: p.t,
        position: h.transform(&p.position),
        orientation: p.orientation.map(|q| rotation * q),
    }));
    Trajectory {
        source: format!("{} + {}", a.source, b.source),
        poses,
    }
}
