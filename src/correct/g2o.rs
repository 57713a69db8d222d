//! The pose graph in g2o's text format, so that g2o or GTSAM can optimise
//! the same graph.
//!
//! SE(3) graphs use g2o's own `VERTEX_SE3:QUAT id x y z qx qy qz qw` and
//! `EDGE_SE3:QUAT from to x y z qx qy qz qw` followed by the upper triangle
//! of the 6x6 information matrix (translation first), which GTSAM's
//! `readG2o` reads. Sim(3) graphs add the scale after the quaternion
//! (`VERTEX_SIM3:QUAT`, `EDGE_SIM3:QUAT`, a 7x7 upper triangle with ln s
//! last): g2o's own Sim(3) types are written for camera-to-world bundle
//! adjustment in an exponential-map form, so this keeps the quaternion form
//! and says so in its tag. `FIX 0` holds the first node.

use super::config::Group;
use super::graph::PoseGraph;
use crate::geometry::Similarity3;
use nalgebra::{Rotation3, UnitQuaternion};
use std::fmt::Write;

/// The graph as g2o text (all loops' edges included).
pub fn to_g2o(graph: &PoseGraph) -> String {
    let sim3 = graph.group == Group::Sim3;
    let (vertex, edge) = if sim3 {
        ("VERTEX_SIM3:QUAT", "EDGE_SIM3:QUAT")
    } else {
        ("VERTEX_SE3:QUAT", "EDGE_SE3:QUAT")
    };
    let mut out = String::new();
    for (id, p) in graph.poses.iter().enumerate() {
        let _ = writeln!(out, "{vertex} {id} {}", pose(p, sim3));
    }
    for e in &graph.edges {
        let s = e.sigmas;
        let mut diag = vec![s.translation; 3];
        diag.extend([s.rotation; 3]);
        if sim3 {
            diag.push(s.log_scale);
        }
        let mut info = Vec::new();
        for i in 0..diag.len() {
            for j in i..diag.len() {
                info.push(if i == j {
                    1.0 / (diag[i] * diag[i])
                } else {
                    0.0
                });
            }
        }
        let info: Vec<String> = info.iter().map(|v| format!("{v:e}")).collect();
        let _ = writeln!(
            out,
            "{edge} {} {} {} {}",
            e.from,
            e.to,
            pose(&e.from_T_to, sim3),
            info.join(" ")
        );
    }
    out.push_str("FIX 0\n");
    out
}

fn pose(p: &Similarity3, with_scale: bool) -> String {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&p.rotation));
    let t = p.translation;
    let mut s = format!(
        "{:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
        t.x, t.y, t.z, q.i, q.j, q.k, q.w
    );
    if with_scale {
        let _ = write!(s, " {:.9}", p.scale);
    }
    s
}
