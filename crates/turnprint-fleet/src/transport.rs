//! The Zenoh side: a peer session with the given endpoints, the robot's
//! payloads published under `turnprint/<fleet>/<robot>/data`, every other
//! robot's received there, and the robot's history (its newest chunks, up
//! to [`STORE_BUDGET`]) served under `turnprint/<fleet>/<robot>/history`
//! for late joiners and for robots that missed a chunk. With verification,
//! the robot's keyframes are served under
//! `turnprint/<fleet>/<robot>/keyframes/<pose>` ([`crate::keyframe`]).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam::channel::Sender;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::query::{ConsolidationMode, QueryTarget, Queryable};
use zenoh::{Session, Wait};

use crate::payload::encode_status;

/// How long a catch-up query waits for its replies: far above a loopback
/// or LAN round trip, short enough that a robot gone silent does not hold
/// the query open for long.
const QUERY_TIMEOUT: Duration = Duration::from_secs(5);

/// How long a keyframe fetch waits for its answer: a rendered or stored
/// image is a few hundred kilobytes, milliseconds on a LAN; a robot that
/// does not answer within this is taken for gone and the candidate
/// expires.
pub const KEYFRAME_TIMEOUT: Duration = Duration::from_secs(3);

/// What serves a robot's keyframes: the encoded keyframe nearest a pose
/// index, `None` when it has none there.
pub type KeyframeSource = Arc<dyn Fn(u64) -> Option<Vec<u8>> + Send + Sync>;

/// Bytes of published chunks a robot keeps to serve: past them the oldest
/// are dropped, and the status tells receivers where the served history
/// starts. A quarter of [`crate::history::HISTORY_BUDGET`]: chunks take
/// 14-28 B a pose on the wire (22.4 kB per km of KITTI at about a pose a
/// metre) against the 80-160 B a pose takes in a receiver's rebuilt
/// history, so a robot catching up gets at least as much of the path as
/// its own budget would hold.
pub const STORE_BUDGET: usize = crate::history::HISTORY_BUDGET / 4;

/// The chunks a robot serves, the newest within a budget.
#[derive(Debug)]
struct Store {
    /// The session, once its first status is out.
    epoch: Option<u64>,
    /// Sequence number of the first chunk held (the older were dropped).
    first: u32,
    chunks: VecDeque<Vec<u8>>,
    bytes: usize,
    budget: usize,
}

impl Store {
    fn push(&mut self, payload: Vec<u8>) {
        self.bytes += payload.len();
        self.chunks.push_back(payload);
        // The newest chunk stays whatever its size: a receiver needs the
        // last one to be told where the robot is.
        while self.bytes > self.budget && self.chunks.len() > 1 {
            if let Some(old) = self.chunks.pop_front() {
                self.bytes -= old.len();
                self.first += 1;
            }
        }
    }

    /// Chunks published so far.
    fn published(&self) -> u32 {
        self.first + self.chunks.len() as u32
    }

    /// The status payload, once the session is known.
    fn status(&self) -> Option<Vec<u8>> {
        self.epoch
            .map(|e| encode_status(e, self.published(), self.first))
    }
}
/// A payload received from another robot.
#[derive(Debug)]
pub struct Incoming {
    /// The robot's name, from the key expression.
    pub robot: String,
    /// The payload.
    pub bytes: Vec<u8>,
}

/// Where a robot listens and whom it connects to.
#[derive(Debug, Clone, Default)]
pub struct Endpoints {
    /// Zenoh endpoints to listen on (`tcp/127.0.0.1:7447`).
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to.
    pub connect: Vec<String>,
}

/// Bytes this robot has sent.
#[derive(Debug, Default)]
pub struct Sent {
    /// Payload bytes published.
    pub published: AtomicU64,
    /// Payloads published.
    pub messages: AtomicU64,
    /// Payload bytes sent in answer to catch-up queries.
    pub replied: AtomicU64,
    /// Catch-up queries answered.
    pub queries: AtomicU64,
    /// Keyframes served to other robots.
    pub keyframes: AtomicU64,
    /// Payload bytes of the keyframes served.
    pub keyframe_bytes: AtomicU64,
}

/// A robot's Zenoh session.
pub struct Transport {
    session: Session,
    fleet: String,
    publisher: Publisher<'static>,
    _subscriber: Subscriber<()>,
    _queryable: Queryable<()>,
    /// The keyframe queryable, once serving.
    keyframes: Mutex<Option<Queryable<()>>>,
    robot: String,
    /// The newest chunks published (the history served to others).
    store: Arc<Mutex<Store>>,
    /// Where received payloads go.
    incoming: Sender<Incoming>,
    /// Bytes sent.
    pub sent: Arc<Sent>,
}

/// The robot's name from a key `turnprint/<fleet>/<robot>/...`.
fn robot_of(key: &str) -> Option<String> {
    key.split('/').nth(2).map(str::to_string)
}

impl Transport {
    /// Opens the session of robot `robot` in fleet `fleet`: received
    /// payloads of other robots are sent to `incoming`.
    pub fn open(
        fleet: &str,
        robot: &str,
        endpoints: &Endpoints,
        incoming: Sender<Incoming>,
    ) -> Result<Transport, String> {
        let mut config = zenoh::Config::default();
        let set = |config: &mut zenoh::Config, key: &str, value: String| {
            config
                .insert_json5(key, &value)
                .map_err(|e| format!("zenoh configuration {key} = {value}: {e}"))
        };
        set(&mut config, "mode", "\"peer\"".into())?;
        let list = |v: &[String]| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
        if !endpoints.listen.is_empty() || !endpoints.connect.is_empty() {
            // Named endpoints: no multicast scouting (a fleet on one host
            // would otherwise also find every other fleet's robots).
            set(&mut config, "scouting/multicast/enabled", "false".into())?;
            set(&mut config, "listen/endpoints", list(&endpoints.listen))?;
            set(&mut config, "connect/endpoints", list(&endpoints.connect))?;
        }
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| format!("opening the zenoh session: {e}"))?;
        let key = format!("turnprint/{fleet}/{robot}/data");
        let publisher = session
            .declare_publisher(key)
            .congestion_control(CongestionControl::Block)
            .wait()
            .map_err(|e| format!("declaring the publisher: {e}"))?;
        let tx = incoming.clone();
        let me = robot.to_string();
        let subscriber = session
            .declare_subscriber(format!("turnprint/{fleet}/*/data"))
            .callback(move |sample| {
                let Some(robot) = robot_of(sample.key_expr().as_str()) else {
                    return;
                };
                if robot != me {
                    let bytes = sample.payload().to_bytes().into_owned();
                    let _ = tx.send(Incoming { robot, bytes });
                }
            })
            .wait()
            .map_err(|e| format!("declaring the subscriber: {e}"))?;
        let store = Arc::new(Mutex::new(Store {
            epoch: None,
            first: 0,
            chunks: VecDeque::new(),
            bytes: 0,
            budget: STORE_BUDGET,
        }));
        let sent = Arc::new(Sent::default());
        let (served, sent_q) = (store.clone(), sent.clone());
        let history_key = format!("turnprint/{fleet}/{robot}/history");
        let reply_key = history_key.clone();
        let queryable = session
            .declare_queryable(history_key)
            .callback(move |query| {
                // The status first, so that the receiver knows where the
                // served history starts before its chunks arrive.
                let all: Vec<Vec<u8>> = served
                    .lock()
                    .map(|s| {
                        s.status()
                            .into_iter()
                            .chain(s.chunks.iter().cloned())
                            .collect()
                    })
                    .unwrap_or_default();
                sent_q.queries.fetch_add(1, Ordering::Relaxed);
                for p in all {
                    sent_q.replied.fetch_add(p.len() as u64, Ordering::Relaxed);
                    let _ = query.reply(reply_key.as_str(), p).wait();
                }
            })
            .wait()
            .map_err(|e| format!("declaring the history queryable: {e}"))?;
        Ok(Transport {
            session,
            fleet: fleet.to_string(),
            publisher,
            _subscriber: subscriber,
            _queryable: queryable,
            keyframes: Mutex::new(None),
            robot: robot.to_string(),
            store,
            incoming,
            sent,
        })
    }

    /// Publishes a chunk (its payload), and keeps it in the served history.
    pub fn publish_chunk(&self, payload: Vec<u8>) -> Result<(), String> {
        if let Ok(mut s) = self.store.lock() {
            s.push(payload.clone());
        }
        self.publish(payload)
    }

    /// Publishes the status of session `epoch`: the chunks published and
    /// the first still served.
    pub fn publish_status(&self, epoch: u64) -> Result<(), String> {
        let status = match self.store.lock() {
            Ok(mut s) => {
                s.epoch = Some(epoch);
                s.status()
            }
            Err(_) => None,
        };
        self.publish(status.ok_or("the served history's lock was poisoned")?)
    }

    /// Publishes any payload as this robot (a test's garbage included).
    pub fn publish(&self, payload: Vec<u8>) -> Result<(), String> {
        self.sent
            .published
            .fetch_add(payload.len() as u64, Ordering::Relaxed);
        self.sent.messages.fetch_add(1, Ordering::Relaxed);
        self.publisher
            .put(payload)
            .wait()
            .map_err(|e| format!("publishing: {e}"))
    }

    /// Asks `robot` (or every robot, `*`) for its history (its status,
    /// then the chunks it serves); the replies arrive as received payloads.
    pub fn catch_up(&self, robot: &str) {
        let tx = self.incoming.clone();
        let _ = self
            .session
            .get(format!("turnprint/{}/{robot}/history", self.fleet))
            .target(QueryTarget::All)
            .consolidation(ConsolidationMode::None)
            .timeout(QUERY_TIMEOUT)
            .callback(move |reply| {
                let Ok(sample) = reply.result() else {
                    return;
                };
                if let Some(robot) = robot_of(sample.key_expr().as_str()) {
                    let bytes = sample.payload().to_bytes().into_owned();
                    let _ = tx.send(Incoming { robot, bytes });
                }
            })
            .wait();
    }

    /// Serves this robot's keyframes from `source` under
    /// `turnprint/<fleet>/<robot>/keyframes/<pose>`.
    pub fn serve_keyframes(&self, source: KeyframeSource) -> Result<(), String> {
        let sent = self.sent.clone();
        let queryable = self
            .session
            .declare_queryable(format!(
                "turnprint/{}/{}/keyframes/*",
                self.fleet, self.robot
            ))
            .callback(move |query| {
                let key = query.key_expr().as_str().to_string();
                let Some(pose) = key.rsplit('/').next().and_then(|p| p.parse::<u64>().ok()) else {
                    return;
                };
                if let Some(bytes) = source(pose) {
                    sent.keyframes.fetch_add(1, Ordering::Relaxed);
                    sent.keyframe_bytes
                        .fetch_add(bytes.len() as u64, Ordering::Relaxed);
                    let _ = query.reply(key.as_str(), bytes).wait();
                }
            })
            .wait()
            .map_err(|e| format!("declaring the keyframe queryable: {e}"))?;
        if let Ok(mut k) = self.keyframes.lock() {
            *k = Some(queryable);
        }
        Ok(())
    }

    /// Asks `robot` for its keyframe nearest pose `pose` and waits for the
    /// answer (at most [`KEYFRAME_TIMEOUT`]): the payload, or why there is
    /// none.
    pub fn fetch_keyframe(&self, robot: &str, pose: u64) -> Result<Vec<u8>, String> {
        let replies = self
            .session
            .get(format!("turnprint/{}/{robot}/keyframes/{pose}", self.fleet))
            .target(QueryTarget::All)
            .timeout(KEYFRAME_TIMEOUT)
            .wait()
            .map_err(|e| format!("asking {robot} for keyframe {pose}: {e}"))?;
        match replies.recv() {
            Ok(reply) => match reply.result() {
                Ok(sample) => Ok(sample.payload().to_bytes().into_owned()),
                Err(e) => Err(format!(
                    "{robot} answered keyframe {pose} with an error: {}",
                    e.payload().try_to_string().unwrap_or_default()
                )),
            },
            Err(_) => Err(format!(
                "{robot} served no keyframe {pose} within {} s",
                KEYFRAME_TIMEOUT.as_secs()
            )),
        }
    }

    /// Bytes of the history served to others (the newest chunks, within
    /// the store's budget).
    pub fn stored_bytes(&self) -> usize {
        self.store.lock().map(|s| s.bytes).unwrap_or(0)
    }

    /// Chunks published so far (served or dropped from the store).
    pub fn chunks_published(&self) -> u32 {
        self.store.lock().map(|s| s.published()).unwrap_or(0)
    }

    /// Keeps at most `bytes` of published chunks to serve
    /// ([`STORE_BUDGET`] unless set).
    pub fn set_store_budget(&self, bytes: usize) {
        if let Ok(mut s) = self.store.lock() {
            s.budget = bytes;
        }
    }
}
