//! ROS 2 bags in MCAP (`Format::Mcap`): the poses of one topic as a
//! [`Trajectory`].
//!
//! A bag holds many topics; a trajectory comes from one of them, of one of
//! the [`MCAP_POSE_TYPES`] (`nav_msgs/msg/Odometry`,
//! `geometry_msgs/msg/PoseStamped`,
//! `geometry_msgs/msg/PoseWithCovarianceStamped`), CDR-encoded as rosbag2
//! writes them. Each message gives one pose: the position and orientation of
//! its pose, timed by its header stamp in seconds, in the order the bag
//! stores them. Without a topic the bag must have exactly one topic of these
//! types.
//!
//! The whole file is read in one linear pass (chunked or not, zstd or lz4,
//! with or without a summary section), chunk CRCs checked. A file that does
//! not end with the closing magic bytes (cut short, or left by a recorder
//! that died) is an error, not a shorter path. Whatever the bytes, the
//! reader returns an error rather than panicking, no one record may claim
//! more than the larger of [`RECORD_LIMIT`] and four times the file's size,
//! and no field more than its record holds (`mcap_fields`).

use std::collections::BTreeMap;
use std::fmt;

use ::mcap::sans_io::{LinearReaderOptions, MessageReadEvent, MessageReader};
use ::mcap::{McapError, Message};
use byteorder::{BigEndian, ByteOrder, LittleEndian};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use super::MCAP_POSE_TYPES;
use crate::{Error, Pose, Result, Trajectory};

/// The size a record may always have, however small the file: a record
/// decompressed from a chunk may be larger than the whole file, but a
/// corrupt length must not make the reader allocate gigabytes.
pub const RECORD_LIMIT: usize = 256 << 20;

/// The source name of bags read from bytes alone.
const BYTES_SOURCE: &str = "<mcap>";

/// Reads the poses of `topic` (or of the only pose topic) from the MCAP
/// bag in `bytes`; messages name the bag `<mcap>`.
///
/// The entry point for fuzzing: any bytes give a trajectory or an error.
pub fn read_mcap_bytes(bytes: &[u8], topic: Option<&str>) -> Result<Trajectory> {
    read(bytes, topic, BYTES_SOURCE)
}

/// Reads the poses of `topic` (or of the only pose topic) from the MCAP bag
/// in `bytes`, named `source` in the trajectory and in messages.
pub(super) fn read(bytes: &[u8], topic: Option<&str>, source: &str) -> Result<Trajectory> {
    let fail = |message: String| Error::input(source, message);
    super::mcap_fields::check(bytes).map_err(|m| fail(format!("corrupt MCAP: {m}")))?;
    let mut bag = Bag::default();
    let mut reader = MessageReader::new_with_options(
        LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(RECORD_LIMIT.max(bytes.len().saturating_mul(4))),
    );
    let mut rest = bytes;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(MessageReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                reader.insert(n).copy_from_slice(&rest[..n]);
                reader.notify_read(n);
                rest = &rest[n..];
            }
            Ok(MessageReadEvent::Message(message)) => bag.add(&message, topic),
            Err(e) => return Err(fail(container_error(&e, bag.messages))),
        }
    }
    bag.trajectory(topic, source).map_err(fail)
}

/// What a read error of the container means, for a one-line message.
fn container_error(e: &McapError, messages_read: u64) -> String {
    match e {
        McapError::BadMagic if messages_read == 0 => {
            "not an MCAP file (it does not start with the MCAP magic bytes)".into()
        }
        McapError::UnexpectedEof => format!(
            "the MCAP file ends before its closing magic bytes, after {messages_read} messages (cut short?)"
        ),
        _ => format!("unreadable MCAP file after {messages_read} messages: {e}"),
    }
}

/// A topic of the bag, as its messages name it.
#[derive(Debug, Default)]
struct Topic {
    /// The schema name of its first channel (`nav_msgs/msg/Odometry`).
    message_type: String,
    /// Messages seen.
    messages: u64,
    /// The poses decoded so far, or why they cannot be: only for the topics
    /// that can give the trajectory.
    poses: Option<std::result::Result<Vec<Pose>, String>>,
}

/// The bag's topics, filled one message at a time.
#[derive(Debug, Default)]
struct Bag {
    topics: BTreeMap<String, Topic>,
    messages: u64,
}

impl Bag {
    /// Counts `message` and, when its topic is the one asked for (or, with
    /// no topic asked for, a pose topic), decodes it.
    fn add(&mut self, message: &Message<'_>, wanted: Option<&str>) {
        self.messages += 1;
        let channel = &message.channel;
        let message_type = channel.schema.as_ref().map(|s| s.name.as_str());
        let kind = message_type.and_then(Kind::of);
        let topic = self.topics.entry(channel.topic.clone()).or_default();
        if topic.messages == 0 {
            topic.message_type = message_type.unwrap_or("no schema").to_string();
        }
        topic.messages += 1;
        let decode = match wanted {
            Some(t) => t == channel.topic,
            None => kind.is_some(),
        };
        if !decode {
            return;
        }
        let poses = topic.poses.get_or_insert_with(|| Ok(Vec::new()));
        let Ok(list) = poses else { return };
        let index = topic.messages;
        let pose = match kind {
            None => Err(format!(
                "topic {} has messages of type {}; readable types: {}",
                channel.topic,
                message_type.unwrap_or("(none: no schema)"),
                MCAP_POSE_TYPES.join(", ")
            )),
            Some(_) if channel.message_encoding != "cdr" => Err(format!(
                "topic {} is encoded as '{}'; only ROS 2 CDR ('cdr') is readable",
                channel.topic, channel.message_encoding
            )),
            Some(kind) => decode_pose(kind, &message.data)
                .map_err(|e| format!("topic {}, message {index}: {e}", channel.topic)),
        };
        match pose {
            Ok(pose) => list.push(pose),
            Err(e) => *poses = Err(e),
        }
    }

    /// The trajectory of `wanted`, or of the only pose topic.
    fn trajectory(
        self,
        wanted: Option<&str>,
        source: &str,
    ) -> std::result::Result<Trajectory, String> {
        let name = match wanted {
            Some(t) => {
                if !self.topics.contains_key(t) {
                    return Err(format!(
                        "no messages on topic '{t}' in the bag; {}",
                        self.listing()
                    ));
                }
                t.to_string()
            }
            None => {
                let poses: Vec<&String> = self
                    .topics
                    .iter()
                    .filter(|(_, topic)| topic.poses.is_some())
                    .map(|(name, _)| name)
                    .collect();
                match poses.as_slice() {
                    [one] => one.to_string(),
                    [] => {
                        return Err(format!(
                            "no topic of a pose type ({}) in the bag; {}",
                            MCAP_POSE_TYPES.join(", "),
                            self.listing()
                        ))
                    }
                    _ => {
                        let named: Vec<String> = poses
                            .iter()
                            .map(|name| format!("{name} ({})", self.topics[*name]))
                            .collect();
                        return Err(format!(
                            "{} pose topics in the bag, choose one (--topic): {}",
                            named.len(),
                            named.join(", ")
                        ));
                    }
                }
            }
        };
        let mut topics = self.topics;
        let topic = topics.remove(&name).unwrap_or_default();
        let poses = topic
            .poses
            .unwrap_or_else(|| Err(format!("topic {name} was not decoded")))?;
        Ok(Trajectory {
            source: source.to_string(),
            poses,
        })
    }

    /// `its topics: /a (type, N messages), ...`, for error messages.
    fn listing(&self) -> String {
        if self.topics.is_empty() {
            return "the bag has no messages at all".into();
        }
        let named: Vec<String> = self
            .topics
            .iter()
            .map(|(name, topic)| format!("{name} ({topic})"))
            .collect();
        format!("its topics: {}", named.join(", "))
    }
}

impl fmt::Display for Topic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = if self.messages == 1 { "" } else { "s" };
        write!(f, "{}, {} message{s}", self.message_type, self.messages)
    }
}

/// The message types that hold a pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Odometry,
    PoseStamped,
    PoseWithCovarianceStamped,
}

impl Kind {
    /// The kind of the schema named `name`; the ROS 1 style name without
    /// `/msg/` is taken too, as some writers use it for ROS 2 messages.
    fn of(name: &str) -> Option<Kind> {
        match name {
            "nav_msgs/msg/Odometry" | "nav_msgs/Odometry" => Some(Kind::Odometry),
            "geometry_msgs/msg/PoseStamped" | "geometry_msgs/PoseStamped" => {
                Some(Kind::PoseStamped)
            }
            "geometry_msgs/msg/PoseWithCovarianceStamped"
            | "geometry_msgs/PoseWithCovarianceStamped" => Some(Kind::PoseWithCovarianceStamped),
            _ => None,
        }
    }
}

/// The pose in one CDR-encoded message of `kind`.
fn decode_pose(kind: Kind, data: &[u8]) -> std::result::Result<Pose, String> {
    let Some((header, body)) = data.split_first_chunk::<4>() else {
        return Err(format!("{} bytes, too short for a CDR message", data.len()));
    };
    // The encapsulation header's first two bytes name the representation;
    // alignment counts from the byte after the four header bytes.
    let (stamp, pose) = match [header[0], header[1]] {
        [0, 0] => stamped_pose::<BigEndian>(kind, body),
        [0, 1] => stamped_pose::<LittleEndian>(kind, body),
        [a, b] => {
            return Err(format!(
                "CDR representation {a:#04x}{b:02x} is not plain CDR (0x0000 or 0x0001); \
                 parameter lists and XCDR2 are not readable"
            ))
        }
    }
    .map_err(|e| format!("not a valid CDR message of its type: {e}"))?;
    let position = Vector3::new(pose.position.x, pose.position.y, pose.position.z);
    if !position.iter().all(|v| v.is_finite()) {
        return Err(format!(
            "position ({} {} {}) is not finite",
            position.x, position.y, position.z
        ));
    }
    let o = &pose.orientation;
    if ![o.x, o.y, o.z, o.w].iter().all(|v| v.is_finite()) {
        return Err(format!(
            "orientation ({} {} {} {}) is not finite",
            o.x, o.y, o.z, o.w
        ));
    }
    let q = Quaternion::new(o.w, o.x, o.y, o.z);
    // An all-zero quaternion is a field left unset (planners publishing bare
    // positions do that), not a column mix-up as it would be in a text file:
    // a pose without orientation.
    let orientation = (q.norm() >= 1e-6).then(|| UnitQuaternion::new_normalize(q));
    let t = f64::from(stamp.sec) + f64::from(stamp.nanosec) * 1e-9;
    Ok(Pose {
        t: Some(t),
        position,
        orientation,
    })
}

/// The header stamp and pose of a message of `kind`, in byte order `BO`.
fn stamped_pose<BO: ByteOrder>(
    kind: Kind,
    body: &[u8],
) -> std::result::Result<(Time, PoseMsg), cdr_encoding::Error> {
    Ok(match kind {
        Kind::Odometry => {
            let (m, _) = cdr_encoding::from_bytes::<Odometry, BO>(body)?;
            (m.header.stamp, m.pose.pose)
        }
        Kind::PoseStamped => {
            let (m, _) = cdr_encoding::from_bytes::<PoseStamped, BO>(body)?;
            (m.header.stamp, m.pose)
        }
        Kind::PoseWithCovarianceStamped => {
            let (m, _) = cdr_encoding::from_bytes::<PoseWithCovarianceStamped, BO>(body)?;
            (m.header.stamp, m.pose.pose)
        }
    })
}

// The message layouts, field for field as in their `.msg` definitions (CDR
// has no field names or lengths: every field must be there, in order).
// Fields the trajectory does not use are read and dropped, so that a
// message of another layout fails rather than gives a wrong pose.

/// `builtin_interfaces/msg/Time`.
#[derive(Deserialize)]
struct Time {
    sec: i32,
    nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Deserialize)]
struct Header {
    stamp: Time,
    _frame_id: Text,
}

/// `geometry_msgs/msg/Point`.
#[derive(Deserialize)]
struct Point {
    x: f64,
    y: f64,
    z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Deserialize)]
struct QuaternionMsg {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

/// `geometry_msgs/msg/Pose`.
#[derive(Deserialize)]
struct PoseMsg {
    position: Point,
    orientation: QuaternionMsg,
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Deserialize)]
struct PoseWithCovariance {
    pose: PoseMsg,
    _covariance: Doubles<36>,
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Deserialize)]
struct PoseStamped {
    header: Header,
    pose: PoseMsg,
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
#[derive(Deserialize)]
struct PoseWithCovarianceStamped {
    header: Header,
    pose: PoseWithCovariance,
}

/// `nav_msgs/msg/Odometry`; its twist with covariance
/// (`geometry_msgs/msg/TwistWithCovariance`: two `Vector3`s, then 36
/// doubles) is 42 doubles in a row.
#[derive(Deserialize)]
struct Odometry {
    header: Header,
    _child_frame_id: Text,
    pose: PoseWithCovariance,
    _twist: Doubles<42>,
}

/// A string read and dropped.
struct Text;

impl<'de> Deserialize<'de> for Text {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Text;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a string")
            }
            fn visit_str<E: de::Error>(self, _: &str) -> std::result::Result<Text, E> {
                Ok(Text)
            }
        }
        d.deserialize_str(V)
    }
}

/// `N` doubles of a fixed-size array, read and dropped (serde's own arrays
/// stop at 32).
struct Doubles<const N: usize>;

impl<'de, const N: usize> Deserialize<'de> for Doubles<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = Doubles<N>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "{N} doubles")
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Self::Value, A::Error> {
                for i in 0..N {
                    if seq.next_element::<f64>()?.is_none() {
                        return Err(de::Error::invalid_length(i, &self));
                    }
                }
                Ok(Doubles)
            }
        }
        d.deserialize_tuple(N, V::<N>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little-endian CDR `PoseStamped`: header, stamp, frame id, pose.
    fn pose_stamped(sec: i32, nanosec: u32, frame: &str, p: [f64; 7]) -> Vec<u8> {
        let mut b = vec![0, 1, 0, 0];
        b.extend(sec.to_le_bytes());
        b.extend(nanosec.to_le_bytes());
        b.extend((frame.len() as u32 + 1).to_le_bytes());
        b.extend(frame.as_bytes());
        b.push(0);
        while !(b.len() - 4).is_multiple_of(8) {
            b.push(0);
        }
        for v in p {
            b.extend(v.to_le_bytes());
        }
        b
    }

    #[test]
    fn a_pose_stamped_decodes() {
        let data = pose_stamped(3, 500_000_000, "map", [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]);
        let pose = decode_pose(Kind::PoseStamped, &data).unwrap();
        assert_eq!(pose.t, Some(3.5));
        assert_eq!(pose.position, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(pose.orientation, Some(UnitQuaternion::identity()));
    }

    #[test]
    fn bad_messages_are_errors() {
        let data = pose_stamped(0, 0, "map", [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]);
        for cut in 0..data.len() {
            assert!(
                decode_pose(Kind::PoseStamped, &data[..cut]).is_err(),
                "{cut}"
            );
        }
        // Too short for the covariance that follows the pose.
        assert!(decode_pose(Kind::PoseWithCovarianceStamped, &data).is_err());
        let mut xcdr2 = data.clone();
        xcdr2[1] = 7;
        let err = decode_pose(Kind::PoseStamped, &xcdr2).unwrap_err();
        assert!(err.contains("not plain CDR"), "{err}");
        let nan = pose_stamped(0, 0, "", [f64::NAN, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]);
        assert!(decode_pose(Kind::PoseStamped, &nan).is_err());
    }

    #[test]
    fn a_zero_quaternion_is_no_orientation() {
        let data = pose_stamped(0, 0, "", [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(
            decode_pose(Kind::PoseStamped, &data).unwrap().orientation,
            None
        );
    }

    #[test]
    fn not_mcap_is_an_error() {
        let err = read_mcap_bytes(b"0 1 2 3 0 0 0 1\n", None).unwrap_err();
        assert!(err.to_string().contains("not an MCAP file"), "{err}");
        // The eight bytes that start (and end) every MCAP file.
        assert!(read_mcap_bytes(b"\x89MCAP0\r\n", None).is_err());
        assert!(read_mcap_bytes(b"", None).is_err());
    }
}
