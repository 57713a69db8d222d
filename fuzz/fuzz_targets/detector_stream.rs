//! Arbitrary pose streams pushed into the online detector, polled as they
//! go, then finished: no panic, no hang, every candidate accounted for.
#![no_main]

libfuzzer_sys::fuzz_target!(|run: turnprint_fuzz::stream::Run| turnprint_fuzz::stream::run(run));
