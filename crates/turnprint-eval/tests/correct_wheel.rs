//! Drift correction and the loop search on a wheeled robot's dead
//! reckoning, judged by the relations measured for its log (CARMEN ACES,
//! `turnprint_eval::relations`; skipped when the shared data is absent, a
//! failure under `CI=true`).

use turnprint::correct::{correct, CorrectConfig};
use turnprint::io::{read_trajectory, Format};
use turnprint::Trajectory;
use turnprint_eval::data::require;
use turnprint_eval::relations::{errors, read, Relation};

/// ACES's wheel odometry and its measured relations; `None` (the test
/// skips) without the shared data.
fn aces() -> Option<(Trajectory, Vec<Relation>)> {
    let odometry = require("carmen/more/aces_odom.csv")?;
    let measured = require("carmen/more/aces.relations")?;
    Some((
        read_trajectory(&odometry, Format::Auto).unwrap(),
        read(&measured).unwrap(),
    ))
}

/// Regression: the CSV reader dropped the `theta` column, so a corrected
/// wheel odometry came out with every heading the identity (ACES: mean
/// heading error of its relations 2.2° -> 9.2°). Correction must keep the
/// heading and do no harm where the log's relations measure it: the local
/// motion and the revisits both stay within 5 % of the odometry's errors.
#[test]
fn correcting_wheel_odometry_keeps_its_heading_and_harms_no_measured_relation() {
    let Some((path, relations)) = aces() else {
        return;
    };
    let (all, revisits) = errors(&path.poses, &relations).expect("timed poses with headings");
    assert_eq!(all.count, relations.len());
    assert!(revisits.count >= 50, "{revisits:?}");
    let corrected = correct(&path, &CorrectConfig::default()).unwrap();
    assert!(corrected.kept() > 0, "no loop kept on ACES");
    let (all_after, revisits_after) =
        errors(&corrected.poses, &relations).expect("the corrected path keeps its headings");
    for (name, before, after) in [
        ("translation", all.translation, all_after.translation),
        ("heading", all.rotation, all_after.rotation),
        (
            "revisits' translation",
            revisits.translation,
            revisits_after.translation,
        ),
        (
            "revisits' heading",
            revisits.rotation,
            revisits_after.rotation,
        ),
    ] {
        assert!(
            after <= 1.05 * before,
            "{name}: mean error {before} before, {after} after correction"
        );
    }
}

/// The loop search on a wheeled robot's dead reckoning, judged by the log's
/// relations (`evaluate_kinds`' wheeled row): its best loop is right and
/// its top 10 covers more of the revisit events than the naive
/// nearest-position baseline, which drift has moved metres apart.
#[test]
fn a_wheeled_robots_loops_are_judged_by_its_relations_and_cover_more_than_the_naive() {
    use turnprint_eval::kinds::{catalog, loops};
    let Some(measured) = require("carmen/more/aces.relations") else {
        return;
    };
    let dir = measured.ancestors().nth(3).expect("<data>/carmen/more/");
    let sessions = catalog(dir).sessions;
    let aces = sessions
        .iter()
        .find(|s| s.name == "carmen aces")
        .expect("ACES in the catalog");
    assert!(aces.relations.is_some() && aces.loops_judged());
    assert_eq!(loops::inputs(aces), vec![loops::Input::Estimate]);
    let run = loops::run(aces, loops::Input::Estimate, 1, false).expect("ACES revisits");
    assert!(run.events >= 5, "{:?}", run.event_ranges);
    assert!(run.rank1_correct[0], "{:?}", run.loops);
    assert!(run.covered[0] > run.covered[1], "{:?}", run.covered);
}

/// Regression: streamed with correction, ACES's dead reckoning kept its
/// revisits' errors (7.38 m and 20.3° on average, against 7.52 m and 20.5°
/// before), the random-walk prior following each loop only between its
/// passes; the revisits that are metres off share no turn with their first
/// pass, so no loop spans them. The eleven loops streamed agree on a
/// heading that turns at one rate (the wheels' bias, about 32° over the
/// log), which is taken out of the odometry (`CorrectConfig::systematic`):
/// measured 3.50 m and 7.5° (bound: 0.7 of before, both).
#[test]
fn a_wheel_odometrys_heading_bias_streamed_is_taken_out_at_its_far_revisits() {
    use turnprint::online::correction::LoopInput;
    use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};
    let Some((path, relations)) = aces() else {
        return;
    };
    let (_, before) = errors(&path.poses, &relations).expect("timed poses with headings");
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block)
        .with_correction(CorrectConfig::default(), LoopInput::Candidates);
    for p in &path.poses {
        d.push(&PoseInput::from(p));
        d.poll();
        d.poll_corrections();
    }
    let (_, _, finished) = d.finish_corrected();
    let corrected = finished
        .and_then(|f| f.corrected)
        .expect("a streamed correction");
    assert!(corrected.bias.is_some(), "no bias measured");
    let (_, after) = errors(&corrected.poses, &relations).expect("headings kept");
    assert!(
        after.translation < 0.7 * before.translation && after.rotation < 0.7 * before.rotation,
        "revisits: {:.2} m / {:.1}° before, {:.2} m / {:.1}° after",
        before.translation,
        before.rotation.to_degrees(),
        after.translation,
        after.rotation.to_degrees()
    );
}
