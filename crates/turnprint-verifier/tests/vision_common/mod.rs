//! Helpers shared by the vision tests: image loading and KITTI poses.
#![allow(dead_code, non_snake_case)]

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use opencv::imgcodecs::{imread, IMREAD_GRAYSCALE};
use opencv::prelude::*;
use turnprint_verifier::features::GrayImage;

/// `file` in the shared data (its layout, e.g. `kitti_gt/06.txt` or
/// `images/opencv_samples/graf1.png`), or `None` after a line saying the
/// test is skipped (a failure under `CI=true`;
/// [`turnprint_eval::data::require`]).
pub fn data(file: &str) -> Option<String> {
    let path = turnprint_eval::data::require(file)?;
    Some(path.to_str().expect("a UTF-8 data path").to_string())
}

/// A grey image owned by the test.
pub struct Owned {
    pub pixels: Vec<u8>,
    pub width: u32,
    pub height: u32,
}

impl Owned {
    pub fn view(&self) -> GrayImage<'_> {
        GrayImage {
            data: &self.pixels,
            width: self.width,
            height: self.height,
            stride: self.width,
        }
    }
}

/// Loads an image file as 8-bit grey with OpenCV.
pub fn load_gray(path: &str) -> Owned {
    let mat = imread(path, IMREAD_GRAYSCALE).unwrap_or_else(|e| panic!("{path}: {e}"));
    assert!(!mat.empty(), "{path}: could not read image");
    let mat = if mat.is_continuous() {
        mat
    } else {
        mat.try_clone().unwrap()
    };
    Owned {
        pixels: mat.data_bytes().unwrap().to_vec(),
        width: mat.cols() as u32,
        height: mat.rows() as u32,
    }
}

/// `world_T_cam` of frame `frame` of a KITTI ground-truth file (line frame + 1).
pub fn kitti_pose(file: &str, frame: usize) -> Isometry3<f64> {
    kitti_poses(file).swap_remove(frame)
}

/// All `world_T_cam` poses of a KITTI ground-truth file.
pub fn kitti_poses(file: &str) -> Vec<Isometry3<f64>> {
    let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{file}: {e}"));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|line| {
            let v: Vec<f64> = line
                .split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect();
            assert_eq!(v.len(), 12, "{file}: bad line {line}");
            let r = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
            let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
            Isometry3::from_parts(Translation3::new(v[3], v[7], v[11]), rot)
        })
        .collect()
}

/// Angle (degrees) between two directions.
pub fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.angle(b).to_degrees()
}
