//! The online detector: poses arrive one at a time (a VO or SLAM loop), the
//! stages of the batch path are kept up to date incrementally, and every
//! newly finalised clothoid segment triggers a search of the last `N`
//! segments against the history on a worker thread.
//!
//! - [`frontend`]: guards, warm-up, incremental track/signature/segments
//!   (the batch stages' own streams);
//! - [`guard`]: out-of-order, duplicate and non-finite poses, jumps;
//! - [`history`]: the worker's compact history and its local windows;
//! - [`correlator`]: per-block spectra and per-segment cached correlations;
//! - [`search`]: queries, batch verification, emission and scoring;
//! - [`probe`]: the proximity probe (nearest earlier positions);
//! - [`register`]: the newest stretch placed on the whole road network (a
//!   drifting map's revisit entered and left by other roads);
//! - [`network`]: when the detector registers, and the candidate it grows;
//! - [`drift_path`]: the drift prior along the path between a revisit's
//!   passes (angle and offset as drift pairs them), which weighs
//!   placements and candidates;
//! - [`worker`]: the thread, the bounded queue and its overflow policy;
//! - [`events`]: candidates and verifier outcomes;
//! - `correction` (feature `correct`): the drift-corrected estimate, kept
//!   up to date on a thread of its own as loops arrive;
//! - [`detector`]: the public type;
//! - [`synthetic`]: a synthetic city drive for long-run figures.

pub mod config;
#[cfg(feature = "correct")]
pub mod correction;
pub mod correlator;
pub mod detector;
pub mod drift_path;
pub mod events;
pub mod frontend;
mod gate;
pub mod guard;
pub mod history;
pub mod network;
pub mod probe;
pub mod register;
pub mod scan;
pub mod search;
pub mod synthetic;
pub mod worker;

pub use config::{Exclusion, OnlineConfig};
pub use detector::{Detector, PoseInput, Pushed, Summary};
pub use events::{CandidateEvent, Ledger, Outcome, Source};
pub use frontend::TrackParams;
pub use guard::{GuardCounts, Rejection};
pub use worker::Overflow;
