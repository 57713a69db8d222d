//! Live map merging between robots over Zenoh.
//!
//! Each robot runs turnprint's online detector on its own path and
//! publishes every hand-over of finalised samples (track, signature,
//! segment boundaries: [`payload`]) under `turnprint/<fleet>/<robot>/`.
//! Each robot rebuilds the others' histories from those chunks
//! ([`history`]), matches its new segments against them and theirs against
//! its own with the library's search ([`fleet`]), and keeps the best
//! estimate of where every robot lies in its own frame. A robot that joins
//! late, or misses a chunk, asks the others for their whole history
//! ([`transport`]); a restarted robot's old session is dropped. With
//! verification, each robot serves its keyframes on request and fetches
//! the other robot's for each cross-robot candidate ([`verify`]).
//!
//! - [`payload`]: the versioned wire form, and why a payload is refused;
//! - [`keyframe`]: a keyframe's wire form (served on request only);
//! - [`history`]: chunks cut from a detector, histories rebuilt from them;
//! - [`fleet`]: matching, candidates and estimates (no transport);
//! - [`transport`]: the Zenoh session, publisher, subscriber, queryables;
//! - [`verify`]: cross-robot candidates verified on both robots' keyframes;
//! - [`run`]: `turnprint stream --fleet`.
#![deny(missing_docs)]

pub mod fixture;
pub mod fleet;
pub mod history;
pub mod keyframe;
pub mod payload;
pub mod run;
pub mod transport;
pub mod verify;

pub use fleet::{CrossCandidate, Estimate, Fleet, Received, Refused};
pub use run::{stream, stream_verified, Options, StreamError};
pub use transport::Endpoints;

/// Longest fleet or robot name.
const MAX_NAME: usize = 64;

/// Whether `name` may name a fleet or a robot: one chunk of a key
/// expression, with none of its special characters (`/`, `*`, `$`, `?`,
/// `#`), 1 to 64 letters, digits, `-`, `_` or `.`.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_NAME
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
}
