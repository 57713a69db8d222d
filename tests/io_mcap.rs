//! ROS 2 bags in MCAP: evo's real `nav2_turtlebot.mcap` (its `/odom`), bags
//! written here with the `mcap` crate and hand-encoded CDR messages, and
//! damaged bags, which must give errors, never panics.
#![cfg(feature = "mcap")]

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use ::mcap::records::MessageHeader;
use ::mcap::{Compression, Summary, WriteOptions};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use proptest::prelude::*;
use turnprint::io::{
    detect_format, parse_trajectory, read_mcap_bytes, read_trajectory, read_trajectory_from_topic,
    read_trajectory_topic, Format,
};
use turnprint::Pose;

const BAG: &str = "evo/nav2_turtlebot.mcap";

/// evo's bag where the real data is (`scripts/fetch_data.sh` fetches it
/// into `target/data`); absent: `None` with a message, or a failure under
/// CI, which must have it.
fn real_bag() -> Option<PathBuf> {
    turnprint_eval::data::require(BAG)
}

/// The number of messages on `topic`, from the bag's summary statistics.
fn messages_on(bytes: &[u8], topic: &str) -> u64 {
    let summary = Summary::read(bytes)
        .expect("a readable summary")
        .expect("the bag has a summary");
    let stats = summary.stats.expect("the summary has statistics");
    summary
        .channels
        .values()
        .filter(|c| c.topic == topic)
        .map(|c| {
            stats
                .channel_message_counts
                .get(&c.id)
                .copied()
                .unwrap_or(0)
        })
        .sum()
}

#[test]
fn evo_bag_odom_has_one_pose_per_message() {
    let Some(path) = real_bag() else { return };
    let bytes = std::fs::read(&path).unwrap();
    let expected = messages_on(&bytes, "/odom");
    assert!(expected > 100, "{expected} /odom messages");
    for format in [Format::Auto, Format::Mcap] {
        let traj = read_trajectory_topic(&path, format, Some("/odom")).unwrap();
        assert_eq!(traj.len() as u64, expected);
        let times: Vec<f64> = traj.poses.iter().map(|p| p.t.unwrap()).collect();
        assert!(times.windows(2).all(|w| w[1] > w[0]), "times increase");
        // Simulation time: about a minute and a half, from 900 s or so.
        let duration = times[times.len() - 1] - times[0];
        assert!(
            times[0] > 0.0 && (30.0..1000.0).contains(&duration),
            "{times:?}"
        );
        for pose in &traj.poses {
            assert!(pose.position.iter().all(|v| v.is_finite()));
            assert!(pose.orientation.is_some());
        }
        // The robot moves.
        let span = traj
            .poses
            .iter()
            .map(|p| p.position)
            .fold(0.0f64, |m, p| m.max((p - traj.poses[0].position).norm()));
        assert!(span > 0.5, "span {span} m");
    }
}

#[test]
fn evo_bag_topic_errors_name_the_topics() {
    let Some(path) = real_bag() else { return };
    let err = read_trajectory_topic(&path, Format::Auto, Some("/nope"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("'/nope'"), "{err}");
    assert!(err.contains("/odom (nav_msgs/msg/Odometry"), "{err}");
    // Two pose topics (odometry and AMCL): no topic is no choice.
    let err = read_trajectory(&path, Format::Auto)
        .unwrap_err()
        .to_string();
    assert!(err.contains("/odom") && err.contains("/amcl_pose"), "{err}");
    assert!(err.contains("--topic"), "{err}");
    // A topic that is there but holds no poses.
    let err = read_trajectory_topic(&path, Format::Auto, Some("/tf_static"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("readable types"), "{err}");
}

#[test]
fn evo_bag_cut_short_is_an_error() {
    let Some(path) = real_bag() else { return };
    let bytes = std::fs::read(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let cut_path = dir.path().join("cut.mcap");
    let n = bytes.len();
    for cut in [0, 7, 8, 100, n / 4, n / 2, 3 * n / 4, n - 100, n - 9, n - 1] {
        std::fs::write(&cut_path, &bytes[..cut]).unwrap();
        let result = read_trajectory_topic(&cut_path, Format::Auto, Some("/odom"));
        let err = result.expect_err(&format!("cut at {cut} of {n}"));
        assert!(err.to_string().contains("cut.mcap"), "{err}");
    }
}

/// A little-endian or big-endian plain CDR message, written field by field.
struct Cdr {
    buf: Vec<u8>,
    big: bool,
}

impl Cdr {
    fn new(big: bool) -> Self {
        Cdr {
            buf: vec![0, if big { 0 } else { 1 }, 0, 0],
            big,
        }
    }
    /// Pads to `n` bytes, counted from the end of the 4-byte header.
    fn align(&mut self, n: usize) {
        while !(self.buf.len() - 4).is_multiple_of(n) {
            self.buf.push(0);
        }
    }
    fn u32(&mut self, v: u32) {
        self.align(4);
        let b = if self.big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        self.buf.extend(b);
    }
    fn f64(&mut self, v: f64) {
        self.align(8);
        let b = if self.big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        self.buf.extend(b);
    }
    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend(s.as_bytes());
        self.buf.push(0);
    }
    fn header(&mut self, sec: i32, nanosec: u32, frame: &str) {
        self.u32(sec as u32);
        self.u32(nanosec);
        self.string(frame);
    }
    fn pose(&mut self, p: &[f64; 7]) {
        for v in p {
            self.f64(*v);
        }
    }
}

/// `(sec, nanosec, [x y z qx qy qz qw])` of the messages written.
type Stamped = (i32, u32, [f64; 7]);

fn pose_stamped(m: &Stamped, big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    c.header(m.0, m.1, "map");
    c.pose(&m.2);
    c.buf
}

fn pose_with_covariance_stamped(m: &Stamped, big: bool) -> Vec<u8> {
    let mut c = Cdr::new(big);
    c.header(m.0, m.1, "map");
    c.pose(&m.2);
    for i in 0..36 {
        c.f64(if i % 7 == 0 { 0.25 } else { 0.0 });
    }
    c.buf
}

fn odometry(m: &Stamped) -> Vec<u8> {
    let mut c = Cdr::new(false);
    c.header(m.0, m.1, "odom");
    c.string("base_link");
    c.pose(&m.2);
    for _ in 0..(36 + 6 + 36) {
        c.f64(0.5);
    }
    c.buf
}

/// Poses along a curve, with turning orientations and odd stamps.
fn messages(n: usize, sec0: i32) -> Vec<Stamped> {
    (0..n)
        .map(|i| {
            let a = i as f64 * 0.1;
            let q = UnitQuaternion::from_euler_angles(0.01 * a, -0.02, a);
            let nanosec = ((i as u64 * 123_456_789) % 1_000_000_000) as u32;
            (
                sec0 + i as i32,
                nanosec,
                [a.cos() * 3.0, a.sin() * 2.0, 0.1 * a, q.i, q.j, q.k, q.w],
            )
        })
        .collect()
}

/// The poses a reader must give for `msgs`.
fn expected(msgs: &[Stamped]) -> Vec<Pose> {
    msgs.iter()
        .map(|(sec, nanosec, p)| Pose {
            t: Some(f64::from(*sec) + f64::from(*nanosec) * 1e-9),
            position: Vector3::new(p[0], p[1], p[2]),
            orientation: Some(UnitQuaternion::new_normalize(Quaternion::new(
                p[6], p[3], p[4], p[5],
            ))),
        })
        .collect()
}

/// One channel to write: topic, schema name, message encoding, messages.
struct Topic {
    topic: &'static str,
    schema: &'static str,
    encoding: &'static str,
    messages: Vec<Vec<u8>>,
}

/// A bag of `topics`, their messages interleaved, in chunks compressed by
/// `compression`, or without chunks.
fn write_bag(topics: &[Topic], chunks: Option<Option<Compression>>) -> Vec<u8> {
    let options = match chunks {
        Some(compression) => WriteOptions::new()
            .compression(compression)
            .chunk_size(Some(2048)),
        None => WriteOptions::new().use_chunks(false),
    };
    let mut writer = options.create(Cursor::new(Vec::new())).unwrap();
    let mut ids = Vec::new();
    for t in topics {
        let schema = writer
            .add_schema(t.schema, "ros2msg", b"# written by the test\n")
            .unwrap();
        ids.push(
            writer
                .add_channel(schema, t.topic, t.encoding, &BTreeMap::new())
                .unwrap(),
        );
    }
    let longest = topics.iter().map(|t| t.messages.len()).max().unwrap_or(0);
    let mut time = 1_000u64;
    for i in 0..longest {
        for (t, &channel_id) in topics.iter().zip(&ids) {
            if let Some(data) = t.messages.get(i) {
                time += 10;
                let header = MessageHeader {
                    channel_id,
                    sequence: i as u32,
                    log_time: time,
                    publish_time: time,
                };
                writer.write_to_known_channel(&header, data).unwrap();
            }
        }
    }
    writer.finish().unwrap();
    writer.into_inner().into_inner()
}

/// Two pose topics (one of them big-endian) and a topic of another type.
fn two_pose_topics() -> (Vec<Stamped>, Vec<Stamped>, Vec<Topic>) {
    let a = messages(57, 1_700_000_000);
    let b = messages(31, 1_700_000_100);
    let topics = vec![
        Topic {
            topic: "/pose",
            schema: "geometry_msgs/msg/PoseStamped",
            encoding: "cdr",
            messages: a.iter().map(|m| pose_stamped(m, false)).collect(),
        },
        Topic {
            topic: "/amcl_pose",
            schema: "geometry_msgs/msg/PoseWithCovarianceStamped",
            encoding: "cdr",
            messages: b
                .iter()
                .map(|m| pose_with_covariance_stamped(m, true))
                .collect(),
        },
        Topic {
            topic: "/chatter",
            schema: "std_msgs/msg/String",
            encoding: "cdr",
            messages: vec![vec![0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0]; 5],
        },
    ];
    (a, b, topics)
}

#[test]
fn a_written_bag_reads_back_exactly() {
    let (a, b, topics) = two_pose_topics();
    for chunks in [
        None,
        Some(None),
        Some(Some(Compression::Zstd)),
        Some(Some(Compression::Lz4)),
    ] {
        let bytes = write_bag(&topics, chunks);
        let traj = read_mcap_bytes(&bytes, Some("/pose")).unwrap();
        assert_eq!(traj.poses, expected(&a), "{chunks:?}");
        let traj = read_mcap_bytes(&bytes, Some("/amcl_pose")).unwrap();
        assert_eq!(traj.poses, expected(&b), "{chunks:?}");
    }
    // Stamps as seconds, to the nanosecond.
    let t = read_mcap_bytes(&write_bag(&topics, None), Some("/pose")).unwrap();
    assert!((t.poses[1].t.unwrap() - 1_700_000_001.123_456_8).abs() < 1e-6);
}

#[test]
fn a_written_bag_reads_from_a_file_and_from_a_stream() {
    let (a, _, topics) = two_pose_topics();
    let bytes = write_bag(&topics, Some(Some(Compression::Zstd)));
    let dir = tempfile::tempdir().unwrap();
    // By extension, and by content under any other name.
    for name in ["bag.mcap", "bag.BIN"] {
        let path = dir.path().join(name);
        std::fs::write(&path, &bytes).unwrap();
        let traj = read_trajectory_topic(&path, Format::Auto, Some("/pose")).unwrap();
        assert_eq!(traj.poses, expected(&a));
        assert_eq!(traj.source, path.display().to_string());
    }
    let traj = read_trajectory_from_topic(
        Cursor::new(&bytes),
        Path::new("<stdin>"),
        Format::Auto,
        Some("/pose"),
    )
    .unwrap();
    assert_eq!(traj.poses, expected(&a));
    assert_eq!(
        detect_format("", Path::new("x.MCAP")).unwrap(),
        Format::Mcap
    );
    assert_eq!("mcap".parse::<Format>().unwrap(), Format::Mcap);
}

#[test]
fn without_a_topic_the_only_pose_topic_is_read() {
    let (_, b, topics) = two_pose_topics();
    let bytes = write_bag(&topics, Some(Some(Compression::Zstd)));
    let err = read_mcap_bytes(&bytes, None).unwrap_err().to_string();
    assert!(
        err.contains("/pose (geometry_msgs/msg/PoseStamped, 57 messages)")
            && err
                .contains("/amcl_pose (geometry_msgs/msg/PoseWithCovarianceStamped, 31 messages)")
            && !err.contains("/chatter"),
        "{err}"
    );
    let mut topics = topics;
    topics.remove(0);
    let bytes = write_bag(&topics, None);
    assert_eq!(read_mcap_bytes(&bytes, None).unwrap().poses, expected(&b));
    // Odometry too.
    let c = messages(12, 5);
    let bytes = write_bag(
        &[Topic {
            topic: "/odom",
            schema: "nav_msgs/msg/Odometry",
            encoding: "cdr",
            messages: c.iter().map(odometry).collect(),
        }],
        Some(Some(Compression::Zstd)),
    );
    assert_eq!(read_mcap_bytes(&bytes, None).unwrap().poses, expected(&c));
}

#[test]
fn what_cannot_be_read_is_named() {
    let (_, _, topics) = two_pose_topics();
    let bytes = write_bag(&topics, None);
    let err = read_mcap_bytes(&bytes, Some("/odom"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("'/odom'"), "{err}");
    assert!(
        err.contains("/chatter (std_msgs/msg/String, 5 messages)"),
        "{err}"
    );
    let err = read_mcap_bytes(&bytes, Some("/chatter"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("std_msgs/msg/String") && err.contains("readable types"),
        "{err}"
    );

    // Not CDR.
    let json = write_bag(
        &[Topic {
            topic: "/pose",
            schema: "geometry_msgs/msg/PoseStamped",
            encoding: "json",
            messages: vec![b"{}".to_vec()],
        }],
        None,
    );
    let err = read_mcap_bytes(&json, None).unwrap_err().to_string();
    assert!(err.contains("'json'") && err.contains("cdr"), "{err}");

    // XCDR2, and a message cut short: the message is named.
    let m = messages(3, 0);
    let mut xcdr2 = pose_stamped(&m[1], false);
    xcdr2[1] = 0x07;
    let short = pose_stamped(&m[2], false)[..40].to_vec();
    for (bad, why) in [(xcdr2, "plain CDR"), (short, "not a valid CDR message")] {
        let bytes = write_bag(
            &[Topic {
                topic: "/pose",
                schema: "geometry_msgs/msg/PoseStamped",
                encoding: "cdr",
                messages: vec![pose_stamped(&m[0], false), bad],
            }],
            None,
        );
        let err = read_mcap_bytes(&bytes, None).unwrap_err().to_string();
        assert!(
            err.contains("topic /pose, message 2") && err.contains(why),
            "{err}"
        );
    }

    // No messages at all.
    let err = read_mcap_bytes(&write_bag(&[], None), None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("no messages"), "{err}");

    // Text formats have no topics; MCAP is not text.
    let dir = tempfile::tempdir().unwrap();
    let tum = dir.path().join("a.tum");
    std::fs::write(&tum, "0 1 2 3 0 0 0 1\n").unwrap();
    let err = read_trajectory_topic(&tum, Format::Auto, Some("/odom")).unwrap_err();
    assert!(
        err.to_string().contains("only MCAP bags have topics"),
        "{err}"
    );
    assert!(read_trajectory_topic(&tum, Format::Auto, None).is_ok());
    assert!(parse_trajectory("0 1 2 3 0 0 0 1\n", Format::Mcap, Path::new("a")).is_err());
    let err = read_trajectory(&tum, Format::Mcap).unwrap_err().to_string();
    assert!(err.contains("not an MCAP file"), "{err}");
}

/// A small zstd bag with both pose types, for the damage tests.
fn small_bag(compression: Option<Compression>) -> Vec<u8> {
    let (_, _, mut topics) = two_pose_topics();
    for t in &mut topics {
        t.messages.truncate(6);
    }
    write_bag(&topics, Some(compression))
}

#[test]
fn every_cut_of_a_written_bag_is_an_error() {
    for compression in [None, Some(Compression::Zstd)] {
        let bytes = small_bag(compression);
        assert!(read_mcap_bytes(&bytes, Some("/pose")).is_ok());
        for cut in 0..bytes.len() {
            assert!(
                read_mcap_bytes(&bytes[..cut], Some("/pose")).is_err(),
                "cut at {cut} of {}",
                bytes.len()
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn damaged_bags_never_panic(
        zstd in any::<bool>(),
        flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
    ) {
        let mut bytes = small_bag(zstd.then_some(Compression::Zstd));
        for (at, byte) in flips {
            let i = at.index(bytes.len());
            bytes[i] = byte;
        }
        for topic in [None, Some("/pose"), Some("/amcl_pose")] {
            if let Ok(traj) = read_mcap_bytes(&bytes, topic) {
                for pose in &traj.poses {
                    prop_assert!(pose.position.iter().all(|v| v.is_finite()));
                }
            }
        }
    }

    #[test]
    fn random_bytes_after_the_magic_never_panic(tail in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut bytes = b"\x89MCAP0\r\n".to_vec();
        bytes.extend(tail);
        let _ = read_mcap_bytes(&bytes, None);
    }
}
