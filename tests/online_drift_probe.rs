//! `OnlineConfig::drift_probe`: where the consistent map's proximity probe
//! finds nothing near, a second probe whose radius grows with the path
//! between the two parts. On KITTI 08 under strong drift (seed 2) the
//! detector without it emits 5 correct candidates, none at the shape cut,
//! with it (the default) 12, two at the cut; on 08's monocular estimate,
//! which ORB-SLAM2 never closed, none without it.

use nalgebra::Vector3;
use rand::SeedableRng;
use turnprint::online::OnlineConfig;
use turnprint_eval::data::load_sequence;
use turnprint_eval::drift::DriftModel;

mod common;

/// Emitted candidates that are correct against `truth`, those of them at
/// the shape cut (`OnlineConfig::min_score`), and all emitted.
fn correct_of(
    points: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    drift_probe: bool,
) -> (usize, usize, usize) {
    let config = OnlineConfig {
        drift_probe,
        ..Default::default()
    };
    let cut = config.min_score;
    let out = common::emitted_candidates(points, config);
    let correct: Vec<_> = out
        .iter()
        .filter(|c| common::is_correct(c, truth))
        .collect();
    let at_cut = correct.iter().filter(|c| c.hypothesis.score >= cut).count();
    (correct.len(), at_cut, out.len())
}

/// A path's truth and its drifted copy.
type TruthAndDrifted = (Vec<Vector3<f64>>, Vec<Vector3<f64>>);

/// KITTI ground truth `name` from the shared data, and the same through
/// the strong drift model times `factor` (random walks seeded with `seed`);
/// `None` after a line saying it is skipped.
fn truth_and_drifted(name: &str, factor: f64, seed: u64) -> Option<TruthAndDrifted> {
    let truth = common::kitti_gt(name)?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let drifted = DriftModel::strong().scaled(factor).apply(&truth, &mut rng);
    Some((truth, drifted))
}

/// Asserts that the detector, with default settings, emits a candidate of
/// `points` that is correct against `truth` and overlaps `frames`.
fn found_at(points: &[Vector3<f64>], truth: &[Vector3<f64>], frames: [usize; 2]) {
    let out = common::emitted_candidates(points, OnlineConfig::default());
    let found = out.iter().any(|c| {
        let h = &c.hypothesis;
        h.a_range[0] <= frames[1] && h.a_range[1] >= frames[0] && common::is_correct(c, truth)
    });
    assert!(
        found,
        "{} candidates, none correct at frames {frames:?}",
        out.len()
    );
}

#[test]
fn drift_probe_finds_revisits_of_a_strongly_drifting_map() {
    let Some((truth, drifted)) = truth_and_drifted("08", 1.0, 2) else {
        return;
    };
    let (without, without_at_cut, _) = correct_of(&drifted, &truth, false);
    let (with, with_at_cut, emitted) = correct_of(&drifted, &truth, true);
    // Without it, the consistent map's probe pairs both revisits only
    // weakly (scores 0.11-0.30, short of the shape cut a correction without
    // a verifier takes); the drifting probe fits them at 0.38-0.41.
    assert_eq!(
        without_at_cut, 0,
        "{without} correct without the drifting probe"
    );
    assert!(
        with_at_cut >= 2 && with >= without + 2,
        "{with} correct of {emitted} with it ({with_at_cut} at the cut), {without} without"
    );
}

/// KITTI 08's monocular estimate revisits its earlier pass about 90 steps
/// away, in reverse, on straight roads: nothing in shape, nothing near. The
/// drifting-map probe's candidates for it score 0.01-0.03 under the drift
/// prior, below the shape candidates' cut: they have their own
/// (`OnlineConfig::drift_min_score`).
#[test]
fn online_finds_a_revisit_of_the_unclosed_mono_08() {
    let Some(dir) = common::shared_dir(&[
        "kitti_gt/08.txt",
        "kitti_gt/08_times.txt",
        "kitti_orbslam2_vio/08_orbslam2_tum.txt",
    ]) else {
        return;
    };
    let seq = load_sequence(&dir, "08").expect("KITTI 08 loads");
    let truth: Vec<Vector3<f64>> = seq
        .mono
        .frames
        .iter()
        .map(|&f| seq.true_position(f))
        .collect();
    let (without, _, _) = correct_of(&seq.mono.positions, &truth, false);
    let (with, _, emitted) = correct_of(&seq.mono.positions, &truth, true);
    assert_eq!(without, 0);
    assert!(with >= 1, "{with} correct of {emitted}");
}

#[test]
fn drift_probe_is_on_by_default() {
    let config = OnlineConfig::default();
    assert!(config.drift_probe);
    assert!(config.drift_radius() > 0.0);
    assert!(config.drift_min_score < config.min_score);
}

/// KITTI 00 under a quarter of the strong drift (seed 2): at its first
/// revisit (frames 1553-1645 over 112-207) the earlier pass lies within the
/// consistent map's probe radius but a few metres off the identity, beyond
/// the first grow round's tolerance (3 % of a probe window, about a metre),
/// so growth from the identity found nothing and the event was missed. The
/// seed now also grows from the fit of its probe points onto their nearest
/// points.
#[test]
fn a_slightly_drifted_revisit_grows_from_the_probe_fit() {
    let Some((truth, drifted)) = truth_and_drifted("00", 0.25, 2) else {
        return;
    };
    found_at(&drifted, &truth, [1553, 1645]);
}

/// KITTI 08 under the strong drift model (seed 2), frames 1399-1514 (over
/// about 720-790, in reverse): the later pass turns onto a straight the
/// earlier pass drove, 60 m before the earlier pass's own turn, and leaves
/// it where the earlier pass came in. Only the straight is common, so
/// nothing in shape pins it. The drift has moved it only 20-30 m, within
/// the consistent map's radius, and the probe's candidate there scores 0.11
/// under the drift prior: below the shape candidates' cut, it was dropped,
/// and the drifting probe, which would have emitted it, never ran.
#[test]
fn a_straight_revisit_found_near_is_emitted() {
    let Some((truth, drifted)) = truth_and_drifted("08", 1.0, 2) else {
        return;
    };
    found_at(&drifted[..1600], &truth, [1399, 1514]);
}

/// KITTI 08 under the strong drift model (seed 34), the same straight
/// revisit: the drift has turned the passes a few degrees apart, so they
/// are 5-8 m apart where the probe looks and the identity grows nothing.
/// The seed's second start, the similarity fit of the probe points onto
/// their nearest points, shrank the window (nearest points on a road at an
/// angle do not measure scale), and the growth ended at that scale with a
/// score near 0. It now keeps the map's own scale
/// (`proximity::consistent_start`).
#[test]
fn a_straight_revisit_turned_apart_grows_at_the_maps_scale() {
    let Some((truth, drifted)) = truth_and_drifted("08", 1.0, 34) else {
        return;
    };
    found_at(&drifted[..1600], &truth, [1399, 1514]);
}

/// KITTI 08 under the strong drift model (seed 40), the same straight
/// revisit: the drift bends the two passes apart along the straight, so
/// growth from the probe's seed ends at 30 m, 0.56 of a probe window, with
/// a score of 0.23 and the map's scale (1.005). Two thirds of a window was
/// the shortest a drifting map's candidate could be; half a window, above
/// the stubs that rule is for (06's racetrack, 0.4-0.5), emits it.
#[test]
fn a_straight_revisit_bent_apart_is_long_enough_at_half_a_window() {
    let Some((truth, drifted)) = truth_and_drifted("08", 1.0, 40) else {
        return;
    };
    found_at(&drifted[..1600], &truth, [1399, 1514]);
}
