//! `--topic`: every command reads a ROS 2 bag's pose topic (evo's
//! `nav2_turtlebot.mcap`, fetched into `target/data` at set-up).

mod common;

use std::process::{Command, Output};

/// evo's bag: `/odom` (nav_msgs/Odometry) and `/amcl_pose`
/// (PoseWithCovarianceStamped).
const BAG: &str = "evo/nav2_turtlebot.mcap";
/// `/odom` messages in the bag (its own summary statistics; `io_mcap.rs`
/// counts them independently of the reader).
const ODOM_MESSAGES: u64 = 2639;

fn turnprint(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_turnprint"))
        .args(args)
        .output()
        .expect("turnprint runs")
}

#[test]
fn loops_and_stream_read_every_odometry_message_of_the_topic() {
    let Some(bag) = common::data(BAG) else { return };
    let out = turnprint(&["loops", &bag, "--topic", "/odom", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert!(v["loops"].is_array(), "{v}");
    // The stream's summary counts the poses it was given: all of them.
    let out = turnprint(&["stream", &bag, "--topic", "/odom", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let summary: serde_json::Value = text
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .find(|e| e["event"] == "summary")
        .expect("a summary line");
    assert_eq!(summary["poses"].as_u64(), Some(ODOM_MESSAGES), "{summary}");
}

#[test]
fn a_missing_topic_is_an_error_naming_the_topics_present() {
    let Some(bag) = common::data(BAG) else { return };
    let out = turnprint(&["loops", &bag, "--topic", "/nope", "--json"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nope") && err.contains("/odom"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // Two pose topics and none chosen: the error asks for one.
    let out = turnprint(&["loops", &bag, "--json"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/odom") && err.contains("/amcl_pose"), "{err}");
}

#[test]
fn the_topic_applies_to_the_bag_and_leaves_a_text_file_as_it_is() {
    let Some(bag) = common::data(BAG) else { return };
    let dir = tempfile::tempdir().unwrap();
    // The bag's odometry as TUM, read back beside the bag.
    let tum = dir.path().join("odom.tum");
    let out = turnprint(&[
        "merge",
        &bag,
        &bag,
        "--topic",
        "/odom",
        "-o",
        tum.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = turnprint(&[
        "match",
        &bag,
        tum.to_str().unwrap(),
        "--topic",
        "/odom",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
