//! `Detector::tap_finalised`: the copies of the finalised samples are the
//! history the worker takes in, whole and in order (a fleet rebuilds a
//! robot's history from them).

use turnprint::online::synthetic::CityDrive;
use turnprint::online::{Detector, OnlineConfig, Overflow, PoseInput};

#[test]
fn the_tap_holds_every_sample_the_worker_took_in() {
    let mut d = Detector::new(OnlineConfig::default(), Overflow::Block);
    let tap = d.tap_finalised();
    for (i, p) in CityDrive::new(3).take(3000).enumerate() {
        d.push(&PoseInput {
            t: Some(i as f64),
            position: p,
            orientation: None,
            keyframe: None,
        });
    }
    let (_, summary) = d.finish();
    let (mut grid, mut sig, mut bounds) = (Vec::new(), 0, Vec::new());
    for o in tap.iter() {
        grid.extend(o.grid);
        sig += o.sig.len();
        bounds.extend(o.bounds);
    }
    assert_eq!(grid.len() as u64, summary.worker.grid_samples);
    assert_eq!(sig as u64, summary.worker.sig_samples);
    // The first boundary opens the first segment.
    assert_eq!(bounds.len() as u64, summary.worker.segments + 1);
    assert!(grid
        .windows(2)
        .all(|w| w[0].s <= w[1].s && w[0].pose <= w[1].pose));
    assert!(bounds.windows(2).all(|w| w[0] < w[1]));
}
