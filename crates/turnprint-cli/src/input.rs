//! Reading a command's paths: a file or stdin (`-`), with `--topic` for
//! ROS 2 bags.

use std::path::Path;

use turnprint::io::{read_trajectory_from_topic, read_trajectory_topic, Format};
use turnprint::{Result, Trajectory};

/// The trajectory in `path`, or on stdin for `-`. `topic` (`--topic`) is
/// the bag topic to read; it applies to every input that is a bag (by
/// `--format mcap` or the `.mcap` extension, or any stdin input), so
/// `match bag.mcap gt.txt --topic /odom` reads the bag's topic and the text
/// file as it is.
pub fn read(path: &Path, format: Format, topic: Option<&str>) -> Result<Trajectory> {
    if path == Path::new("-") {
        let stdin = std::io::stdin().lock();
        return read_trajectory_from_topic(stdin, Path::new("<stdin>"), format, topic);
    }
    let bag = format == Format::Mcap
        || (format == Format::Auto
            && path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("mcap")));
    read_trajectory_topic(path, format, topic.filter(|_| bag))
}
