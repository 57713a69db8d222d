//! Any bytes read as a CSV with a header: an error or finite poses, never a panic.
#![no_main]

use turnprint::io::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| turnprint_fuzz::read(data, Format::Csv, "fuzz.csv"));
