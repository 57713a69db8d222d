//! The Zenoh side: a peer session with the given endpoints, the robot's
//! payloads published under `turnprint/<fleet>/<robot>/data`, every other
//! robot's received there, and the robot's whole history served under
//! `turnprint/<fleet>/<robot>/history` for late joiners and for robots
//! that missed a chunk.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam::channel::Sender;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::query::{ConsolidationMode, QueryTarget, Queryable};
use zenoh::{Session, Wait};

/// How long a catch-up query waits for its replies: far above a loopback
/// or LAN round trip, short enough that a robot gone silent does not hold
/// the query open for long.
const QUERY_TIMEOUT: Duration = Duration::from_secs(5);

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
}

/// A robot's Zenoh session.
pub struct Transport {
    session: Session,
    fleet: String,
    publisher: Publisher<'static>,
    _subscriber: Subscriber<()>,
    _queryable: Queryable<()>,
    /// Every payload published so far (the history served to others).
    store: Arc<Mutex<Vec<Vec<u8>>>>,
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
        let store: Arc<Mutex<Vec<Vec<u8>>>> = Arc::default();
        let sent = Arc::new(Sent::default());
        let (served, sent_q) = (store.clone(), sent.clone());
        let history_key = format!("turnprint/{fleet}/{robot}/history");
        let reply_key = history_key.clone();
        let queryable = session
            .declare_queryable(history_key)
            .callback(move |query| {
                let all = served.lock().map(|s| s.clone()).unwrap_or_default();
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
            store,
            incoming,
            sent,
        })
    }

    /// Publishes a payload; `keep` stores it in the served history (chunks
    /// are kept, status messages are not).
    pub fn publish(&self, payload: Vec<u8>, keep: bool) -> Result<(), String> {
        self.sent
            .published
            .fetch_add(payload.len() as u64, Ordering::Relaxed);
        self.sent.messages.fetch_add(1, Ordering::Relaxed);
        if keep {
            if let Ok(mut s) = self.store.lock() {
                s.push(payload.clone());
            }
        }
        self.publisher
            .put(payload)
            .wait()
            .map_err(|e| format!("publishing: {e}"))
    }

    /// Asks `robot` (or every robot, `*`) for its whole history; the
    /// replies arrive as received payloads.
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

    /// Bytes of the history served to others (all chunks published).
    pub fn stored_bytes(&self) -> usize {
        self.store
            .lock()
            .map(|s| s.iter().map(Vec::len).sum())
            .unwrap_or(0)
    }
}
