//! Helpers shared by the integration tests.

use nalgebra::Vector3;
use turnprint::online::{CandidateEvent, Detector, OnlineConfig, Overflow, PoseInput};

/// Every candidate the detector emits over `points`, pushed one at a time
/// (`Overflow::Block`: the same output on any machine).
pub fn emitted_candidates(points: &[Vector3<f64>], config: OnlineConfig) -> Vec<CandidateEvent> {
    let mut det = Detector::new(config, Overflow::Block);
    let mut out = Vec::new();
    for p in points {
        det.push(&PoseInput::at(*p));
        out.extend(det.poll());
    }
    out.extend(det.finish().0);
    out
}
