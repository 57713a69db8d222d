//! Any bytes read with `Format::Auto` from a file without an extension, so
//! that the content decides: an error or finite poses, the same as the
//! detected format reads, never a panic.
#![no_main]

use turnprint::io::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| turnprint_fuzz::read(data, Format::Auto, "fuzz"));
