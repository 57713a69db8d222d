//! A street world built along a real trajectory: facade panels on both sides
//! of the road and a ground, in KITTI's camera frame (x right, y down,
//! z forward; the ground is the x-z plane, heights grow towards -y).
//!
//! The world is flat: the ground is the plane `y = camera_height` and the
//! trajectory's own heights are ignored, so that the world is one static
//! scene whatever pose renders it (render poses with [`on_road`] to put the
//! camera at its height above that ground).
//!
//! The road is the trajectory resampled by arc length. For each new stretch
//! of road, two vertical panels stand at a lateral offset. A revisited stretch
//! adds no panels (the first visit built them), and panels that would stand on
//! any road (crossings, tight turns) are dropped, so every place is built once
//! and a revisit sees exactly the same facades.

use nalgebra::{Vector2, Vector3};

use super::texture::{hash2, mix, unit};

/// Layout of the street world (metres: the test world, not the method).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldParams {
    /// Road sample spacing along the trajectory (panel length).
    pub road_step: f64,
    /// Distance from the road centreline to the facades.
    pub facade_offset: f64,
    /// Panels closer than this to any road sample are dropped.
    pub keep_out: f64,
    /// A road sample this close to an earlier stretch is a revisit and builds nothing.
    pub revisit_radius: f64,
    /// Camera height above the ground.
    pub camera_height: f64,
    /// Panels per building (buildings share one facade style and height).
    pub panels_per_building: usize,
    /// Probability that a building is replaced by a gap.
    pub gap_probability: f64,
    /// Seed of all textures and layout choices.
    pub seed: u64,
}

impl Default for WorldParams {
    fn default() -> Self {
        WorldParams {
            road_step: 4.0,
            facade_offset: 9.0,
            keep_out: 7.0,
            revisit_radius: 8.0,
            camera_height: 1.65,
            panels_per_building: 4,
            gap_probability: 0.12,
            seed: 0x7E57_0F1E_1D00,
        }
    }
}

/// One vertical facade panel, a segment in the x-z plane extruded upwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Panel {
    /// Start point (x, z).
    pub a: Vector2<f64>,
    /// End point (x, z).
    pub b: Vector2<f64>,
    /// y of the ground at the panel (y down).
    pub base_y: f64,
    /// Height above the ground.
    pub height: f64,
    /// Texture coordinate (metres along the facade) at `a`.
    pub s0: f64,
    /// Seed of the building's facade style.
    pub style: u64,
    /// Brightness factor from the panel's orientation to the light.
    pub light: f64,
}

/// Uniform grid over the x-z plane holding indices of items per cell.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Minimum (x, z) corner.
    pub origin: Vector2<f64>,
    /// Cell side.
    pub cell: f64,
    /// Cells along x and z.
    pub dims: (usize, usize),
    /// Item indices per cell, row-major in z.
    pub cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(min: Vector2<f64>, max: Vector2<f64>, cell: f64) -> Self {
        let nx = (((max.x - min.x) / cell).ceil() as usize).max(1);
        let nz = (((max.y - min.y) / cell).ceil() as usize).max(1);
        Grid {
            origin: min,
            cell,
            dims: (nx, nz),
            cells: vec![Vec::new(); nx * nz],
        }
    }

    /// Cell coordinates of a point (may be outside the grid).
    pub fn cell_of(&self, p: &Vector2<f64>) -> (i64, i64) {
        (
            ((p.x - self.origin.x) / self.cell).floor() as i64,
            ((p.y - self.origin.y) / self.cell).floor() as i64,
        )
    }

    /// Items of cell `(i, j)`, empty outside the grid.
    pub fn items(&self, i: i64, j: i64) -> &[u32] {
        if i < 0 || j < 0 || i >= self.dims.0 as i64 || j >= self.dims.1 as i64 {
            return &[];
        }
        &self.cells[j as usize * self.dims.0 + i as usize]
    }

    fn insert_box(&mut self, lo: Vector2<f64>, hi: Vector2<f64>, item: u32) {
        let (i0, j0) = self.cell_of(&lo);
        let (i1, j1) = self.cell_of(&hi);
        for j in j0.max(0)..=j1.min(self.dims.1 as i64 - 1) {
            for i in i0.max(0)..=i1.min(self.dims.0 as i64 - 1) {
                self.cells[j as usize * self.dims.0 + i as usize].push(item);
            }
        }
    }
}

/// The static street world.
#[derive(Debug, Clone)]
pub struct World {
    /// Layout used to build it.
    pub params: WorldParams,
    /// Facade panels.
    pub panels: Vec<Panel>,
    /// Grid over the panels for ray casting.
    pub panel_grid: Grid,
    /// Road samples (camera positions resampled by arc length).
    pub road: Vec<Vector3<f64>>,
}

fn xz(p: &Vector3<f64>) -> Vector2<f64> {
    Vector2::new(p.x, p.z)
}

/// Resamples a polyline every `step` metres of arc length (x-z distance).
fn resample(positions: &[Vector3<f64>], step: f64) -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    let Some(first) = positions.first() else {
        return out;
    };
    out.push(*first);
    // Arc length still to go before the next sample.
    let mut to_next = step;
    for w in positions.windows(2) {
        let seg = (xz(&w[1]) - xz(&w[0])).norm();
        let mut at = to_next;
        while at <= seg {
            out.push(w[0] + (w[1] - w[0]) * (at / seg));
            at += step;
        }
        to_next = at - seg;
    }
    out
}

impl World {
    /// Builds the street world along `positions` (camera centres, KITTI frame).
    pub fn from_positions(
        positions: &[Vector3<f64>],
        params: WorldParams,
    ) -> Result<World, String> {
        if positions.len() < 2 {
            return Err(format!(
                "a world needs at least 2 positions, got {}",
                positions.len()
            ));
        }
        if positions.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
            return Err("non-finite position in trajectory".into());
        }
        let road = resample(positions, params.road_step);
        let margin = params.facade_offset + 50.0;
        let (mut lo, mut hi) = (xz(&road[0]), xz(&road[0]));
        for p in &road {
            lo = lo.inf(&xz(p));
            hi = hi.sup(&xz(p));
        }
        let (lo, hi) = (lo - Vector2::repeat(margin), hi + Vector2::repeat(margin));
        let mut road_grid = Grid::new(lo, hi, params.keep_out.max(params.revisit_radius));
        // Road samples within `radius` of `p`, excluding those of the current stretch.
        let near = |grid: &Grid,
                    road: &[Vector3<f64>],
                    p: &Vector2<f64>,
                    radius: f64,
                    skip: std::ops::Range<usize>|
         -> bool {
            let (ci, cj) = grid.cell_of(p);
            let reach = (radius / grid.cell).ceil() as i64;
            for j in cj - reach..=cj + reach {
                for i in ci - reach..=ci + reach {
                    for &k in grid.items(i, j) {
                        if !skip.contains(&(k as usize))
                            && (xz(&road[k as usize]) - p).norm() < radius
                        {
                            return true;
                        }
                    }
                }
            }
            false
        };
        // Decide which stretches are first visits, adding samples to the grid in order.
        let window = (3.0 * params.revisit_radius / params.road_step).ceil() as usize;
        let mut new_stretch = vec![false; road.len()];
        for (k, p) in road.iter().enumerate() {
            let recent = k.saturating_sub(window)..k + 1;
            new_stretch[k] = !near(&road_grid, &road, &xz(p), params.revisit_radius, recent);
            road_grid.insert_box(xz(p), xz(p), k as u32);
        }
        let mut panels = Vec::new();
        let mut s_along = [0.0f64; 2];
        for k in 0..road.len().saturating_sub(1) {
            let (p, q) = (xz(&road[k]), xz(&road[k + 1]));
            let dir = q - p;
            if dir.norm() < 1e-9 || !(new_stretch[k] && new_stretch[k + 1]) {
                continue;
            }
            let forward = dir.normalize();
            let right = Vector2::new(forward.y, -forward.x);
            for (side_index, side) in [1.0, -1.0].into_iter().enumerate() {
                let a = p + right * (side * params.facade_offset);
                let b = q + right * (side * params.facade_offset);
                let building = (k / params.panels_per_building.max(1)) as i64;
                // The style hashes the building's world cell, so it belongs to the place.
                let anchor =
                    xz(&road[(building as usize * params.panels_per_building).min(road.len() - 1)]);
                let cell = (anchor + right * (side * params.facade_offset)) / 2.0;
                let style = hash2(
                    params.seed ^ mix(side_index as u64 + 1),
                    cell.x.floor() as i64,
                    cell.y.floor() as i64,
                );
                s_along[side_index] += (b - a).norm();
                if unit(mix(style ^ 0x9A9)) < params.gap_probability {
                    continue;
                }
                let mid = (a + b) * 0.5;
                if [a, mid, b]
                    .iter()
                    .any(|pt| near(&road_grid, &road, pt, params.keep_out, 0..0))
                {
                    continue;
                }
                let normal = Vector2::new(-(b - a).y, (b - a).x).normalize();
                let sun = Vector2::new(0.6, 0.8);
                panels.push(Panel {
                    a,
                    b,
                    base_y: params.camera_height,
                    height: 6.0 + 14.0 * unit(mix(style ^ 0x4E16)),
                    s0: s_along[side_index] - (b - a).norm(),
                    style,
                    light: 0.8 + 0.2 * normal.dot(&sun).abs(),
                });
            }
        }
        let mut panel_grid = Grid::new(lo, hi, 8.0);
        for (i, panel) in panels.iter().enumerate() {
            panel_grid.insert_box(panel.a.inf(&panel.b), panel.a.sup(&panel.b), i as u32);
        }
        Ok(World {
            params,
            panels,
            panel_grid,
            road,
        })
    }

    /// y of the (flat) ground.
    pub fn ground_y(&self) -> f64 {
        self.params.camera_height
    }
}

/// The pose with its height dropped (`y = 0`): the camera at its height above
/// the flat ground of the rendered world, orientation kept.
pub fn on_road(world_T_cam: &nalgebra::Isometry3<f64>) -> nalgebra::Isometry3<f64> {
    let mut pose = *world_T_cam;
    pose.translation.vector.y = 0.0;
    pose
}

/// Camera poses of the truth: its orientations, or (without them) looking
/// along the path with y down, as KITTI's camera frame.
pub fn camera_poses(truth: &turnprint::Trajectory) -> Vec<nalgebra::Isometry3<f64>> {
    let n = truth.len();
    (0..n)
        .map(|i| {
            let p = truth.poses[i].position;
            let q = truth.poses[i].orientation.unwrap_or_else(|| {
                let next = truth.poses[(i + 1).min(n - 1)].position;
                let prev = truth.poses[i.saturating_sub(1)].position;
                let d = next - prev;
                let yaw = d.x.atan2(d.z);
                nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::y_axis(), yaw)
            });
            nalgebra::Isometry3::from_parts(nalgebra::Translation3::from(p), q)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resample_spaces_points_by_arc_length() {
        let pts = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 10.0),
            Vector3::new(10.0, 0.0, 10.0),
        ];
        let r = resample(&pts, 4.0);
        // Samples at 0, 4, 8, 12, 16 and 20 m of arc length.
        assert_eq!(r.len(), 6);
        for w in r.windows(2) {
            let d = (xz(&w[1]) - xz(&w[0])).norm();
            assert!(d <= 4.0 + 1e-9 && d > 2.0, "{d}");
        }
    }

    #[test]
    fn a_revisited_street_is_built_once() {
        // Drive 200 m along z, then come back 1 m to the side.
        let mut pts: Vec<_> = (0..=100)
            .map(|i| Vector3::new(0.0, 0.0, 2.0 * i as f64))
            .collect();
        pts.extend((0..=100).map(|i| Vector3::new(1.0, 0.0, 200.0 - 2.0 * i as f64)));
        let world = World::from_positions(&pts, WorldParams::default()).unwrap();
        let once = World::from_positions(&pts[..=100], WorldParams::default()).unwrap();
        assert!(
            world.panels.len() <= once.panels.len() + 6,
            "{} vs {}",
            world.panels.len(),
            once.panels.len()
        );
        assert!(world.panels.len() > 60);
    }
}
