//! A 2D polyline with arc length, for nearest-point queries: how far a mapped
//! point of one path is from the other path, and where along it.

use glam::DVec2;
use nalgebra::Vector2;
use parry2d_f64::bounding_volume::Aabb;
use parry2d_f64::query::PointQueryWithLocation;
use parry2d_f64::shape::{Polyline, SegmentPointLocation};

/// A polyline (parry2d, with its BVH) and the arc length at each vertex.
pub struct Polyline2 {
    shape: Polyline,
    arc: Vec<f64>,
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
        let vertices: Vec<DVec2> = points.iter().map(|p| DVec2::new(p.x, p.y)).collect();
        let mut arc = Vec::with_capacity(points.len());
        let mut acc = 0.0;
        for (i, p) in points.iter().enumerate() {
            if i > 0 {
                acc += (p - points[i - 1]).norm();
            }
            arc.push(acc);
        }
        Polyline2 {
            shape: Polyline::new(vertices, None),
            arc,
        }
    }

    /// Nearest point to `p`.
    pub fn project(&self, p: &Vector2<f64>) -> Projection {
        let q = DVec2::new(p.x, p.y);
        let (proj, (seg, loc)) = self.shape.project_local_point_and_get_location(q, false);
        let seg = seg as usize;
        let [i0, i1] = self.shape.indices()[seg.min(self.shape.indices().len() - 1)];
        let (i0, i1) = (i0 as usize, i1 as usize);
        let v = match loc {
            SegmentPointLocation::OnVertex(0) => 0.0,
            SegmentPointLocation::OnVertex(_) => 1.0,
            SegmentPointLocation::OnEdge([_, v]) => v,
        };
        Projection {
            distance: (proj.point - q).length(),
            arc: self.arc[i0] + v * (self.arc[i1] - self.arc[i0]),
            vertex: i0 as f64 + v * (i1 as f64 - i0 as f64),
        }
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
        let q = DVec2::new(p.x, p.y);
        let r = DVec2::splat(max_dist);
        let aabb = Aabb::new(q - r, q + r);
        let vertices = self.shape.vertices();
        let mut best: Option<Projection> = None;
        for seg in self.shape.bvh().intersect_aabb(&aabb) {
            let [i0, i1] = self.shape.indices()[seg as usize];
            let (a, b) = (vertices[i0 as usize], vertices[i1 as usize]);
            let ab = b - a;
            let len2 = ab.length_squared();
            let t = if len2 > 0.0 {
                ((q - a).dot(ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let distance = (a + ab * t - q).length();
            if distance > max_dist || best.is_some_and(|b| b.distance <= distance) {
                continue;
            }
            let vertex = i0 as f64 + t * (i1 as f64 - i0 as f64);
            if !allowed(vertex) {
                continue;
            }
            let (a0, a1) = (self.arc[i0 as usize], self.arc[i1 as usize]);
            best = Some(Projection {
                distance,
                arc: a0 + t * (a1 - a0),
                vertex,
            });
        }
        best
    }

    /// Total length.
    pub fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }
}
