//! Poses read one line at a time, as a running odometry process writes them
//! (`turnprint stream -`): the same parsers as whole files, the format
//! detected from the first data line when it is `auto`.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::{detect, line_format, Format, LineFormat};
use crate::{Error, Pose, Result};

/// Why GPX cannot be streamed.
const NO_GPX: &str = "GPX cannot be read line by line: give it as a file";

/// Why an MCAP bag cannot be streamed.
const NO_MCAP: &str = "an MCAP bag cannot be read line by line: give it as a file";

/// Why `format`, which has no line reader, cannot be streamed.
fn not_by_line(format: Format) -> &'static str {
    match format {
        Format::Mcap => NO_MCAP,
        _ => NO_GPX,
    }
}

/// A line-oriented trajectory read as its lines arrive.
pub struct PoseLines {
    path: PathBuf,
    reader: Option<Box<dyn LineFormat>>,
    /// The lines before the first data line, kept for `auto` detection
    /// (which may read a `#` header above it).
    preamble: String,
    /// Lines seen.
    line: usize,
    /// Whether a line of numbers that are not all finite is a lost pose
    /// rather than an error.
    lost_poses: bool,
}

impl PoseLines {
    /// A reader of `format` whose messages name `path` (`-` for stdin).
    /// GPX (XML) and MCAP (binary) are not lines: an error.
    pub fn new(format: Format, path: &Path) -> Result<PoseLines> {
        if matches!(format, Format::Gpx | Format::Mcap) {
            return Err(Error::input(
                path.display().to_string(),
                not_by_line(format),
            ));
        }
        Ok(PoseLines {
            path: path.to_path_buf(),
            reader: line_format(format),
            preamble: String::new(),
            line: 0,
            lost_poses: false,
        })
    }

    /// This reader, taking a line of numbers that are not all finite (the
    /// odometry lost track: `nan nan nan ...`) for a pose at a non-finite
    /// position instead of an error, for the detector's guard to drop and
    /// count. Other bad lines are still errors.
    pub fn with_lost_poses(self) -> PoseLines {
        PoseLines {
            lost_poses: true,
            ..self
        }
    }

    /// The pose on the next line, if it holds one; an error names the line.
    pub fn push(&mut self, raw: &str) -> Result<Option<Pose>> {
        self.line += 1;
        let raw = if self.line == 1 {
            raw.strip_prefix('\u{feff}').unwrap_or(raw)
        } else {
            raw
        };
        let content = raw.trim();
        if self.reader.is_none() {
            // `auto`: comments wait for the first data line, which decides.
            if content.is_empty() || content.starts_with('#') {
                self.preamble.push_str(content);
                self.preamble.push('\n');
                return Ok(None);
            }
            let text = format!("{}{content}", self.preamble);
            let format = detect::detect(&text, &self.path)?;
            let Some(reader) = line_format(format) else {
                return Err(super::parse_error(
                    &self.path,
                    self.line,
                    not_by_line(format),
                ));
            };
            self.reader = Some(reader);
            // The comments above, from line 1: no poses, but one may be a
            // CSV header.
            let preamble = std::mem::take(&mut self.preamble);
            for (i, earlier) in preamble.lines().enumerate() {
                if !earlier.is_empty() {
                    self.read(i + 1, earlier)?;
                }
            }
        }
        if content.is_empty() {
            return Ok(None);
        }
        self.read(self.line, content)
    }

    fn read(&mut self, line: usize, content: &str) -> Result<Option<Pose>> {
        let Some(reader) = self.reader.as_mut() else {
            return Ok(None);
        };
        match reader.line(line, content, &self.path) {
            Err(_) if self.lost_poses && lost(content) => Ok(Some(Pose {
                t: None,
                position: Vector3::repeat(f64::NAN),
                orientation: None,
            })),
            read => read,
        }
    }
}

/// True when every field of `content` is a number and one is not finite.
fn lost(content: &str) -> bool {
    let mut non_finite = false;
    let numbers = content
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .all(|f| {
            f.parse::<f64>()
                .map(|v| non_finite |= !v.is_finite())
                .is_ok()
        });
    numbers && non_finite
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::parse_trajectory;

    /// Every line pushed gives the poses of the whole file, in order.
    fn poses_by_line(text: &str, format: Format) -> Result<Vec<Pose>> {
        let mut lines = PoseLines::new(format, Path::new("-"))?;
        let mut poses = Vec::new();
        for l in text.lines() {
            poses.extend(lines.push(l)?);
        }
        Ok(poses)
    }

    #[test]
    fn line_by_line_reads_what_the_whole_file_reads() {
        let texts = [
            "# t x y z qx qy qz qw\n0 1 2 3 0 0 0 1\n\n0.1 1.5 2 3 0 0 0 1\n",
            "1 0 0 5 0 1 0 6 0 0 1 7\n1 0 0 8 0 1 0 9 0 0 1 10\n",
            "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z\n1403636579758555392,1,2,3,1,0,0,0\n",
            "1, 2\n3, 4\n",
            "\u{feff}# a comment\n# t,x,y,z\n0,1,2,3\n1,4,5,6\n",
            "time x y\n0 1 2\n1 3 4\n",
        ];
        for text in texts {
            let whole = parse_trajectory(text, Format::Auto, Path::new("-"))
                .unwrap()
                .poses;
            let streamed = poses_by_line(text, Format::Auto).unwrap();
            assert_eq!(whole.len(), streamed.len(), "{text:?}");
            for (w, s) in whole.iter().zip(&streamed) {
                assert_eq!(w.position, s.position, "{text:?}");
                assert_eq!(w.t, s.t, "{text:?}");
            }
        }
    }

    #[test]
    fn a_bad_line_is_named_and_gpx_is_refused() {
        let err =
            poses_by_line("0 1 2 3 0 0 0 1\n\n0 1 nan 3 0 0 0 1\n", Format::Auto).unwrap_err();
        assert!(err.to_string().starts_with("-:3: "), "{err}");
        let err = poses_by_line("<gpx><trk>", Format::Auto).unwrap_err();
        assert!(err.to_string().contains("GPX"), "{err}");
        assert!(PoseLines::new(Format::Gpx, Path::new("-")).is_err());
        let err = PoseLines::new(Format::Mcap, Path::new("-")).err().unwrap();
        assert!(err.to_string().contains("MCAP"), "{err}");
        let mut lines = PoseLines::new(Format::Auto, Path::new("bag.mcap")).unwrap();
        let err = lines.push("0 1 2 3 0 0 0 1").unwrap_err();
        assert!(err.to_string().contains("MCAP"), "{err}");
    }

    #[test]
    fn a_lost_pose_is_a_non_finite_pose_only_when_asked() {
        let text = "0 1 2 3 0 0 0 1\n0.1 nan nan nan nan nan nan nan\n0.2 1 2 3 0 0 0 1\n";
        assert!(poses_by_line(text, Format::Tum).is_err());
        let mut lines = PoseLines::new(Format::Auto, Path::new("-"))
            .unwrap()
            .with_lost_poses();
        let poses: Vec<Pose> = text
            .lines()
            .map(|l| lines.push(l).unwrap().unwrap())
            .collect();
        assert!(poses[1].position.iter().all(|v| v.is_nan()));
        assert!(poses[2].position.iter().all(|v| v.is_finite()));
        // Words and wrong counts are still errors.
        let mut lines = PoseLines::new(Format::Tum, Path::new("-"))
            .unwrap()
            .with_lost_poses();
        assert!(lines.push("0 1 2 x 0 0 0 1").is_err());
        assert!(lines.push("0 1 2 3").is_err());
    }
}
