//! `--format auto`: the format of a file from its extension, else from its
//! first data line (and the `#` comment just before it, which may be a
//! header).
//!
//! Rules, in order: extension `.gpx`/`.tum`/`.kitti`/`.xyz`/`.mcap` (a file
//! read whole is also an MCAP bag when it starts with the MCAP magic bytes,
//! checked before the text is decoded); text starting
//! with `<` is GPX; a first data line that is not all numbers is a CSV
//! header; whitespace-separated numbers: 12 are KITTI, 8 are TUM, else a
//! `#` header naming x and y makes it CSV, else 2-3 are xyz;
//! comma-separated numbers: 8 or more starting with an integer (nanoseconds)
//! are EuRoC, else a `#` header naming x and y makes it CSV, else 2-3 are
//! xyz. Anything else is an error asking for `--format`.

use std::path::Path;

use super::csv::header_columns;
use super::{clip, parse_error, Format};
use crate::Result;

/// The format of `text` read from `path`.
pub(super) fn detect(text: &str, path: &Path) -> Result<Format> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gpx") => return Ok(Format::Gpx),
        Some("tum") => return Ok(Format::Tum),
        Some("kitti") => return Ok(Format::Kitti),
        Some("xyz") => return Ok(Format::Xyz),
        Some("mcap") => return Ok(Format::Mcap),
        _ => {}
    }
    sniff(text).map_err(|(line, message)| parse_error(path, line, message))
}

/// The format from the content alone, or `(line, why not)`.
fn sniff(text: &str) -> std::result::Result<Format, (usize, String)> {
    let mut comment: Option<&str> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if line.starts_with('<') {
            return Ok(Format::Gpx);
        }
        if line.starts_with('#') {
            comment = Some(line);
            continue;
        }
        return classify(line, comment).map_err(|m| (i + 1, m));
    }
    // Nothing but comments: any line format reads no poses and says so.
    Ok(Format::Tum)
}

/// The format of a file whose first data line is `line`, preceded by the
/// `#` comment `comment`.
fn classify(line: &str, comment: Option<&str>) -> std::result::Result<Format, String> {
    let comma = line.contains(',');
    let fields: Vec<&str> = if comma {
        line.split(',').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    };
    let numeric = fields.iter().all(|f| f.parse::<f64>().is_ok());
    if !numeric {
        return header_columns(line).map(|_| Format::Csv).map_err(|m| {
            format!(
                "cannot tell the format (use --format): '{}' is neither numbers nor a CSV header: {m}",
                clip(line)
            )
        });
    }
    let named_header = comment.is_some_and(|c| header_columns(c).is_ok());
    let n = fields.len();
    let format = if comma {
        let integer_time = fields[0].parse::<i64>().is_ok();
        match n {
            8.. if integer_time => Some(Format::Euroc),
            _ if named_header => Some(Format::Csv),
            // 8+ comma-separated numbers without integer nanoseconds could
            // be a comma-separated TUM file just as well: no guess.
            2 | 3 => Some(Format::Xyz),
            _ => None,
        }
    } else {
        match n {
            12 => Some(Format::Kitti),
            8 => Some(Format::Tum),
            _ if named_header => Some(Format::Csv),
            2 | 3 => Some(Format::Xyz),
            _ => None,
        }
    };
    format.ok_or_else(|| {
        format!(
            "cannot tell the format (use --format): {n} {} numbers per line match none of tum (8), kitti (12), euroc (8+ comma separated), xyz (2-3)",
            if comma { "comma-separated" } else { "whitespace-separated" }
        )
    })
}
