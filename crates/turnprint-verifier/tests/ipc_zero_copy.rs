//! A keyframe travels from the publisher's loan to the verifier without a
//! copy: the bytes the detector writes and the slice the verifier loop hands
//! to `FrameVerifier::add_keyframe` are the same bytes of the same
//! shared-memory file (same inode, same file offset), through real iceoryx2.
//!
//! The verifier loop runs in a thread of this process so the test can see
//! both addresses; what it drives is the production `server::run` with a
//! `FrameVerifier` that records where its image slice lives.

mod ipc_support;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use ipc_support::unique_prefix;
use turnprint_ipc::server::{self, FrameVerifier, ServerConfig};
use turnprint_ipc::{
    CameraParams, CandidateMsg, ClientConfig, KeyframeHeader, VerdictMsg, VerifierClient,
};

/// Where a byte lives: the mapped file (device, inode, path) and the offset in it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Backing {
    dev: String,
    inode: u64,
    path: String,
    offset: u64,
}

/// Looks `addr` up in /proc/self/maps.
fn backing(addr: usize) -> Option<Backing> {
    let maps = std::fs::read_to_string("/proc/self/maps").ok()?;
    for line in maps.lines() {
        let mut f = line.split_whitespace();
        let range = f.next()?;
        let (lo, hi) = range.split_once('-')?;
        let (lo, hi) = (
            usize::from_str_radix(lo, 16).ok()?,
            usize::from_str_radix(hi, 16).ok()?,
        );
        if addr < lo || addr >= hi {
            continue;
        }
        let _perms = f.next()?;
        let file_offset = u64::from_str_radix(f.next()?, 16).ok()?;
        let dev = f.next()?.to_string();
        let inode = f.next()?.parse().ok()?;
        let path = f.collect::<Vec<_>>().join(" ");
        return Some(Backing {
            dev,
            inode,
            path,
            offset: file_offset + (addr - lo) as u64,
        });
    }
    None
}

/// Keyframe id, where its image slice lived, checksum of the slice.
type Seen = (u64, Option<Backing>, u64);

/// Records where each keyframe's image slice lives and a checksum of it.
struct SliceRecorder(Arc<Mutex<Vec<Seen>>>);

impl FrameVerifier for SliceRecorder {
    fn add_keyframe(&mut self, header: &KeyframeHeader, image: &[u8]) -> Result<(), String> {
        let sum = image.iter().map(|&b| b as u64).sum();
        self.0
            .lock()
            .unwrap()
            .push((header.keyframe_id, backing(image.as_ptr() as usize), sum));
        Ok(())
    }

    fn verify(&mut self, candidate: &CandidateMsg) -> VerdictMsg {
        VerdictMsg::rejected(candidate.candidate_id, 1, "recorder decides nothing", 0)
    }

    fn memory_bytes(&self) -> usize {
        0
    }
}

#[test]
fn the_verifier_reads_the_bytes_the_publisher_wrote() {
    let prefix = unique_prefix("zerocopy");
    let seen = Arc::new(Mutex::new(Vec::new()));
    let recorder = SliceRecorder(seen.clone());
    let server_prefix = prefix.clone();
    // The loop runs until the process ends.
    std::thread::spawn(move || {
        let mut recorder = recorder;
        let mut config = ServerConfig::new(server_prefix);
        config.report_period = None;
        server::run(&config, &mut recorder)
    });

    let mut config = ClientConfig::new(&prefix);
    config.liveness_timeout = Duration::from_secs(5);
    let mut client = VerifierClient::new(config).unwrap();
    assert!(client.wait_for_verifier(Duration::from_secs(10)));

    let (width, height) = (640u32, 480u32);
    let camera = CameraParams::pinhole(width, height, 500.0, 500.0, 320.0, 240.0);
    let mut written = None;
    let mut expected_sum = 0u64;
    client
        .publish_keyframe_with(7, 0.7, &camera, width, |buf| {
            for (i, b) in buf.iter_mut().enumerate() {
                *b = (i % 253) as u8;
            }
            expected_sum = buf.iter().map(|&b| b as u64).sum();
            written = backing(buf.as_ptr() as usize);
        })
        .unwrap();
    let written = written.expect("the loan is mapped memory");
    assert!(
        written.path.starts_with("/dev/shm/"),
        "the loan lives in shared memory: {written:?}"
    );

    let end = Instant::now() + Duration::from_secs(10);
    while seen.lock().unwrap().is_empty() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(5));
    }
    let seen = seen.lock().unwrap();
    let (id, read, sum) = seen
        .first()
        .expect("keyframe reached the verifier loop")
        .clone();
    assert_eq!(id, 7);
    assert_eq!(sum, expected_sum);
    let read = read.expect("the verifier's slice is mapped memory");
    eprintln!("written at {written:?}, read at {read:?}");
    // Same file, same offset: the verifier reads the publisher's bytes in place.
    assert_eq!(read, written);
}
