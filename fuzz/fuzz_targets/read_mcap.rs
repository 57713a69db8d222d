//! Any bytes read as a ROS 2 bag (MCAP), with and without a topic: an error
//! or finite poses, never a panic.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    for topic in [None, Some("/odom")] {
        if let Ok(trajectory) = turnprint::io::read_mcap_bytes(data, topic) {
            turnprint_fuzz::check_trajectory(&trajectory);
        }
    }
});
