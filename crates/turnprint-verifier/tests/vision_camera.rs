//! Camera models: pixel -> bearing -> pixel round trips for all three models,
//! and agreement with OpenCV's own pinhole and fisheye projections.

use nalgebra::{Vector2, Vector3};
use opencv::calib3d::{fisheye_project_points_def, project_points_def};
use opencv::core::{Affine3d, Mat, Point2d, Point3d, Vector};
use opencv::prelude::*;
use turnprint_verifier::CameraModel;

const W: u32 = 640;
const H: u32 = 480;

fn cameras() -> Vec<(&'static str, CameraModel)> {
    vec![
        (
            "pinhole",
            CameraModel::standard_pinhole(W, H, 90f64.to_radians()),
        ),
        (
            "pinhole with distortion",
            CameraModel::Pinhole {
                fx: 458.654,
                fy: 457.296,
                cx: 367.215,
                cy: 248.375,
                k1: -0.28340811,
                k2: 0.07395907,
                p1: 0.00019359,
                p2: 1.76187114e-05,
            },
        ),
        (
            "fisheye 190",
            CameraModel::standard_fisheye(W, H, 190f64.to_radians()),
        ),
        (
            "omni",
            CameraModel::standard_omni(W, H, 0.9, 200f64.to_radians()),
        ),
    ]
}

#[test]
fn pixel_bearing_pixel_round_trip() {
    for (name, cam) in cameras() {
        let mut checked = 0;
        for v in (0..H).step_by(7) {
            for u in (0..W).step_by(7) {
                let px = Vector2::new(u as f64, v as f64);
                let Some(bearing) = cam.unproject(&px) else {
                    continue;
                };
                assert!((bearing.norm() - 1.0).abs() < 1e-12);
                let back = cam
                    .project(&bearing)
                    .unwrap_or_else(|| panic!("{name}: {px:?} -> {bearing:?} has no pixel"));
                assert!((back - px).norm() < 1e-6, "{name}: {px:?} -> {back:?}");
                checked += 1;
            }
        }
        // The distorted pinhole's corners lie beyond its invertible range; all others cover the image.
        let all = (H.div_ceil(7) * W.div_ceil(7)) as usize;
        assert!(
            checked * 10 >= all * 9,
            "{name}: only {checked} of {all} pixels have rays"
        );
    }
}

#[test]
fn bearing_pixel_bearing_round_trip_beyond_90_degrees() {
    let fisheye = CameraModel::standard_fisheye(W, H, 190f64.to_radians());
    let omni = CameraModel::standard_omni(W, H, 0.9, 200f64.to_radians());
    for cam in [fisheye, omni] {
        for k in 0..=90 {
            // From the axis out to 95 deg off axis, in several azimuths.
            let theta = (k as f64 * 95.0 / 90.0).to_radians();
            for phi in [0.3f64, 1.9, 4.0] {
                let b = Vector3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let px = cam.project(&b).expect("inside the model");
                let back = cam.unproject(&px).expect("a ray");
                assert!(
                    (back.into_inner() - b).norm() < 1e-9,
                    "{cam:?}: {b:?} -> {px:?} -> {back:?}"
                );
            }
        }
    }
    // A pinhole sees nothing behind it; the omni model nothing beyond its horizon s_z = -xi.
    let pinhole = CameraModel::standard_pinhole(W, H, 1.5);
    assert!(pinhole.project(&Vector3::new(0.0, 0.0, -1.0)).is_none());
    assert!(omni.project(&Vector3::new(0.0, 0.1, -1.0)).is_none());
}

#[test]
fn params_round_trip_and_bad_params_are_errors() {
    for (_, cam) in cameras() {
        let (kind, p) = cam.to_params();
        assert_eq!(CameraModel::from_params(kind, &p).unwrap(), cam);
    }
    let e = CameraModel::from_params(7, &[0.0; 12]).unwrap_err();
    assert!(e.contains("unknown camera kind 7"), "{e}");
    let e = CameraModel::from_params(0, &[0.0; 12]).unwrap_err();
    assert!(e.contains("focal"), "{e}");
    let mut p = [500.0; 12];
    p[0] = 1.5;
    assert!(CameraModel::from_params(2, &p).unwrap_err().contains("xi"));
}

fn mat3(m: &[f64; 9]) -> Mat {
    Mat::new_rows_cols_with_data(3, 3, m)
        .unwrap()
        .try_clone()
        .unwrap()
}

#[test]
fn pinhole_and_fisheye_agree_with_opencv() {
    let points: Vec<Vector3<f64>> = (0..50)
        .map(|k| {
            let a = k as f64 * 0.37;
            Vector3::new(0.6 * a.sin(), 0.4 * (1.3 * a).cos(), 1.0 + 0.02 * k as f64)
        })
        .collect();
    let object: Vector<Point3d> = points.iter().map(|p| Point3d::new(p.x, p.y, p.z)).collect();
    let zero = Mat::new_rows_cols_with_data(1, 3, &[0.0f64; 3])
        .unwrap()
        .try_clone()
        .unwrap();
    // Pinhole with radial-tangential distortion.
    let (fx, fy, cx, cy, k1, k2, p1, p2) = (
        458.654,
        457.296,
        367.215,
        248.375,
        -0.28340811,
        0.07395907,
        0.00019359,
        1.76187114e-05,
    );
    let cam = CameraModel::Pinhole {
        fx,
        fy,
        cx,
        cy,
        k1,
        k2,
        p1,
        p2,
    };
    let dist = Mat::new_rows_cols_with_data(1, 4, &[k1, k2, p1, p2])
        .unwrap()
        .try_clone()
        .unwrap();
    let mut projected: Vector<Point2d> = Vector::new();
    project_points_def(
        &object,
        &zero,
        &zero,
        &mat3(&[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]),
        &dist,
        &mut projected,
    )
    .unwrap();
    for (p, q) in points.iter().zip(projected.iter()) {
        let ours = cam.project(p).unwrap();
        assert!(
            (ours - Vector2::new(q.x, q.y)).norm() < 1e-6,
            "pinhole {p:?}: {ours:?} vs {q:?}"
        );
    }
    // OpenCV fisheye (its atan(r) form agrees with our atan2 in front of the camera).
    let CameraModel::Fisheye { fx, fy, cx, cy, k } =
        CameraModel::standard_fisheye(W, H, 190f64.to_radians())
    else {
        unreachable!()
    };
    let cam = CameraModel::Fisheye { fx, fy, cx, cy, k };
    let dist = Mat::new_rows_cols_with_data(1, 4, &k)
        .unwrap()
        .try_clone()
        .unwrap();
    let mut projected: Vector<Point2d> = Vector::new();
    fisheye_project_points_def(
        &object,
        &mut projected,
        Affine3d::default(),
        &mat3(&[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]),
        &dist,
    )
    .unwrap();
    for (p, q) in points.iter().zip(projected.iter()) {
        let ours = cam.project(p).unwrap();
        assert!(
            (ours - Vector2::new(q.x, q.y)).norm() < 1e-6,
            "fisheye {p:?}: {ours:?} vs {q:?}"
        );
    }
}
