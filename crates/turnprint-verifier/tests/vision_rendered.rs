//! The verifier on the rendered street world along KITTI 00: a revisit seen
//! by every camera pairing is confirmed with the true relative pose, two
//! different straight streets are rejected, look-alike facades in another
//! arrangement pass the match gate and are turned away by the geometry, and
//! the feature store keeps to its memory cap.
#![allow(non_snake_case)]

mod vision_common;

use nalgebra::{Isometry3, Vector2, Vector3};
use turnprint_verifier::features::GrayImage;
use turnprint_verifier::render::{on_road, render, World, WorldParams};
use turnprint_verifier::{CameraModel, OrbVerifier, VerifierParams};
use vision_common::{data, kitti_poses};

const W: u32 = 640;
const H: u32 = 480;

fn cameras() -> [(&'static str, CameraModel); 3] {
    [
        (
            "pinhole",
            CameraModel::standard_pinhole(W, H, 90f64.to_radians()),
        ),
        (
            "fisheye",
            CameraModel::standard_fisheye(W, H, 190f64.to_radians()),
        ),
        (
            "omni",
            CameraModel::standard_omni(W, H, 0.9, 200f64.to_radians()),
        ),
    ]
}

fn pairings() -> Vec<(CameraModel, CameraModel, String)> {
    let [(pn, p), (fnm, f), (on, o)] = cameras();
    vec![
        (p, p, format!("{pn}-{pn}")),
        (p, f, format!("{pn}-{fnm}")),
        (p, o, format!("{pn}-{on}")),
        (f, o, format!("{fnm}-{on}")),
    ]
}

struct Scene {
    world: World,
    poses: Vec<Isometry3<f64>>,
}

/// The street world along KITTI 00's ground truth (`None` when absent).
fn kitti00() -> Option<Scene> {
    let poses = kitti_poses(&data("kitti_gt/00.txt")?);
    let positions: Vec<Vector3<f64>> = poses.iter().map(|p| p.translation.vector).collect();
    let world = World::from_positions(&positions, WorldParams::default()).unwrap();
    Some(Scene { world, poses })
}

/// Heading of the optical axis on the ground plane (radians).
fn heading(p: &Isometry3<f64>) -> f64 {
    let z = p.rotation * Vector3::z();
    z.x.atan2(z.z)
}

fn verdict_for(
    scene: &Scene,
    (ca, cb): (CameraModel, CameraModel),
    i: usize,
    j: usize,
) -> turnprint_verifier::Verdict {
    let mut v = OrbVerifier::new(VerifierParams::default()).unwrap();
    let ia = render(&scene.world, &ca, on_road(&scene.poses[i]), W, H);
    let ib = render(&scene.world, &cb, on_road(&scene.poses[j]), W, H);
    v.add_keyframe(
        1,
        ca,
        GrayImage {
            data: &ia,
            width: W,
            height: H,
            stride: W,
        },
    )
    .unwrap();
    v.add_keyframe(
        2,
        cb,
        GrayImage {
            data: &ib,
            width: W,
            height: H,
            stride: W,
        },
    )
    .unwrap();
    v.verify(1, 2)
}

#[test]
fn a_revisit_is_confirmed_for_every_camera_pairing() {
    let Some(scene) = kitti00() else {
        return;
    };
    // KITTI 00 closes its loop near the start: take the frame of the last
    // stretch nearest to frame 50.
    let a = 50;
    let b = (4300..scene.poses.len())
        .min_by(|&x, &y| {
            let d = |k: usize| {
                (scene.poses[k].translation.vector - scene.poses[a].translation.vector).norm()
            };
            d(x).total_cmp(&d(y))
        })
        .unwrap();
    let distance = (scene.poses[b].translation.vector - scene.poses[a].translation.vector).norm();
    assert!(distance < 3.0, "frames {a} and {b} are {distance} m apart");
    let gt = on_road(&scene.poses[b]).inverse() * on_road(&scene.poses[a]);
    for (ca, cb, name) in pairings() {
        let verdict = verdict_for(&scene, (ca, cb), a, b);
        let pose = verdict
            .pose
            .as_ref()
            .unwrap_or_else(|| panic!("{name} {a}-{b} rejected: {}", verdict.reason));
        let rot_err = (pose.b_R_a.inverse() * gt.rotation.to_rotation_matrix())
            .angle()
            .to_degrees();
        eprintln!(
            "{name} {a}-{b}: {}; rotation error {rot_err:.2} deg",
            verdict.reason
        );
        assert!(rot_err < 1.0, "{name}: rotation error {rot_err} deg");
        if pose.b_t_a.norm() > 0.0 {
            let t_err = pose.b_t_a.angle(&gt.translation.vector).to_degrees();
            assert!(
                t_err < 15.0,
                "{name}: translation direction error {t_err} deg"
            );
        }
    }
}

#[test]
fn two_straight_streets_in_different_places_are_rejected() {
    let Some(scene) = kitti00() else {
        return;
    };
    let n = scene.poses.len();
    // Path shape around a frame: heading change over +-20 frames.
    let turn = |k: usize| {
        let d = heading(&scene.poses[(k + 20).min(n - 1)])
            - heading(&scene.poses[k.saturating_sub(20)]);
        d.sin().atan2(d.cos()).abs()
    };
    let a = 50;
    assert!(turn(a) < 3f64.to_radians());
    // Another straight stretch, far from frame a and from every pass near it.
    let far = |k: usize| {
        scene.poses.iter().step_by(5).all(|p| {
            (p.translation.vector - scene.poses[k].translation.vector).norm() > 50.0
                || (p.translation.vector - scene.poses[a].translation.vector).norm() > 100.0
        })
    };
    let b = (1000..n)
        .step_by(10)
        .find(|&k| turn(k) < 3f64.to_radians() && far(k))
        .expect("another straight street");
    for (ca, cb, name) in pairings() {
        let verdict = verdict_for(&scene, (ca, cb), a, b);
        eprintln!("{name} {a}-{b}: {}", verdict.reason);
        assert!(
            !verdict.confirmed(),
            "{name}: frames {a} and {b} confirmed: {}",
            verdict.reason
        );
    }
}

#[test]
fn the_same_pose_renders_the_same_image_and_other_places_differ() {
    let Some(scene) = kitti00() else {
        return;
    };
    let cam = cameras()[0].1;
    let a = render(&scene.world, &cam, on_road(&scene.poses[100]), W, H);
    assert_eq!(
        a,
        render(&scene.world, &cam, on_road(&scene.poses[100]), W, H)
    );
    let b = render(&scene.world, &cam, on_road(&scene.poses[2000]), W, H);
    let differ = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x.abs_diff(**y) > 20)
        .count();
    assert!(differ > a.len() / 5, "only {differ} pixels differ");
    // Textured, not flat: a good spread of grey levels.
    let mean = a.iter().map(|&v| v as f64).sum::<f64>() / a.len() as f64;
    let sd = (a.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
    assert!(sd > 20.0, "grey level spread {sd}");
}

#[test]
fn the_feature_store_keeps_to_its_memory_cap() {
    let Some(scene) = kitti00() else {
        return;
    };
    let cam = cameras()[0].1;
    let images: Vec<Vec<u8>> = (0..6)
        .map(|k| {
            render(
                &scene.world,
                &cam,
                on_road(&scene.poses[300 + 40 * k]),
                W,
                H,
            )
        })
        .collect();
    // Measure one keyframe's footprint, then allow about three.
    let mut probe = OrbVerifier::new(VerifierParams::default()).unwrap();
    probe
        .add_keyframe(
            0,
            cam,
            GrayImage {
                data: &images[0],
                width: W,
                height: H,
                stride: W,
            },
        )
        .unwrap();
    let one = probe.memory_bytes();
    assert!(one > 1000 * 32, "{one} bytes for a keyframe");
    let params = VerifierParams {
        memory_cap: 3 * one + one / 2,
        ..VerifierParams::default()
    };
    let mut v = OrbVerifier::new(params).unwrap();
    for (k, image) in images.iter().enumerate() {
        v.add_keyframe(
            k as u64,
            cam,
            GrayImage {
                data: image,
                width: W,
                height: H,
                stride: W,
            },
        )
        .unwrap();
        assert!(
            v.memory_bytes() <= params.memory_cap,
            "{} > {}",
            v.memory_bytes(),
            params.memory_cap
        );
        if k == 3 {
            // Using keyframe 1 makes keyframe 2 the least recently used.
            let _ = v.verify(1, 3);
        }
    }
    assert!(v.len() <= 3 && v.len() >= 2, "{} keyframes kept", v.len());
    assert!(v.features(5).is_some() && v.features(0).is_none() && v.features(2).is_none());
    let verdict = v.verify(0, 5);
    assert!(
        !verdict.confirmed() && verdict.reason.contains("keyframe 0 unknown"),
        "{}",
        verdict.reason
    );
    // A keyframe larger than the whole cap is an error, not a silent drop.
    let mut tiny = OrbVerifier::new(VerifierParams {
        memory_cap: 1000,
        ..VerifierParams::default()
    })
    .unwrap();
    let e = tiny
        .add_keyframe(
            7,
            cam,
            GrayImage {
                data: &images[0],
                width: W,
                height: H,
                stride: W,
            },
        )
        .unwrap_err();
    assert!(e.contains("more than the cap"), "{e}");
    // Bad images are errors naming the keyframe.
    let e = tiny
        .add_keyframe(
            8,
            cam,
            GrayImage {
                data: &images[0][..100],
                width: W,
                height: H,
                stride: W,
            },
        )
        .unwrap_err();
    assert!(e.contains("keyframe 8"), "{e}");
}

/// The street world with the facades around frame `b` made look-alikes of
/// those around frame `a`: every panel near `b` takes the style, height and
/// texture of the panel at the same place relative to `a`'s camera,
/// `shift(k)` metres further along the street for the `k`-th panel.
fn look_alikes(scene: &Scene, a: usize, b: usize, shift: impl Fn(usize) -> f64) -> World {
    let ground = |k: usize| {
        let p = on_road(&scene.poses[k]);
        let h = heading(&p);
        (
            Vector2::new(p.translation.vector.x, p.translation.vector.z),
            Vector2::new(h.sin(), h.cos()),
        )
    };
    let ((pa, fa), (pb, fb)) = (ground(a), ground(b));
    let right = |f: Vector2<f64>| Vector2::new(f.y, -f.x);
    // A point near b in a's frame: the same distances along and across.
    let to_a = |q: Vector2<f64>, shift: f64| {
        let (along, across) = ((q - pb).dot(&fb), (q - pb).dot(&right(fb)));
        pa + fa * (along + shift) + right(fa) * across
    };
    let mut world = scene.world.clone();
    let near_a: Vec<_> = (scene.world.panels.iter())
        .filter(|q| (q.a - pa).norm() < 150.0)
        .collect();
    let near_b = (world.panels.iter_mut()).filter(|q| (q.a - pb).norm() < 80.0);
    for (k, panel) in near_b.enumerate() {
        let (start, end) = (to_a(panel.a, shift(k)), to_a(panel.b, shift(k)));
        let dir = (end - start).normalize();
        let mid = (start + end) * 0.5;
        // The original panel under the mapped one, running the same way.
        let twin = near_a.iter().find(|q| {
            let qd = (q.b - q.a).normalize();
            let along = (mid - q.a).dot(&qd);
            qd.dot(&dir) > 0.95
                && (0.0..=(q.b - q.a).norm()).contains(&along)
                && (mid - q.a - qd * along).norm() < 1.0
        });
        if let Some(q) = twin {
            let qd = (q.b - q.a).normalize();
            panel.style = q.style;
            panel.height = q.height;
            panel.light = q.light;
            panel.s0 = q.s0 + (start - q.a).dot(&qd);
        }
    }
    world
}

/// Look-alike facades: every building near frame `b` wears the facade of a
/// building near frame `a`, each moved along the street by its own few
/// metres (the same facades in another order, as a chain of look-alike
/// shops). Enough of their features match to pass the match gate, and no
/// one camera motion explains them: the geometric test turns them away.
#[test]
fn look_alike_facades_in_another_arrangement_are_turned_away_by_the_geometry() {
    let Some(scene) = kitti00() else {
        return;
    };
    let a = 50;
    let cam = cameras()[0].1;
    let (mut reached, mut cases) = (0, 0);
    for b in (1000..4500).step_by(250) {
        // Four panels (two road steps on both sides) make a building; five
        // shifts in turn, so that neighbours never move together.
        for metres in [4.0, 7.0, 10.0] {
            let shift = |k: usize| metres * ((k / 4 * 3 % 5) as f64 - 2.0);
            let copy = Scene {
                world: look_alikes(&scene, a, b, shift),
                poses: scene.poses.clone(),
            };
            let verdict = verdict_for(&copy, (cam, cam), a, b);
            cases += 1;
            if verdict.reason.contains("needed") {
                continue;
            }
            reached += 1;
            eprintln!("{a}-{b}, {metres} m: {}", verdict.reason);
            assert!(
                !verdict.confirmed(),
                "{a}-{b}, {metres} m: look-alikes confirmed: {}",
                verdict.reason
            );
            assert!(
                verdict.reason.contains("inliers"),
                "{a}-{b}, {metres} m: not a geometric rejection: {}",
                verdict.reason
            );
        }
    }
    // Measured: 19 of the 42 pass the match gate (17 turned away by the
    // essential matrix's inliers, 2 by parallax); a quarter less is allowed.
    assert!(
        reached >= 14,
        "only {reached} of {cases} reached the geometric test"
    );
}
