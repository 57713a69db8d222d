//! Names and layouts of the iceoryx2 services shared by the detector's
//! [`VerifierClient`](super::client::VerifierClient) and the verifier process.
//!
//! All live under `turnprint/<prefix>/`, so several detector/verifier pairs
//! (or parallel tests) never meet:
//!
//! | service | pattern | from -> to | payload |
//! |---|---|---|---|
//! | `keyframes` | publish-subscribe | detector -> verifier | `[u8]` image, [`KeyframeHeader`] user header |
//! | `candidates` | publish-subscribe | detector -> verifier | [`CandidateMsg`] |
//! | `verdicts` | publish-subscribe | verifier -> detector | [`VerdictMsg`] |
//! | `status` | publish-subscribe | verifier -> detector | [`VerifierStatus`] (heartbeat, statistics) |
//! | `to_verifier` | event | detector -> verifier | wakes the verifier's WaitSet |
//! | `to_client` | event | verifier -> detector | wakes a waiting client |
//!
//! Both sides open the services with the same settings (whoever comes first
//! creates them), so the layouts below are constants, not options.

use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe};

use super::payload::{CandidateMsg, KeyframeHeader, VerdictMsg, VerifierStatus};
use super::IpcError;

/// Keyframes the verifier's queue holds; a flood overwrites the oldest
/// unread ones (safe overflow) and the verifier counts the gaps.
pub const KEYFRAME_QUEUE: usize = 4;
/// Candidates waiting in the verifier's queue before the oldest is overwritten
/// (such a candidate then expires on the client by timeout).
pub const CANDIDATE_QUEUE: usize = 512;
/// Verdicts waiting in a client's queue.
pub const VERDICT_QUEUE: usize = 512;
/// Status messages waiting in a client's queue (only the newest matters).
pub const STATUS_QUEUE: usize = 4;
/// Ports per service: a live pair plus room for dead ones not yet cleaned up.
const MAX_PORTS: usize = 4;
/// Nodes per service, same reason.
const MAX_NODES: usize = 16;

/// Full iceoryx2 service names under one prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceNames {
    /// The prefix these names were made from.
    pub prefix: String,
    /// Keyframe images in.
    pub keyframes: String,
    /// Candidates in.
    pub candidates: String,
    /// Verdicts out.
    pub verdicts: String,
    /// Heartbeat and statistics out.
    pub status: String,
    /// Event: detector has sent something.
    pub to_verifier: String,
    /// Event: verifier has sent something.
    pub to_client: String,
}

impl ServiceNames {
    /// Names under `turnprint/<prefix>/`; the prefix may use letters, digits,
    /// `-`, `_`, `.` and `/`.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        let ok = !prefix.is_empty()
            && prefix.len() <= 128
            && prefix
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_./".contains(c));
        if !ok {
            return Err(IpcError(format!(
                "bad service prefix {prefix:?}: use 1-128 of [A-Za-z0-9-_./]"
            )));
        }
        let base = format!("turnprint/{prefix}");
        Ok(Self {
            prefix: prefix.to_string(),
            keyframes: format!("{base}/keyframes"),
            candidates: format!("{base}/candidates"),
            verdicts: format!("{base}/verdicts"),
            status: format!("{base}/status"),
            to_verifier: format!("{base}/to_verifier"),
            to_client: format!("{base}/to_client"),
        })
    }
}

fn service_name(name: &str) -> Result<ServiceName, IpcError> {
    ServiceName::new(name).map_err(|e| IpcError(format!("service name {name:?}: {e:?}")))
}

/// Opens or creates the keyframe service.
pub fn keyframes<S: Service>(
    node: &Node<S>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<S, [u8], KeyframeHeader>, IpcError> {
    node.service_builder(&service_name(&names.keyframes)?)
        .publish_subscribe::<[u8]>()
        .user_header::<KeyframeHeader>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(KEYFRAME_QUEUE)
        .subscriber_max_borrowed_samples(2)
        .history_size(0)
        .max_publishers(MAX_PORTS)
        .max_subscribers(MAX_PORTS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| IpcError(format!("{}: {e:?}", names.keyframes)))
}

/// Opens or creates a publish-subscribe service of fixed-size messages.
fn messages<S: Service, T: std::fmt::Debug + ZeroCopySend>(
    node: &Node<S>,
    name: &str,
    queue: usize,
) -> Result<publish_subscribe::PortFactory<S, T, ()>, IpcError> {
    node.service_builder(&service_name(name)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(queue)
        .subscriber_max_borrowed_samples(2)
        .history_size(0)
        .max_publishers(MAX_PORTS)
        .max_subscribers(MAX_PORTS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| IpcError(format!("{name}: {e:?}")))
}

/// Opens or creates the candidate service.
pub fn candidates<S: Service>(
    node: &Node<S>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<S, CandidateMsg, ()>, IpcError> {
    messages(node, &names.candidates, CANDIDATE_QUEUE)
}

/// Opens or creates the verdict service.
pub fn verdicts<S: Service>(
    node: &Node<S>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<S, VerdictMsg, ()>, IpcError> {
    messages(node, &names.verdicts, VERDICT_QUEUE)
}

/// Opens or creates the status (heartbeat) service.
pub fn status<S: Service>(
    node: &Node<S>,
    names: &ServiceNames,
) -> Result<publish_subscribe::PortFactory<S, VerifierStatus, ()>, IpcError> {
    messages(node, &names.status, STATUS_QUEUE)
}

/// Opens or creates one of the two wake-up event services.
pub fn event<S: Service>(node: &Node<S>, name: &str) -> Result<event::PortFactory<S>, IpcError> {
    node.service_builder(&service_name(name)?)
        .event()
        .max_notifiers(MAX_PORTS)
        .max_listeners(MAX_PORTS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| IpcError(format!("{name}: {e:?}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_live_under_the_prefix() {
        let n = ServiceNames::new("robot-7/run_2").unwrap();
        assert_eq!(n.keyframes, "turnprint/robot-7/run_2/keyframes");
        assert_eq!(n.to_client, "turnprint/robot-7/run_2/to_client");
    }

    #[test]
    fn bad_prefix_is_an_error() {
        assert!(ServiceNames::new("").is_err());
        assert!(ServiceNames::new("a b").is_err());
    }
}
