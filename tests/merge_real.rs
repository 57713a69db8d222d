//! Merges of real paths that regressed or were fixed, named after the bug.
#![cfg(feature = "eval")]

use std::path::Path;

use rand::rngs::StdRng;
use rand::SeedableRng;
use turnprint::eval::data::load_sequence;
use turnprint::eval::merge::{window_case, MergeCase};
use turnprint::eval::{Prepared, Source};

/// The case on these windows under four random similarities.
fn cases(
    seq: &str,
    source: Source,
    reversed: bool,
    a: [usize; 2],
    b: [usize; 2],
) -> Vec<MergeCase> {
    let p = Prepared::new(load_sequence(Path::new("tests/data"), seq).expect("tests/data"));
    (1..=4)
        .map(|seed| {
            let mut rng = StdRng::seed_from_u64(seed);
            window_case(&mut rng, &p, source, reversed, [a, b], "time", 200.0).expect("case")
        })
        .collect()
}

/// ORB-SLAM2's monocular estimate of KITTI 06 steps back every other frame
/// over whole stretches; each back step was a cusp of 180° of turning, and
/// a 9-pose stretch of B full of them matched a U-turn of A at 37 times
/// the true scale, ahead of the true stretch.
#[test]
fn back_steps_of_mono_06_do_not_make_turns() {
    for case in cases("06", Source::Mono, false, [571, 904], [170, 1100]) {
        assert!(case.oracle_correct);
        assert!(case.rank1_correct, "{case:?}");
    }
}

/// The score counted the turning of the query's stretch alone. Monocular
/// wiggle gives a stretch of B turning the other part of A lacks: a
/// stretch of B turning 186° on a part of A turning 100° outranked the true
/// part (206° on both sides).
#[test]
fn turning_counts_only_where_both_paths_turn() {
    for case in cases("08", Source::Mono, true, [2435, 3672], [3219, 4044]) {
        assert!(case.oracle_correct);
        assert!(case.rank1_correct, "{case:?}");
    }
}
