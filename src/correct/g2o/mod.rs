//! The pose graph in g2o's text format, so that g2o or GTSAM can optimise
//! the same graph, and g2o files read back as pose graphs, so that turnprint's
//! solver runs on the standard benchmarks.
//!
//! SE(3) graphs use g2o's own `VERTEX_SE3:QUAT id x y z qx qy qz qw` and
//! `EDGE_SE3:QUAT from to x y z qx qy qz qw` followed by the upper triangle
//! of the 6x6 information matrix (translation first), which GTSAM's
//! `readG2o` reads. Sim(3) graphs add the scale after the quaternion
//! (`VERTEX_SIM3:QUAT`, `EDGE_SIM3:QUAT`, a 7x7 upper triangle with ln s
//! last): g2o's own Sim(3) types are written for camera-to-world bundle
//! adjustment in an exponential-map form, so this keeps the quaternion form
//! and says so in its tag. `FIX 0` holds the first node.
//!
//! [`from_g2o`] reads those and the planar `VERTEX_SE2 id x y θ` /
//! `EDGE_SE2 from to x y θ` with its 3x3 upper triangle (x, y, θ), lifted to
//! 3D with z = 0 and the rotation about z. A [`PoseGraph`]'s sigmas are
//! isotropic per block but for a loop edge's slide, height and roll, so the
//! information must be block diagonal, with a translation block equal on
//! every axis but at most two and a rotation block on every axis but at
//! most one (each a [`super::graph::Loose`] axis); anything else is an
//! error, as is any line that is not one of these records. [`cost`] is the objective the solver
//! minimises in the convention g2o and GTSAM report (computed in
//! [`super::solve`]).

use super::config::Group;
use super::graph::PoseGraph;
use crate::geometry::{nearest_rotation, Similarity3};
use nalgebra::UnitQuaternion;
use std::fmt::Write;

mod read;

pub use super::solve::{cost, cost_of};
pub use read::from_g2o;

/// The graph as g2o text (all loops' edges included).
pub fn to_g2o(graph: &PoseGraph) -> String {
    let sim3 = graph.group == Group::Sim3;
    let (vertex, edge) = if sim3 {
        ("VERTEX_SIM3:QUAT", "EDGE_SIM3:QUAT")
    } else {
        ("VERTEX_SE3:QUAT", "EDGE_SE3:QUAT")
    };
    let mut out = String::new();
    for (id, p) in graph.at_rest.iter().enumerate() {
        let _ = writeln!(out, "{vertex} {id} {}", pose(p, sim3));
    }
    for e in &graph.edges {
        let w = e.sigmas.sqrt_information(sim3);
        let full = w.transpose() * &w;
        let mut info = Vec::new();
        for i in 0..full.nrows() {
            for j in i..full.ncols() {
                info.push(full[(i, j)]);
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
    let q = UnitQuaternion::from_rotation_matrix(&nearest_rotation(&p.rotation));
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

#[cfg(test)]
mod tests {
    use super::super::graph::{Edge, Loose, Sigmas};
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    fn pose(angles: (f64, f64, f64), t: [f64; 3], scale: f64) -> Similarity3 {
        Similarity3 {
            scale,
            rotation: *Rotation3::from_euler_angles(angles.0, angles.1, angles.2).matrix(),
            translation: Vector3::from(t),
        }
    }

    /// Four nodes, odometry and one loop edge, in `group`.
    fn graph(group: Group) -> PoseGraph {
        let s = if group == Group::Sim3 { 1.1 } else { 1.0 };
        let poses = vec![
            Similarity3::identity(),
            pose((0.1, -0.05, 0.4), [1.0, 0.2, -0.1], 1.0),
            pose((0.0, 0.2, 1.5), [1.5, 1.4, 0.3], 1.0),
            pose((-0.3, 0.1, 3.0), [0.2, 1.1, 0.1], 1.0),
        ];
        let sigmas = Sigmas {
            translation: 0.05,
            rotation: 0.01,
            log_scale: if group == Group::Sim3 { 0.2 } else { 1.0 },
            slide: None,
            height: None,
            roll: None,
        };
        let mut edges: Vec<Edge> = (0..3)
            .map(|k| Edge {
                from: k,
                to: k + 1,
                from_T_to: poses[k].inverse().compose(&poses[k + 1]),
                sigmas,
                loop_id: None,
            })
            .collect();
        edges.push(Edge {
            from: 3,
            to: 0,
            from_T_to: pose((0.2, -0.1, -2.9), [-0.1, 1.0, 0.0], s),
            sigmas: Sigmas {
                translation: 0.5,
                rotation: 0.1,
                slide: Some(Loose {
                    axis: Vector3::new(0.6, 0.8, 0.0),
                    sigma: 20.0,
                }),
                height: Some(Loose {
                    axis: Vector3::new(0.0, 0.0, 1.0),
                    sigma: 3.0,
                }),
                roll: Some(Loose {
                    axis: Vector3::new(0.0, 0.6, 0.8),
                    sigma: 0.7,
                }),
                ..sigmas
            },
            loop_id: Some(0),
        });
        PoseGraph {
            keyframes: (0..4).collect(),
            at_rest: poses.clone(),
            poses,
            edges,
            group,
        }
    }

    fn close(a: &Similarity3, b: &Similarity3) -> bool {
        (a.translation - b.translation).norm() < 1e-8
            && (a.rotation - b.rotation).norm() < 1e-8
            && (a.scale - b.scale).abs() < 1e-8
    }

    #[test]
    fn to_g2o_then_from_g2o_gives_the_same_graph() {
        for group in [Group::Se3, Group::Sim3] {
            let g = graph(group);
            let back = from_g2o(&to_g2o(&g)).expect("reads its own output");
            assert_eq!(back.group, g.group);
            assert_eq!(back.keyframes, g.keyframes);
            assert_eq!(back.poses.len(), g.poses.len());
            assert!(g.poses.iter().zip(&back.poses).all(|(a, b)| close(a, b)));
            assert_eq!(back.edges.len(), g.edges.len());
            for (a, b) in g.edges.iter().zip(&back.edges) {
                assert_eq!((a.from, a.to), (b.from, b.to));
                assert!(close(&a.from_T_to, &b.from_T_to), "{group:?}");
                let rel = |x: f64, y: f64| (x - y).abs() <= 1e-12 * x;
                assert!(rel(a.sigmas.translation, b.sigmas.translation));
                assert!(rel(a.sigmas.rotation, b.sigmas.rotation));
                if group == Group::Sim3 {
                    assert!(rel(a.sigmas.log_scale, b.sigmas.log_scale));
                }
                for (x, y) in [
                    (a.sigmas.slide, b.sigmas.slide),
                    (a.sigmas.height, b.sigmas.height),
                    (a.sigmas.roll, b.sigmas.roll),
                ] {
                    match (x, y) {
                        (None, None) => {}
                        (Some(x), Some(y)) => {
                            // An eigenvector's sign is free.
                            assert!((x.axis.dot(&y.axis).abs() - 1.0).abs() < 1e-9);
                            assert!((x.sigma - y.sigma).abs() <= 1e-9 * x.sigma);
                        }
                        other => panic!("loose axis lost: {other:?}"),
                    }
                }
                // The format has no loop identity.
                assert_eq!(b.loop_id, None);
            }
            let (c, d) = (cost(&g, &g.poses), cost(&back, &back.poses));
            assert!((c - d).abs() <= 1e-6 * c, "{c} vs {d}");
        }
    }

    #[test]
    fn cost_is_half_the_squared_whitened_residual() {
        let mut g = graph(Group::Se3);
        g.edges.truncate(3);
        assert!(cost(&g, &g.poses) < 1e-20);
        // Node 3 moved by one translation sigma along its own x axis: only
        // the last odometry edge sees it, 1 sigma in translation.
        let mut moved = g.poses.clone();
        moved[3] = moved[3].compose(&pose((0.0, 0.0, 0.0), [0.05, 0.0, 0.0], 1.0));
        assert!(
            (cost(&g, &moved) - 0.5).abs() < 1e-12,
            "{}",
            cost(&g, &moved)
        );
        // A rotation of two rotation sigmas about the node's own z: 0.5 * 2².
        let mut turned = g.poses.clone();
        turned[3] = turned[3].compose(&pose((0.0, 0.0, 0.02), [0.0; 3], 1.0));
        assert!(
            (cost(&g, &turned) - 2.0).abs() < 1e-9,
            "{}",
            cost(&g, &turned)
        );
        assert!(cost(&g, &g.poses[..2]).is_nan());
    }

    /// A loop edge's translation residual along its slide counts in the
    /// slide's sigma, across it in the translation sigma.
    #[test]
    fn a_slide_frees_its_direction_only() {
        let mut g = graph(Group::Se3);
        // The loop measured as the nodes are: no residual to start from.
        g.edges[3].from_T_to = g.poses[3].inverse().compose(&g.poses[0]);
        let e = &g.edges[3];
        let start = cost_of(&g, &g.poses, |x| x.loop_id.is_some());
        assert!(start < 1e-20);
        let moved_by = |offset: Vector3<f64>| {
            let mut poses = g.poses.clone();
            // Node 0 moved by `offset` in its own frame: the loop edge's
            // residual, in node 0's frame, changes by about that.
            poses[0] = poses[0].compose(&pose((0.0, 0.0, 0.0), offset.into(), 1.0));
            cost_of(&g, &poses, |x| x.loop_id.is_some()) - start
        };
        let slide = e.sigmas.slide.unwrap();
        let across = Vector3::new(-0.8, 0.6, 0.0);
        let (along_cost, across_cost) = (moved_by(slide.axis), moved_by(across));
        // 0.5 (1 / 20)² along, 0.5 (1 / 0.5)² across.
        assert!((along_cost - 0.00125).abs() < 1e-9, "{along_cost}");
        assert!((across_cost - 2.0).abs() < 1e-9, "{across_cost}");
    }

    /// A loop edge's rotation residual about its roll's axis counts in the
    /// roll's sigma, about the other axes in the rotation sigma.
    #[test]
    fn a_roll_frees_its_axis_only() {
        let mut g = graph(Group::Se3);
        g.edges[3].from_T_to = g.poses[3].inverse().compose(&g.poses[0]);
        let e = &g.edges[3];
        let start = cost_of(&g, &g.poses, |x| x.loop_id.is_some());
        let turned_by = |axis: Vector3<f64>, angle: f64| {
            let mut poses = g.poses.clone();
            let r = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
            poses[0] = poses[0].compose(&Similarity3 {
                scale: 1.0,
                rotation: *r.matrix(),
                translation: Vector3::zeros(),
            });
            cost_of(&g, &poses, |x| x.loop_id.is_some()) - start
        };
        let roll = e.sigmas.roll.unwrap();
        let (about, across) = (turned_by(roll.axis, 0.07), turned_by(Vector3::x(), 0.07));
        // 0.5 (0.07 / 0.7)² about it, 0.5 (0.07 / 0.1)² across.
        assert!((about - 0.005).abs() < 1e-9, "{about}");
        assert!((across - 0.245).abs() < 1e-9, "{across}");
    }

    #[test]
    fn planar_graphs_are_lifted_about_z() {
        let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 2 1.5707963267948966\n\
                    EDGE_SE2 0 1 1 2 1.5 100 0 0 100 0 400\nFIX 0\n";
        let g = from_g2o(text).expect("reads");
        assert_eq!(g.group, Group::Se3);
        let p = &g.poses[1];
        assert!((p.translation - Vector3::new(1.0, 2.0, 0.0)).norm() < 1e-12);
        assert!((p.rotation * Vector3::x() - Vector3::y()).norm() < 1e-12);
        let e = &g.edges[0];
        assert!((e.sigmas.translation - 0.1).abs() < 1e-12);
        assert!((e.sigmas.rotation - 0.05).abs() < 1e-12);
        // Measured 1.5 rad against π/2 and the translation exactly: the
        // residual is the rotation's alone, in its sigma.
        let dth: f64 = std::f64::consts::FRAC_PI_2 - 1.5;
        let expected = 0.5 * (dth / 0.05).powi(2);
        let c = cost(&g, &g.poses);
        assert!((c - expected).abs() < 1e-9 * expected, "{c} vs {expected}");
    }

    fn error_of(text: &str) -> String {
        match from_g2o(text) {
            Ok(_) => panic!("accepted: {text}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn bad_input_is_a_clear_error_naming_the_line() {
        let v = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n";
        let info = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 4 0 0 4 0 4";
        let edge = |fields: &str| format!("{v}EDGE_SE3:QUAT 0 1 {fields}\n");
        let cases: Vec<(String, &str)> = vec![
            (String::new(), "no vertices"),
            (v.to_string(), "no edges"),
            ("VERTEX_XYZ 0 1 2 3\n".into(), "unknown record"),
            (
                format!("{v}EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1\n"),
                "needs 30 fields after the tag, found 9",
            ),
            (
                edge(&format!("1 0 zero 0 0 0 1 {info}")),
                "not a finite number",
            ),
            (
                edge(&format!("1 0 NaN 0 0 0 1 {info}")),
                "not a finite number",
            ),
            (edge(&format!("1 0 0 0 0 0 0 {info}")), "not a rotation"),
            (
                edge(&format!(
                    "1 0 0 0 0 0 1 {}",
                    info.replacen("1 0 0 0", "1 0 0 0.5", 1)
                )),
                "off-diagonal",
            ),
            (
                edge(&format!(
                    "1 0 0 0 0 0 1 {}",
                    info.replace("4 0 0 4 0 4", "4 0 0 2 0 1")
                )),
                "rotation information has eigenvalues",
            ),
            (
                edge(&format!("1 0 0 0 0 0 1 {}", info.replacen('1', "-1", 1))),
                "not positive",
            ),
            (
                format!("{v}EDGE_SE3:QUAT 0 0 1 0 0 0 0 0 1 {info}\n"),
                "to itself",
            ),
            (
                format!("{v}EDGE_SE3:QUAT 0 5 1 0 0 0 0 0 1 {info}\n"),
                "vertex 5",
            ),
            (
                format!("{v}EDGE_SE3:QUAT -1 1 1 0 0 0 0 0 1 {info}\n"),
                "not a node id",
            ),
            (
                format!("{v}VERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"),
                "given twice",
            ),
            (
                "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 2 1 0 0 0 0 0 1\n".into(),
                "ids must be 0..n-1",
            ),
            (format!("{v}VERTEX_SE2 2 0 0 0\n"), "in a graph of"),
            (
                format!("{}FIX 1\n", edge(&format!("1 0 0 0 0 0 1 {info}"))),
                "only node 0",
            ),
            (
                format!("{}FIX\n", edge(&format!("1 0 0 0 0 0 1 {info}"))),
                "FIX names no node",
            ),
            (
                "VERTEX_SIM3:QUAT 0 0 0 0 0 0 0 1 -1\n".into(),
                "not positive",
            ),
        ];
        for (text, expected) in cases {
            let message = error_of(&text);
            assert!(message.contains(expected), "{text:?}: {message}");
            assert!(message.starts_with("g2o:"), "{message}");
        }
        // A bad line's number is in the message.
        let message = error_of(&edge(&format!("1 0 zero 0 0 0 1 {info}")));
        assert!(message.starts_with("g2o:3:"), "{message}");
    }

    /// Information entries near f64's range are an error, not a hang.
    #[test]
    fn huge_information_is_an_error_or_a_graph() {
        let text = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n\
                    EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1e300 1e300 0 0 0 0 1e-300 0 0 0 0 1e300 \
                    0 0 0 4 0 0 4 0 4\n";
        match from_g2o(text) {
            Ok(g) => {
                let s = g.edges[0].sigmas;
                assert!(s.translation.is_finite() && s.translation > 0.0, "{s:?}");
            }
            Err(e) => assert!(e.to_string().contains("information"), "{e}"),
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        let samples = [
            "EDGE_SE3:QUAT",
            "VERTEX_SE2 0 1e400 0 0",
            "VERTEX_SE2 99999999999999999999999 0 0 0",
            "FIX 0 0 0",
            "\u{feff}VERTEX_SE2 0 0 0 0",
            "VERTEX_SIM3:QUAT 0 0 0 0 0 0 0 1 inf",
        ];
        for s in samples {
            let _ = from_g2o(s);
        }
    }
}
