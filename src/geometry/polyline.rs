//! A 2D polyline with arc length, for nearest-point queries: how far a mapped
//! point of one path is from the other path, and where along it.
//!
//! The index is a parry2d BVH over runs of [`CHUNK`] consecutive segments
//! rather than over single segments: a path is spatially coherent, so a run's
//! box is tight, and building the tree over 8x fewer leaves is what keeps
//! verification cheap (the per-segment build was half of the online
//! detector's time). The tree is built on the first query, so a path that is
//! never a target costs nothing, and short polylines (a few hundred
//! segments) skip it for a flat scan of the leaf boxes.

use std::sync::OnceLock;

use glam::DVec2;
use nalgebra::Vector2;
use parry2d_f64::bounding_volume::Aabb;
use parry2d_f64::partitioning::{Bvh, BvhBuildStrategy};

/// Consecutive segments per BVH leaf.
const CHUNK: usize = 8;
/// Up to this many leaves a flat scan of their boxes beats building and
/// walking a tree (the online detector's verification windows).
const FLAT_LEAVES: usize = 128;

/// A polyline, the arc length at each vertex, and a lazily built BVH.
pub struct Polyline2 {
    vertices: Vec<Vector2<f64>>,
    arc: Vec<f64>,
    bvh: OnceLock<Bvh>,
    leaves: OnceLock<Vec<Aabb>>,
}

/// Nearest point of a [`Polyline2`] to a query point.
#[derive(Debug, Clone, Copy)]
pub struct Projection {
    /// Distance from the query point.
    pub distance: f64,
    /// Arc length of the nearest point along the polyline.
    pub arc: f64,
    /// Fractional vertex index of the nearest point.
    pub vertex: f64,
}

impl Polyline2 {
    /// A polyline through `points` (at least two, all finite).
    pub fn new(points: &[Vector2<f64>]) -> Self {
        let mut arc = Vec::with_capacity(points.len());
        let mut acc = 0.0;
        for (i, p) in points.iter().enumerate() {
            if i > 0 {
                acc += (p - points[i - 1]).norm();
            }
            arc.push(acc);
        }
        Polyline2 {
            vertices: points.to_vec(),
            arc,
            bvh: OnceLock::new(),
            leaves: OnceLock::new(),
        }
    }

    /// Segments `[CHUNK·leaf, CHUNK·(leaf+1))` (segment `i` joins vertices
    /// `i` and `i + 1`).
    fn leaf_segments(&self, leaf: usize) -> std::ops::Range<usize> {
        let n = self.vertices.len().saturating_sub(1);
        (leaf * CHUNK).min(n)..((leaf + 1) * CHUNK).min(n)
    }

    /// The box of each leaf's segments.
    fn leaf_boxes(&self) -> Vec<Aabb> {
        let n = self.vertices.len().saturating_sub(1);
        (0..n.div_ceil(CHUNK))
            .map(|leaf| {
                let r = self.leaf_segments(leaf);
                let (mut lo, mut hi) = (self.vertices[r.start], self.vertices[r.start]);
                for v in &self.vertices[r.start..=r.end] {
                    lo = lo.inf(v);
                    hi = hi.sup(v);
                }
                Aabb::new(DVec2::new(lo.x, lo.y), DVec2::new(hi.x, hi.y))
            })
            .collect()
    }

    fn bvh(&self) -> &Bvh {
        self.bvh.get_or_init(|| {
            let leaves = self.leaves.get_or_init(|| self.leaf_boxes());
            Bvh::from_leaves(BvhBuildStrategy::Binned, leaves)
        })
    }

    /// Nearest point to `p` (the whole polyline searched).
    pub fn project(&self, p: &Vector2<f64>) -> Option<Projection> {
        self.project_within(p, f64::INFINITY, |_| true)
    }

    /// Nearest point to `p` within `max_dist` among the segments whose
    /// nearest point passes `allowed(fractional vertex index)`: a path
    /// matched against itself must not find itself.
    pub fn project_within(
        &self,
        p: &Vector2<f64>,
        max_dist: f64,
        allowed: impl Fn(f64) -> bool,
    ) -> Option<Projection> {
        if self.vertices.len() < 2 {
            return None;
        }
        let r = DVec2::splat(max_dist.min(f64::MAX));
        let q = DVec2::new(p.x, p.y);
        let aabb = Aabb::new(q - r, q + r);
        let leaves = self.leaves.get_or_init(|| self.leaf_boxes());
        // Leaves nearest first, so the scan stops at the first leaf whose box
        // is farther than the best point found.
        let box_dist2 = |leaf: u32| {
            let b = &leaves[leaf as usize];
            let d = (b.mins - q).max(q - b.maxs).max(DVec2::ZERO);
            (d.length_squared(), leaf)
        };
        let mut near: Vec<(f64, u32)> = if leaves.len() <= FLAT_LEAVES {
            (0..leaves.len() as u32)
                .map(box_dist2)
                .filter(|&(d2, _)| d2 <= max_dist * max_dist)
                .collect()
        } else {
            self.bvh().intersect_aabb(&aabb).map(box_dist2).collect()
        };
        near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let max2 = max_dist * max_dist;
        let mut best: Option<(f64, usize, f64)> = None;
        for (box2, leaf) in near {
            if best.is_some_and(|b| b.0 < box2) {
                break;
            }
            for i in self.leaf_segments(leaf as usize) {
                let (a, b) = (self.vertices[i], self.vertices[i + 1]);
                let ab = b - a;
                let len2 = ab.norm_squared();
                let t = if len2 > 0.0 {
                    ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let d2 = (a + ab * t - p).norm_squared();
                if d2 > max2 || best.is_some_and(|b| b.0 <= d2) {
                    continue;
                }
                if !allowed(i as f64 + t) {
                    continue;
                }
                best = Some((d2, i, t));
            }
        }
        best.map(|(d2, i, t)| {
            let (a0, a1) = (self.arc[i], self.arc[i + 1]);
            Projection {
                distance: d2.sqrt(),
                arc: a0 + t * (a1 - a0),
                vertex: i as f64 + t,
            }
        })
    }

    /// Total length.
    pub fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_point_on_a_zigzag_matches_brute_force() {
        let pts: Vec<Vector2<f64>> = (0..203)
            .map(|i| Vector2::new(i as f64, ((i * 7) % 5) as f64))
            .collect();
        let line = Polyline2::new(&pts);
        for k in 0..50 {
            let p = Vector2::new(k as f64 * 4.1 - 3.0, (k % 9) as f64 - 2.0);
            let brute = (0..pts.len() - 1)
                .map(|i| {
                    let (a, b) = (pts[i], pts[i + 1]);
                    let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
                    (a + (b - a) * t - p).norm()
                })
                .fold(f64::INFINITY, f64::min);
            let got = line.project(&p).expect("a nearest point");
            assert!(
                (got.distance - brute).abs() < 1e-12,
                "{k}: {got:?} vs {brute}"
            );
            if brute > 0.0 {
                assert!(line.project_within(&p, brute * 0.99, |_| true).is_none());
            }
        }
    }
}
