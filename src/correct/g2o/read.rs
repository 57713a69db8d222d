//! Reading g2o text into a pose graph: SE(3), Sim(3) and planar SE(2)
//! vertices and edges, each information matrix checked to be one a
//! [`PoseGraph`]'s sigmas can hold.

use super::super::config::Group;
use super::super::graph::{Edge, Loose, PoseGraph, Sigmas};
use crate::geometry::Similarity3;
use crate::{Error, Result};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use std::path::PathBuf;

/// Relative tolerance within which information entries count as equal and
/// off-diagonal ones as zero: the file's own printing, not a modelling one.
const INFO_TOLERANCE: f64 = 1e-9;

/// The pose graph in g2o text `text`.
///
/// Node ids must be 0..n-1 (in any order); node 0 is the one the solver
/// holds, so `FIX` may only name it. Every edge comes back as odometry
/// (`loop_id` None): the format has no slot for a loop's identity, so a
/// graph written by [`super::to_g2o`] reads back with its loop edges as plain edges.
/// A planar graph's out-of-plane sigmas equal its in-plane ones: its start
/// and its measurements lie in the plane, where the out-of-plane residuals
/// are zero and the cost is even in any out-of-plane move, so the solver
/// never leaves the plane and the cost is the planar one whatever that sigma
/// is; equal sigmas keep those directions as well conditioned as the rest.
/// `Sigmas::log_scale` of an SE(3) graph is 1 (unused).
pub fn from_g2o(text: &str) -> Result<PoseGraph> {
    let mut kind: Option<Kind> = None;
    let mut vertices: Vec<(usize, usize, Similarity3)> = Vec::new();
    let mut edges: Vec<(usize, Edge)> = Vec::new();
    let mut fixed: Vec<(usize, usize)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let mut fields = content.split_whitespace();
        let tag = fields.next().unwrap_or_default();
        let rest: Vec<&str> = fields.collect();
        if tag == "FIX" {
            if rest.is_empty() {
                return Err(parse_error(line, "FIX names no node"));
            }
            for f in &rest {
                fixed.push((line, id(f, line)?));
            }
            continue;
        }
        let (this, is_vertex) = Kind::of(tag).ok_or_else(|| {
            parse_error(
                line,
                format!(
                    "unknown record '{}' (expected VERTEX_SE3:QUAT, EDGE_SE3:QUAT, \
                     VERTEX_SIM3:QUAT, EDGE_SIM3:QUAT, VERTEX_SE2, EDGE_SE2 or FIX)",
                    clip(tag)
                ),
            )
        })?;
        match kind {
            None => kind = Some(this),
            Some(k) if k != this => {
                return Err(parse_error(
                    line,
                    format!("{tag} in a graph of {} records", k.name()),
                ))
            }
            _ => {}
        }
        let ids = if is_vertex { 1 } else { 2 };
        let want = ids + this.pose_len() + if is_vertex { 0 } else { this.info_len() };
        if rest.len() != want {
            return Err(parse_error(
                line,
                format!(
                    "{tag} needs {want} fields after the tag, found {}",
                    rest.len()
                ),
            ));
        }
        let a = id(rest[0], line)?;
        let numbers = rest[ids..]
            .iter()
            .enumerate()
            .map(|(k, f)| number(f, ids + k + 2, line))
            .collect::<Result<Vec<f64>>>()?;
        let (pose_numbers, info) = numbers.split_at(this.pose_len());
        let pose = this.pose(pose_numbers).map_err(|m| parse_error(line, m))?;
        if is_vertex {
            vertices.push((line, a, pose));
        } else {
            let b = id(rest[1], line)?;
            if a == b {
                return Err(parse_error(line, format!("edge from node {a} to itself")));
            }
            let sigmas = this.sigmas(info).map_err(|m| parse_error(line, m))?;
            edges.push((
                line,
                Edge {
                    from: a,
                    to: b,
                    from_T_to: pose,
                    sigmas,
                    loop_id: None,
                },
            ));
        }
    }
    let kind = kind.ok_or_else(|| parse_error(text.lines().count().max(1), "no vertices"))?;
    let n = vertices.len();
    let mut poses: Vec<Option<Similarity3>> = vec![None; n];
    for (line, id, pose) in vertices {
        match poses.get_mut(id) {
            None => {
                return Err(parse_error(
                    line,
                    format!("vertex id {id} out of 0..{n}: ids must be 0..n-1"),
                ))
            }
            Some(Some(_)) => return Err(parse_error(line, format!("vertex {id} given twice"))),
            Some(slot) => *slot = Some(pose),
        }
    }
    // n slots filled by n distinct ids below n: every slot is set.
    let poses: Vec<Similarity3> = poses.into_iter().flatten().collect();
    if poses.len() < 2 {
        return Err(parse_error(
            1,
            format!("{} vertex: a pose graph needs 2", poses.len()),
        ));
    }
    for &(line, id) in &fixed {
        if id != 0 {
            return Err(parse_error(
                line,
                format!("FIX {id}: only node 0 can be held (the solver holds node 0)"),
            ));
        }
    }
    let mut out = Vec::with_capacity(edges.len());
    for (line, e) in edges {
        if let Some(bad) = [e.from, e.to].into_iter().find(|&v| v >= n) {
            return Err(parse_error(
                line,
                format!("edge names vertex {bad}, which is not given"),
            ));
        }
        out.push(e);
    }
    if out.is_empty() {
        return Err(parse_error(text.lines().count().max(1), "no edges"));
    }
    Ok(PoseGraph {
        keyframes: (0..n).collect(),
        at_rest: poses.clone(),
        poses,
        edges: out,
        group: if kind == Kind::Sim3 {
            Group::Sim3
        } else {
            Group::Se3
        },
    })
}

/// The record families of a file; one file holds one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Se3,
    Sim3,
    Se2,
}

impl Kind {
    /// The family of `tag` and whether it is a vertex.
    fn of(tag: &str) -> Option<(Kind, bool)> {
        Some(match tag {
            "VERTEX_SE3:QUAT" => (Kind::Se3, true),
            "EDGE_SE3:QUAT" => (Kind::Se3, false),
            "VERTEX_SIM3:QUAT" => (Kind::Sim3, true),
            "EDGE_SIM3:QUAT" => (Kind::Sim3, false),
            "VERTEX_SE2" => (Kind::Se2, true),
            "EDGE_SE2" => (Kind::Se2, false),
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Kind::Se3 => "SE3:QUAT",
            Kind::Sim3 => "SIM3:QUAT",
            Kind::Se2 => "SE2",
        }
    }

    fn pose_len(self) -> usize {
        match self {
            Kind::Se3 => 7,
            Kind::Sim3 => 8,
            Kind::Se2 => 3,
        }
    }

    fn dim(self) -> usize {
        match self {
            Kind::Se3 => 6,
            Kind::Sim3 => 7,
            Kind::Se2 => 3,
        }
    }

    fn info_len(self) -> usize {
        let d = self.dim();
        d * (d + 1) / 2
    }

    fn pose(self, v: &[f64]) -> std::result::Result<Similarity3, String> {
        if self == Kind::Se2 {
            let (s, c) = v[2].sin_cos();
            return Ok(Similarity3 {
                scale: 1.0,
                rotation: Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
                translation: Vector3::new(v[0], v[1], 0.0),
            });
        }
        let q = Quaternion::new(v[6], v[3], v[4], v[5]);
        let norm = q.norm();
        // Printed quaternions are unit to their digits; far from it is no
        // orientation at all.
        if !(norm > 0.5 && norm < 2.0) {
            return Err(format!(
                "quaternion ({} {} {} {}) is not a rotation",
                v[3], v[4], v[5], v[6]
            ));
        }
        let scale = if self == Kind::Sim3 { v[7] } else { 1.0 };
        if scale <= 0.0 {
            return Err(format!("scale {scale} is not positive"));
        }
        Ok(Similarity3 {
            scale,
            rotation: *UnitQuaternion::new_normalize(q)
                .to_rotation_matrix()
                .matrix(),
            translation: Vector3::new(v[0], v[1], v[2]),
        })
    }

    /// The sigmas of an upper-triangle information matrix, or why it has
    /// none.
    fn sigmas(self, upper: &[f64]) -> std::result::Result<Sigmas, String> {
        let d = self.dim();
        let mut m = nalgebra::DMatrix::<f64>::zeros(d, d);
        let mut k = 0;
        for i in 0..d {
            for j in i..d {
                m[(i, j)] = upper[k];
                m[(j, i)] = upper[k];
                k += 1;
            }
        }
        if let Some(bad) = m.diagonal().iter().find(|v| **v <= 0.0) {
            return Err(format!("information diagonal entry {bad} is not positive"));
        }
        let largest = m.diagonal().iter().cloned().fold(0.0, f64::max);
        let tolerance = INFO_TOLERANCE * largest;
        // Only the translation block and the rotation block may couple their
        // own axes (a slide, a roll).
        let nt = if self == Kind::Se2 { 2 } else { 3 };
        let nr = if self == Kind::Se2 { 1 } else { 3 };
        let part = |i: usize| {
            if i < nt {
                0
            } else if i < nt + nr {
                1
            } else {
                2
            }
        };
        let coupled = (0..d)
            .flat_map(|i| (0..d).map(move |j| (i, j)))
            .filter(|&(i, j)| i != j && (part(i) != part(j) || part(i) == 2))
            .map(|(i, j)| m[(i, j)].abs())
            .fold(0.0, f64::max);
        if coupled > tolerance {
            return Err(format!(
                "information has off-diagonal entries (up to {coupled}) between blocks: \
                 the graph's sigmas are one per block"
            ));
        }
        let (translation, loose) = loose_block(&m, 0, nt, 2, "translation")?;
        // The loosest translation axis is the slide along the road, the
        // other the height ([`Sigmas::height`]).
        let (slide, height) = (loose.first().copied(), loose.get(1).copied());
        let (rotation, roll) = loose_block(&m, nt, nr, 1, "rotation")?;
        let roll = roll.first().copied();
        let log_scale = (self == Kind::Sim3).then(|| m[(6, 6)]);
        Ok(Sigmas {
            translation,
            rotation,
            log_scale: log_scale.map_or(1.0, |v| 1.0 / v.sqrt()),
            slide,
            height,
            roll,
        })
    }
}

/// The sigma and loose axes of the `n` rows of an information matrix from
/// row `at` on (one block, `what`): equal information on every axis (no
/// loose axis), or equal on all but at most `most_loose` axes, which have
/// less, loosest first. A planar graph's third translation axis takes the
/// in-plane information across (see [`from_g2o`]).
fn loose_block(
    m: &nalgebra::DMatrix<f64>,
    at: usize,
    n: usize,
    most_loose: usize,
    what: &str,
) -> std::result::Result<(f64, Vec<Loose>), String> {
    // Bounded iterations: entries near f64's range must give an error, not
    // a decomposition that never converges.
    let eig = nalgebra::SymmetricEigen::try_new(m.view((at, at), (n, n)).into_owned(), 1e-15, 1000)
        .ok_or(format!("{what} information has no eigen-decomposition"))?;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let most = eig.eigenvalues[order[n - 1]];
    if eig.eigenvalues[order[0]] <= 0.0 {
        return Err(format!("{what} information is not positive definite"));
    }
    let equal = |v: f64| (v - most).abs() <= 1e3 * INFO_TOLERANCE * most;
    let loose: Vec<Loose> = order
        .iter()
        .filter(|&&k| !equal(eig.eigenvalues[k]))
        .map(|&k| {
            let v = eig.eigenvectors.column(k);
            Loose {
                axis: Vector3::new(v[0], v[1], if n == 3 { v[2] } else { 0.0 }),
                sigma: 1.0 / eig.eigenvalues[k].sqrt(),
            }
        })
        .collect();
    if loose.len() > most_loose {
        return Err(format!(
            "{what} information has eigenvalues {:?}: the graph's {what} sigmas \
             are one on every axis but at most {most_loose}",
            eig.eigenvalues.as_slice()
        ));
    }
    Ok((1.0 / most.sqrt(), loose))
}

fn parse_error(line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        path: PathBuf::from("g2o"),
        line,
        message: message.into(),
    }
}

fn id(field: &str, line: usize) -> Result<usize> {
    field
        .parse::<usize>()
        .map_err(|_| parse_error(line, format!("'{}' is not a node id", clip(field))))
}

fn number(field: &str, column: usize, line: usize) -> Result<f64> {
    match field.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(parse_error(
            line,
            format!("'{}' in field {column} is not a finite number", clip(field)),
        )),
    }
}

/// A field shortened for a one-line message.
fn clip(s: &str) -> String {
    const MAX: usize = 40;
    if s.chars().count() <= MAX {
        s.to_string()
    } else {
        format!("{}...", s.chars().take(MAX).collect::<String>())
    }
}
