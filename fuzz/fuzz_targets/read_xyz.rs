//! Any bytes read as xyz positions: an error or finite poses, never a panic.
#![no_main]

use turnprint::io::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| turnprint_fuzz::read(data, Format::Xyz, "fuzz.xyz"));
