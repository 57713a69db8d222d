//! Ray-cast grey images of a textured street world built along a real
//! trajectory, for any of the verifier's camera models.
//!
//! Each pixel is unprojected to a bearing with the camera model (the same
//! maths the verifier uses to lift keypoints), turned into a world ray and
//! intersected with the facade panels (2-D grid traversal over the x-z
//! plane) and the ground. Textures are box-filtered over the pixel footprint
//! so that the same place renders consistently from different viewpoints.

#![allow(non_snake_case)]

pub mod texture;
pub mod world;

use nalgebra::{Isometry3, Vector2, Vector3};

use crate::camera::CameraModel;
use texture::{ground_shade, Facade};
pub use world::{camera_poses, on_road, Panel, World, WorldParams};

/// Rays stop after this distance (metres): beyond it fog hides everything.
const MAX_DISTANCE: f64 = 300.0;
/// Fog distance constant (metres).
const FOG: f64 = 140.0;
/// Grey level of the sky and of the fog.
const SKY: f64 = 0.88;

/// What a ray hit.
enum Hit {
    Panel { t: f64, index: usize, u: f64 },
    Ground { t: f64 },
    Sky,
}

/// Nearest panel hit along `o + t d` with `t < t_max`, by grid traversal.
fn cast_panels(
    world: &World,
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    t_max: f64,
) -> Option<(f64, usize, f64)> {
    let g = &world.panel_grid;
    let o2 = Vector2::new(o.x, o.z);
    let d2 = Vector2::new(d.x, d.z);
    if d2.norm() < 1e-12 {
        return None;
    }
    let (mut i, mut j) = g.cell_of(&o2);
    let step_i: i64 = if d2.x > 0.0 { 1 } else { -1 };
    let step_j: i64 = if d2.y > 0.0 { 1 } else { -1 };
    let boundary =
        |c: i64, step: i64, origin: f64| origin + (c + i64::from(step > 0)) as f64 * g.cell;
    let mut t_next_x = if d2.x != 0.0 {
        (boundary(i, step_i, g.origin.x) - o2.x) / d2.x
    } else {
        f64::INFINITY
    };
    let mut t_next_z = if d2.y != 0.0 {
        (boundary(j, step_j, g.origin.y) - o2.y) / d2.y
    } else {
        f64::INFINITY
    };
    let dt_x = if d2.x != 0.0 {
        g.cell / d2.x.abs()
    } else {
        f64::INFINITY
    };
    let dt_z = if d2.y != 0.0 {
        g.cell / d2.y.abs()
    } else {
        f64::INFINITY
    };
    let mut best: Option<(f64, usize, f64)> = None;
    loop {
        for &k in g.items(i, j) {
            let p = &world.panels[k as usize];
            let e = p.b - p.a;
            let denom = d2.x * e.y - d2.y * e.x;
            if denom.abs() < 1e-12 {
                continue;
            }
            let w = p.a - o2;
            let t = (w.x * e.y - w.y * e.x) / denom;
            let u = (w.x * d2.y - w.y * d2.x) / denom;
            if t <= 1e-6
                || !(0.0..=1.0).contains(&u)
                || t >= t_max
                || best.is_some_and(|b| t >= b.0)
            {
                continue;
            }
            let y = o.y + t * d.y;
            // Panels rise from below the ground (hiding seams on slopes) to their top.
            if y >= p.base_y - p.height && y <= p.base_y + 3.0 {
                best = Some((t, k as usize, u));
            }
        }
        let t_exit = t_next_x.min(t_next_z);
        if best.is_some_and(|b| b.0 <= t_exit) || t_exit >= t_max {
            return best;
        }
        if t_next_x < t_next_z {
            i += step_i;
            t_next_x += dt_x;
        } else {
            j += step_j;
            t_next_z += dt_z;
        }
    }
}

/// Renders the grey image seen by `camera` at pose `world_T_cam` (maps camera
/// points into the world; see [`on_road`] for trajectory poses). Pixels with
/// no ray in the model are black.
pub fn render(
    world: &World,
    camera: &CameraModel,
    world_T_cam: Isometry3<f64>,
    width: u32,
    height: u32,
) -> Vec<u8> {
    let mut image = vec![0u8; width as usize * height as usize];
    let centre = Vector2::new(0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
    let pixel_angle = camera.pixel_angle(&centre).unwrap_or(1e-3);
    let o = world_T_cam.translation.vector;
    let ground_y = world.ground_y();
    let seed = world.params.seed;
    for v in 0..height {
        for u in 0..width {
            let Some(bearing) = camera.unproject(&Vector2::new(u as f64, v as f64)) else {
                continue;
            };
            let d = world_T_cam.rotation * bearing.into_inner();
            let t_ground = if d.y > 1e-9 {
                (ground_y - o.y) / d.y
            } else {
                f64::INFINITY
            };
            let t_max = t_ground.min(MAX_DISTANCE);
            let hit = match cast_panels(world, &o, &d, t_max) {
                Some((t, index, u)) => Hit::Panel { t, index, u },
                None if t_ground < MAX_DISTANCE => Hit::Ground { t: t_ground },
                None => Hit::Sky,
            };
            let grey = match hit {
                Hit::Panel { t, index, u } => {
                    let p = &world.panels[index];
                    let e = p.b - p.a;
                    let len = e.norm();
                    let n = Vector2::new(-e.y, e.x) / len;
                    let cos = (n.dot(&Vector2::new(d.x, d.z))).abs().max(0.2);
                    let fw = t * pixel_angle / cos;
                    let s = p.s0 + u * len;
                    let h = p.base_y - (o.y + t * d.y);
                    let shade = Facade::new(p.style).shade(s, h, fw) * p.light;
                    let fog = (-t / FOG).exp();
                    shade * fog + SKY * (1.0 - fog)
                }
                Hit::Ground { t } => {
                    let fw = t * pixel_angle / d.y.abs().max(0.05);
                    let q = o + d * t;
                    let fog = (-t / FOG).exp();
                    ground_shade(seed, q.x, q.z, fw) * fog + SKY * (1.0 - fog)
                }
                Hit::Sky => SKY + 0.08 * d.y.min(0.0),
            };
            image[(v * width + u) as usize] = (grey.clamp(0.0, 1.0) * 255.0).round() as u8;
        }
    }
    image
}
