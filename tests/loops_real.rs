//! Loops on real paths that regressed or were fixed, named after the bug.

use turnprint_eval::data::load_sequence;
use turnprint_eval::drift::DriftModel;
use turnprint_eval::{loops, Prepared, Source};

mod common;

/// KITTI 08's monocular ORB-SLAM2 estimate was never closed: its revisits
/// lie about 90 steps from the earlier pass, in reverse, bent by scale
/// drift. The shape candidates lose to look-alikes of the block grid; the
/// drifting map's proximity probe must find both events.
#[test]
fn loops_find_both_revisits_of_the_unclosed_mono_08() {
    let Some(dir) = common::shared_dir(&[
        "kitti_gt/08.txt",
        "kitti_gt/08_times.txt",
        "kitti_orbslam2_vio/08_orbslam2_tum.txt",
    ]) else {
        return;
    };
    let p = Prepared::new(load_sequence(&dir, "08").expect("KITTI 08 loads"));
    assert_eq!(p.events.len(), 2, "{:?}", p.events);
    assert!(p.seq.mono.positions.len() > 4000);
    for seed in [3, 4] {
        let [found, naive] = loops::run(&p, Source::Mono, seed, &DriftModel::strong(), 0.0);
        assert_eq!(found.error, None);
        assert_eq!(found.events_covered, 2, "seed {seed}: {:?}", found.loops);
        assert!(found.rank1_correct, "seed {seed}: {:?}", found.loops);
        // The nearest-earlier-position search finds neither.
        assert_eq!(naive.events_covered, 0);
    }
}
