//! The parts of the `turnprint` command that are more than argument
//! parsing: reading its inputs ([`input`]), figures ([`plot`]), `stream`
//! replays and stdin ([`stream`]), and `stream --verify` with the visual
//! verifier sidecar ([`sidecar`]).

pub mod input;
pub mod plot;
pub mod sidecar;
pub mod stream;
