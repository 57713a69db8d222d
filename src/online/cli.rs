//! `turnprint stream A --json`: replays a trajectory through the detector
//! and writes JSON Lines (`cli.md`). The replay uses [`Overflow::Block`]
//! so the output does not depend on machine speed.

use std::io::Write;
use std::path::Path;

use serde_json::json;

use super::{Detector, OnlineConfig, Overflow, PoseInput, Summary};
use crate::io::{read_trajectory, Format};
use crate::{Error, Result};

/// Streams the trajectory at `path` and writes one JSON object per line
/// to `out`: candidates as they come, then the summary.
pub fn stream(
    path: &Path,
    format: Format,
    config: &OnlineConfig,
    out: &mut dyn Write,
) -> Result<Summary> {
    let trajectory = read_trajectory(path, format)?;
    let name = path.display().to_string();
    if trajectory.len() < crate::pipeline::prepare::MIN_POSES {
        return Err(Error::input(
            &name,
            format!(
                "{} poses; the method needs at least {}",
                trajectory.len(),
                crate::pipeline::prepare::MIN_POSES
            ),
        ));
    }
    let io_err = |e: std::io::Error| Error::Io {
        path: "<stdout>".into(),
        source: e,
    };
    let mut detector = Detector::new(config.clone(), Overflow::Block);
    for pose in &trajectory.poses {
        detector.push(&PoseInput {
            t: pose.t,
            position: pose.position,
            orientation: pose.orientation,
            keyframe: None,
        });
        for e in detector.poll() {
            writeln!(out, "{}", e.to_json()).map_err(io_err)?;
        }
    }
    let (rest, summary) = detector.finish();
    for e in rest {
        writeln!(out, "{}", e.to_json()).map_err(io_err)?;
    }
    let mut s = serde_json::to_value(summary).unwrap_or_default();
    if let Some(o) = s.as_object_mut() {
        o.insert("event".into(), json!("summary"));
        o.insert("path".into(), json!(name));
        o.insert("candidates".into(), json!(summary.worker.candidates));
    }
    writeln!(out, "{s}").map_err(io_err)?;
    Ok(summary)
}
