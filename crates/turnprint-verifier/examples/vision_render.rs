//! Renders KITTI 00 frames of the street world with each camera model and
//! writes them as PNG files, to look at the test world.
//!
//! `cargo run --release -p turnprint-verifier --example vision_render -- OUT_DIR [FRAME...]`
//!
//! KITTI 00's ground truth comes from the shared data
//! (`kitti_gt/00.txt`, see `turnprint_eval::data`).

use nalgebra::Isometry3;
use opencv::core::{Mat, Vector};
use opencv::imgcodecs::imwrite;
use turnprint_verifier::render::{camera_poses, on_road, render, World, WorldParams};
use turnprint_verifier::CameraModel;

/// Camera poses of a KITTI ground-truth file, read by the project's reader.
fn kitti_poses(file: &str) -> Vec<Isometry3<f64>> {
    let truth = turnprint::io::read_trajectory(file.as_ref(), turnprint::io::Format::Kitti)
        .unwrap_or_else(|e| panic!("{e}"));
    camera_poses(&truth)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).cloned().unwrap_or_else(|| "/tmp".into());
    let frames: Vec<usize> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|a| a.parse().expect("frame index"))
            .collect()
    } else {
        vec![50, 4495]
    };
    let Some(truth) = turnprint_eval::data::require("kitti_gt/00.txt") else {
        return;
    };
    let poses = kitti_poses(truth.to_str().expect("a UTF-8 data path"));
    let positions: Vec<_> = poses.iter().map(|p| p.translation.vector).collect();
    let t0 = std::time::Instant::now();
    let world = World::from_positions(&positions, WorldParams::default()).expect("world");
    eprintln!(
        "world: {} panels, {} road samples, built in {:?}",
        world.panels.len(),
        world.road.len(),
        t0.elapsed()
    );
    let (w, h) = (640, 480);
    let cameras = [
        (
            "pinhole",
            CameraModel::standard_pinhole(w, h, 90f64.to_radians()),
        ),
        (
            "fisheye",
            CameraModel::standard_fisheye(w, h, 190f64.to_radians()),
        ),
        (
            "omni",
            CameraModel::standard_omni(w, h, 0.9, 200f64.to_radians()),
        ),
    ];
    for &frame in &frames {
        for (name, camera) in &cameras {
            let t0 = std::time::Instant::now();
            let image = render(&world, camera, on_road(&poses[frame]), w, h);
            eprintln!("{name} frame {frame}: {:?}", t0.elapsed());
            let mat = Mat::new_rows_cols_with_data(h as i32, w as i32, &image).expect("mat");
            let path = format!("{out}/kitti00_{frame}_{name}.png");
            imwrite(&path, &mat, &Vector::new()).expect("write png");
        }
    }
}
