//! The evaluation's ground truth on the real KITTI data (the shared data,
//! `turnprint_eval::data`; tests whose files are absent say so and skip):
//! the GPS aligns with the ground truth, revisit events are found where
//! KITTI 00 closes its loops, and the naive baseline, on undrifted ground
//! truth under a random similarity, finds every event (so the harness can
//! score a correct detector as correct).

use std::path::PathBuf;

use rand::{rngs::StdRng, SeedableRng};
use turnprint_eval::baseline::Naive;
use turnprint_eval::checks::loop_correct;
use turnprint_eval::data::{data_dirs, load_sequence, require};
use turnprint_eval::drift::DriftModel;
use turnprint_eval::similarity::random_similarity;
use turnprint_eval::Prepared;

/// The first data folder holding KITTI ground truth `name` and each of
/// `files` (`load_sequence` reads what it finds in one folder), or `None`
/// after a line saying it is skipped.
fn data_dir(name: &str, files: &[&str]) -> Option<PathBuf> {
    let mut files: Vec<String> = files.iter().map(|f| f.replace("NN", name)).collect();
    files.insert(0, format!("kitti_gt/{name}.txt"));
    if let Some(dir) = data_dirs()
        .into_iter()
        .find(|d| files.iter().all(|f| d.join(f).is_file()))
    {
        return Some(dir);
    }
    for f in &files {
        require(f)?;
    }
    // Each is somewhere, but not all in one folder.
    let message = format!("{files:?} are in no single one of {:?}", data_dirs());
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    assert!(!ci, "CI=true: {message}");
    eprintln!("skipped: {message}");
    None
}

/// KITTI sequence `name` with `files` besides its ground truth (`NN` for
/// the sequence: `kitti_gt/NN_times.txt`), or `None` when one is absent.
fn sequence(name: &str, files: &[&str]) -> Option<Prepared> {
    let dir = data_dir(name, files)?;
    Some(Prepared::new(
        load_sequence(&dir, name).expect("the sequence loads"),
    ))
}

/// KITTI 00 with the files `files`.
fn kitti00(files: &[&str]) -> Option<Prepared> {
    sequence("00", files)
}

/// Frame times and the real GPS of KITTI 00.
const GPS: [&str; 2] = ["kitti_gt/NN_times.txt", "gtsam_data/KittiGps_converted.txt"];
/// Frame times and the monocular ORB-SLAM2 estimate.
const MONO: [&str; 2] = [
    "kitti_gt/NN_times.txt",
    "kitti_orbslam2_vio/NN_orbslam2_tum.txt",
];

#[test]
fn kitti00_gps_aligns_with_ground_truth() {
    let Some(p) = kitti00(&GPS) else {
        return;
    };
    let (gps, fit) = p.seq.gps.as_ref().expect("GPS of 00 in the data");
    assert!(fit.rmse_m < 1.5, "{fit:?}");
    assert!((fit.scale - 1.0).abs() < 0.01, "{fit:?}");
    assert!(fit.rows_used >= 460, "{fit:?}");
    // GPS rows are paired to increasing frames spanning the drive.
    assert!(gps.frames.windows(2).all(|w| w[1] > w[0]));
    assert!(
        gps.frames[0] < 30.0 && *gps.frames.last().unwrap() > 4500.0,
        "{:?}",
        (gps.frames[0], gps.frames.last())
    );
}

#[test]
fn kitti00_mono_pairs_every_frame() {
    let Some(p) = kitti00(&MONO) else {
        return;
    };
    assert_eq!(p.seq.mono.positions.len(), p.seq.gt.len());
    assert!(p
        .seq
        .mono
        .frames
        .iter()
        .enumerate()
        .all(|(i, f)| *f == i as f64));
}

#[test]
fn naive_baseline_finds_kitti00_events_on_ground_truth_only() {
    let Some(p) = kitti00(&[]) else {
        return;
    };
    // 00 revisits the road of its first loop near frame 1560, drives a long
    // stretch again from about frame 3270, and ends where it started.
    assert_eq!(p.events.len(), 3, "{:?}", p.events);
    assert!(p.events.iter().any(|e| e.last == p.seq.gt.len() - 1));
    let mut rng = StdRng::seed_from_u64(11);
    let sim = random_similarity(&mut rng, 500.0);
    let input: Vec<_> = p.seq.gt.iter().map(|q| sim.apply(q)).collect();
    let loops = Naive::default().loops(&input);
    assert!(loops.iter().all(|l| loop_correct(l, &p.seq.gt, 10.0)));
    for e in &p.events {
        assert!(
            loops
                .iter()
                .any(|l| l.query[0] <= e.last && l.query[1] >= e.first),
            "event {e:?} missed"
        );
    }
    // With strong drift the same search loses most of them.
    let drifted = DriftModel::strong().apply(&p.seq.gt, &mut rng);
    let loops = Naive::default().loops(&drifted);
    let correct = loops
        .iter()
        .filter(|l| loop_correct(l, &p.seq.gt, 10.0))
        .count();
    assert!(
        correct * 2 <= loops.len().max(1),
        "{correct} of {}",
        loops.len()
    );
}

/// KITTI 05's later pass from frame 1309 joins the earlier road from a
/// side street and leaves it straight on: the 218 m they share is a
/// straight (24° of turning on A) entered from different turns. Scaled
/// down about one end, B lies on A as well as it does in truth, so the
/// case is ambiguous by shape; a time overlap through turns is not.
#[test]
fn a_straight_revisit_of_kitti05_is_ambiguous_by_shape_and_a_turning_overlap_is_not() {
    use turnprint_eval::merge::run_case;
    use turnprint_eval::Source;
    let Some(p) = sequence("05", &[]) else {
        return;
    };
    let mut rng = StdRng::seed_from_u64(3);
    let mut ambiguity = |a: [usize; 2], b: [usize; 2], reversed: bool| {
        let run =
            run_case(&mut rng, &p, Source::Gt, reversed, [a, b], 150.0, 0).expect("common road");
        let (_, oracle) = run.oracle.expect("oracle");
        assert!(oracle.correct && oracle.median_error < 1e-6);
        run.ambiguity.expect("ambiguity")
    };
    let straight = ambiguity([451, 1057], [1309, 1931], true);
    assert!(straight.has_rival(), "{straight:?}");
    assert!(straight.truth.turning_deg < 45.0, "{straight:?}");
    let turning = ambiguity([1897, 2569], [1743, 2227], false);
    assert!(!turning.has_rival(), "{turning:?}");
    // Ground truth on its own drive fits A to the centimetre: the band is
    // its floor.
    assert_eq!(turning.band_m, turnprint_eval::ambiguity::BAND_M.0);
}

/// Under the strong drift model (seed 1) the detector misses KITTI 00's
/// first revisit (frames 1553-1645 over 116-207), yet the map's own poses
/// decide it by the online deadline: its road and turns (over 90°, with
/// the approach) lie on the earlier pass only where the truth puts them.
/// The best failing move (the detector's probe put it 50 m along the road)
/// keeps less than half of that.
#[test]
fn kitti00s_first_revisit_under_strong_drift_is_decidable_by_its_turns() {
    let Some(p) = kitti00(&[]) else {
        return;
    };
    let truth = p.seq.gt.clone();
    let mut rng = StdRng::seed_from_u64(1);
    let drifted = DriftModel::strong().apply(&truth, &mut rng);
    let arc = turnprint_eval::revisits::arc_lengths(&truth);
    let deadline = arc.partition_point(|&s| s <= arc[1645] + 40.0);
    let amb = turnprint_eval::ambiguity::revisit_rival(
        &truth,
        &drifted,
        [1553, 1645],
        deadline,
        100.0,
        300,
        8.0,
        &turnprint::score::DriftPrior::default(),
    )
    .expect("the earlier pass is in the map");
    assert!(!amb.has_rival(), "{amb:?}");
    assert!(amb.truth.turning_deg > 90.0, "{amb:?}");
    let rival = amb.best_rival.expect("a failing move");
    assert!(rival.support.length_m < 0.5 * amb.truth.length_m, "{amb:?}");
}
