//! The parts of the `turnprint` command that are more than argument
//! parsing: reading its inputs ([`input`]), figures ([`plot`]), `stream`
//! replays and stdin ([`stream`]), `stream --verify` with the visual
//! verifier sidecar ([`sidecar`]), the keyframes it renders and the sidecar
//! process ([`keyframes`]), and a fleet robot's cross-robot candidates
//! verified on both robots' keyframes ([`fleet_verify`]).

pub mod fleet_verify;
pub mod input;
pub mod keyframes;
pub mod plot;
pub mod sidecar;
pub mod stream;
