//! A hand-held camera (TUM RGB-D fr2/desk): motion capture at 300 Hz of a
//! camera carried twice round a desk, and the monocular ORB-SLAM2
//! keyframes of the same run at an unknown scale. Named after the bugs.

use nalgebra::{Rotation3, Unit, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use turnprint::geometry::Similarity3;
use turnprint::io::{read_trajectory, Format};
use turnprint::pipeline::prepare::PreparedPath;
use turnprint::{find_loops, match_paths, Config, Trajectory};

mod common;

/// `evo/{name}` of the shared data, or `None` after a line saying it is
/// skipped.
fn read(name: &str) -> Option<Trajectory> {
    let path = common::shared(&format!("evo/{name}"))?;
    Some(read_trajectory(&path, Format::Tum).expect("TUM file reads"))
}

/// The median distance, over the keyframes, between a keyframe mapped by
/// `gt_T_kf` and the ground-truth pose nearest in time, and the
/// least-squares similarity of the same pairs (the reference).
#[allow(non_snake_case)]
fn keyframe_error(gt: &Trajectory, kf: &Trajectory, gt_T_kf: &Similarity3) -> (f64, Similarity3) {
    let times: Vec<f64> = gt.poses.iter().map(|p| p.t.expect("TUM")).collect();
    let (src, dst): (Vec<_>, Vec<_>) = kf
        .poses
        .iter()
        .map(|p| {
            let t = p.t.expect("TUM");
            let i = times.partition_point(|&x| x < t).min(times.len() - 1);
            (p.position, gt.poses[i].position)
        })
        .unzip();
    let mut d: Vec<f64> = src
        .iter()
        .zip(&dst)
        .map(|(s, g)| (gt_T_kf.apply(s) - g).norm())
        .collect();
    d.sort_by(f64::total_cmp);
    (
        d[d.len() / 2],
        Similarity3::fit(&src, &dst).expect("reference"),
    )
}

/// GCV chose a bandwidth of 0.7 pose spacings: motion capture is precise,
/// so the hand's tremor is signal to it. The path then turned 10° per pose
/// (112 000 signature samples for 21 000 poses); `loops` took 194 s and
/// `match` against the keyframes 64 s. The tremor's turning halves with
/// each doubling of the bandwidth, a real turn's does not.
#[test]
fn a_hand_held_camera_is_smoothed_past_its_tremor() {
    let Some(gt) = read("fr2_desk_groundtruth.txt") else {
        return;
    };
    let prepared = PreparedPath::new(&gt, &Config::for_loops()).expect("moves");
    let samples_per_pose = prepared.signature.len() as f64 / gt.poses.len() as f64;
    assert!(
        samples_per_pose < 0.5,
        "{samples_per_pose} samples per pose"
    );
    // The camera went twice round the desk: at least 720° remain.
    let turning = prepared.signature.len() as f64 * prepared.signature.dk;
    assert!(
        turning > 4.0 * std::f64::consts::PI,
        "{} deg",
        turning.to_degrees()
    );
}

/// Merging the monocular keyframes into the motion capture's frame: the
/// similarity must agree with the one fitted to time-paired poses.
#[test]
fn a_hand_held_camera_merges_with_its_monocular_keyframes() {
    let (Some(gt), Some(kf)) = (
        read("fr2_desk_groundtruth.txt"),
        read("fr2_desk_ORB_kf_mono.txt"),
    ) else {
        return;
    };
    let hypotheses = match_paths(&gt, &kf, &Config::for_matching()).expect("match");
    let best = hypotheses.first().expect("a hypothesis");
    let (error, reference) = keyframe_error(&gt, &kf, &best.similarity());
    let (reference_error, _) = keyframe_error(&gt, &kf, &reference);
    let length: f64 = gt
        .poses
        .windows(2)
        .map(|w| (w[1].position - w[0].position).norm())
        .sum();
    assert!(
        (best.scale / reference.scale - 1.0).abs() < 0.03,
        "{} vs {}",
        best.scale,
        reference.scale
    );
    // 20 m of path: within 0.2 % of it (4 cm), like the least-squares fit.
    assert!(
        error < 0.002 * length,
        "{error} (least squares: {reference_error})"
    );
    assert!(!best.reversed);
}

/// A camera held still for a moment is one point of the smoothed path; a
/// 0.3 m stretch of the same path matched it at scale 0.0005 (and the
/// still start matched a stretch at scale 82) as loops 3, 5, 8 and 9.
#[test]
fn a_camera_held_still_is_no_loop_at_scale_zero() {
    let Some(gt) = read("fr2_desk_groundtruth.txt") else {
        return;
    };
    let loops = find_loops(&gt, &Config::for_loops()).expect("loops");
    assert!(!loops.is_empty());
    for l in &loops {
        assert!((0.1..10.0).contains(&l.scale), "{l:?}");
    }
}

/// The desk's revisit is its last stretch coming back near its start. The
/// best loop must be that revisit as the motion capture shows it: the last
/// tenth of the path paired with the first tenth, at scale 1, each pair no
/// farther apart than twice the truth's own nearest approach of the two
/// passes there (the camera came back within 0.1-0.3 m, not onto itself).
#[test]
fn the_best_loop_of_the_hand_held_path_is_its_revisit() {
    let Some(gt) = read("fr2_desk_groundtruth.txt") else {
        return;
    };
    let n = gt.poses.len();
    let loops = find_loops(&gt, &Config::for_loops()).expect("loops");
    let best = loops.first().expect("a loop");
    let (late, early) = if best.a_range[0] > best.b_range[0] {
        (best.a_range, best.b_range)
    } else {
        (best.b_range, best.a_range)
    };
    assert!(
        late[0] >= n * 9 / 10 && early[1] <= n / 10,
        "best loop {late:?} over {early:?} of {n} poses is not the end over the start"
    );
    assert!((best.scale - 1.0).abs() < MAX_SCALE_ERROR, "{best:?}");
    let start = &gt.poses[..n / 10];
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let pos = |i: usize| gt.poses[i].position;
    let apart = median(
        (best.correspondences.iter())
            .map(|&(a, b)| (pos(a) - pos(b)).norm())
            .collect(),
    );
    let approach = median(
        (best.correspondences.iter())
            .map(|&(a, b)| {
                let late = if a > b { a } else { b };
                (start.iter())
                    .map(|p| (p.position - pos(late)).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .collect(),
    );
    eprintln!(
        "best loop: paired poses {apart:.3} m apart, the passes' nearest approach {approach:.3} m"
    );
    assert!(
        apart <= 2.0 * approach,
        "{apart} m apart, nearest approach {approach} m"
    );
}

/// A loop of the motion capture onto itself is at scale 1 to within this.
const MAX_SCALE_ERROR: f64 = 0.1;
/// Its paired poses are apart by at most this fraction of the matched length
/// (the same place, up to the path's own smoothing).
const MAX_APART: f64 = 0.05;

/// The desk's only revisit is its last 2-3 m (of 18.3 m) coming back within
/// 0.1-0.3 m of its start. Every reported loop is checked against the motion
/// capture: a true loop maps the path onto itself at scale 1 with its paired
/// poses at the same place.
#[test]
#[ignore = "known limit (EVALUATION.md, Limits of loops): the best loop is the revisit (the test above), the other nine are elsewhere or centimetres long"]
fn the_loops_of_the_hand_held_path_are_its_revisit() {
    let Some(gt) = read("fr2_desk_groundtruth.txt") else {
        return;
    };
    let loops = find_loops(&gt, &Config::for_loops()).expect("loops");
    let mut bad = 0;
    for l in &loops {
        let mut apart: Vec<f64> = l
            .correspondences
            .iter()
            .map(|&(a, b)| (gt.poses[a].position - gt.poses[b].position).norm())
            .collect();
        apart.sort_by(f64::total_cmp);
        let median = apart[apart.len() / 2];
        eprintln!(
            "loop {} a {:?} b {:?}: scale {:.4}, paired poses {:.3} m apart (median) of {:.2} m matched",
            l.rank, l.a_range, l.b_range, l.scale, median, l.length
        );
        bad +=
            usize::from((l.scale - 1.0).abs() >= MAX_SCALE_ERROR || median >= MAX_APART * l.length);
    }
    assert_eq!(
        bad,
        0,
        "{bad} of {} loops are not the same place",
        loops.len()
    );
}

/// A third of the hand-held path, under a random similarity (scale
/// 0.01-100, any rotation, either direction), matched against the whole:
/// twelve fixed draws. The part's best-fit plane is not the whole's (the
/// camera rose and fell and tilted), so the planes' lift was 22-43° off and
/// both 3D refinements (`align::lift`, `align::polish`) refused to move
/// that far: 6 of 8 draws came back with the scale 1-19 % and the rotation
/// 23-43° off. They now move when they bring the points four times closer.
/// One draw in twenty or thirty still ranks a look-alike first (a start at
/// 47 % of the path, reversed: the planar projections of part and whole
/// differ, the true overlap's residual is 0.037 and a short look-alike's
/// 0.002), so one miss in twelve is allowed.
#[test]
fn a_part_of_a_path_that_leaves_every_plane_is_placed_in_3d() {
    let Some(gt) = read("fr2_desk_groundtruth.txt") else {
        return;
    };
    let n = gt.poses.len();
    let mut rng = StdRng::seed_from_u64(7);
    let mut misses = Vec::new();
    for draw in 0..12 {
        let first = (rng.random_range(0.1..0.6) * n as f64) as usize;
        let s = 10f64.powf(rng.random_range(-2.0..2.0));
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let axis = Unit::try_new(axis, 1e-6).unwrap_or(Vector3::z_axis());
        let r = Rotation3::from_axis_angle(&axis, rng.random_range(0.0..std::f64::consts::TAU));
        let reversed = rng.random_bool(0.5);
        let mut part: Vec<Vector3<f64>> = gt.poses[first..first + n * 3 / 10]
            .iter()
            .map(|p| s * (r * p.position) + Vector3::new(3.0, -1.0, 2.0) * s)
            .collect();
        if reversed {
            part.reverse();
        }
        let b = Trajectory::from_positions("part", &part);
        let hypotheses = match_paths(&gt, &b, &Config::for_matching()).expect("match");
        let h = hypotheses.first().expect("a hypothesis");
        let scale_err = (h.scale * s - 1.0).abs();
        let cos = ((h.rotation * r.matrix()).trace() - 1.0) / 2.0;
        let angle_err = cos.clamp(-1.0, 1.0).acos().to_degrees();
        if scale_err > 0.005 || angle_err > 0.5 || h.reversed != reversed {
            misses.push(format!(
                "draw {draw}: scale {:.2} %, {angle_err:.1}°",
                100.0 * scale_err
            ));
        }
    }
    assert!(misses.len() <= 1, "{misses:?}");
}

/// Streamed, the hand-held path kept 920 B of history per pose with the
/// tremor as turns, then 179 B once it was smoothed past it, its grid still
/// at half a pose spacing: 22 samples per bandwidth. The grid now takes at
/// most 8 per bandwidth.
#[test]
fn a_hand_held_camera_streams_in_little_memory() {
    use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
    let Some(gt) = read("fr2_desk_groundtruth.txt") else {
        return;
    };
    let mut detector = Detector::new(OnlineConfig::default(), Overflow::Block);
    for p in &gt.poses {
        detector.push(&PoseInput::at(p.position));
    }
    let (_, summary) = detector.finish();
    let per_pose = summary.worker.history_bytes as f64 / summary.poses as f64;
    assert!(per_pose < 128.0, "{per_pose} bytes of history per pose");
}
