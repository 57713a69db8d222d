//! Merging: B brought into A's frame by a hypothesis, appended after A.

use crate::geometry::Similarity3;
use crate::{Hypothesis, Pose, Trajectory};

/// A's poses, then B's poses mapped by `p_A = s R p_B + t` (orientations
/// rotated by `R`), as one trajectory.
pub fn merge(a: &Trajectory, b: &Trajectory, h: &Hypothesis) -> Trajectory {
    let mut poses = a.poses.clone();
    poses.extend(placed(b, &h.similarity()).poses);
    Trajectory {
        source: format!("{} + {}", a.source, b.source),
        poses,
    }
}

/// `path` mapped by `frame_T_path` (`p = s R p_path + t`, orientations
/// rotated by `R`).
pub fn placed(path: &Trajectory, frame_t_path: &Similarity3) -> Trajectory {
    let rotation = nalgebra::UnitQuaternion::from_rotation_matrix(
        &crate::geometry::nearest_rotation(&frame_t_path.rotation),
    );
    Trajectory {
        source: path.source.clone(),
        poses: (path.poses.iter())
            .map(|p| Pose {
                t: p.t,
                position: frame_t_path.apply(&p.position),
                orientation: p.orientation.map(|q| rotation * q),
            })
            .collect(),
    }
}
