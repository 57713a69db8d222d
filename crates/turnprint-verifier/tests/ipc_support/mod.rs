//! Shared pieces of the verifier-link tests: unique service prefixes, the
//! real `turnprint-verifier` process, and the real KITTI images.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::Child;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use turnprint_ipc::payload::camera_kind;
use turnprint_ipc::{CameraParams, ClientConfig, Outcome, VerifierClient};

/// A service prefix no other test (or test process) uses.
pub fn unique_prefix(test: &str) -> String {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    format!(
        "test-{test}-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    )
}

/// A running `turnprint-verifier`; killed (SIGKILL) when dropped.
pub struct VerifierProcess {
    pub child: Child,
    pub stderr_path: PathBuf,
    _dir: tempfile::TempDir,
}

impl VerifierProcess {
    /// Starts the real verifier binary on `prefix` with extra arguments.
    pub fn start(prefix: &str, extra: &[&str]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let stderr_path = dir.path().join("stderr.txt");
        let stderr = std::fs::File::create(&stderr_path).unwrap();
        use std::process::{Command, Stdio};
        let child = Command::new(env!("CARGO_BIN_EXE_turnprint-verifier"))
            .args([
                "--prefix",
                prefix,
                "--heartbeat-ms",
                "20",
                "--report-secs",
                "1",
            ])
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .expect("start turnprint-verifier");
        Self {
            child,
            stderr_path,
            _dir: dir,
        }
    }

    /// Sends SIGKILL (`kill -9`) and reaps the process.
    pub fn kill9(&mut self) {
        self.child.kill().unwrap();
        self.child.wait().unwrap();
    }

    /// What the verifier wrote to stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr_path).unwrap_or_default()
    }

    /// Resident memory of the process in bytes (from /proc).
    pub fn rss_bytes(&self) -> Option<u64> {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.child.id())).ok()?;
        let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
        let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kb * 1024)
    }
}

impl Drop for VerifierProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A client on `prefix` with the given candidate and liveness timeouts.
pub fn client(prefix: &str, timeout: Duration, liveness: Duration) -> VerifierClient {
    let mut config = ClientConfig::new(prefix);
    config.timeout = timeout;
    config.liveness_timeout = liveness;
    VerifierClient::new(config).expect("client")
}

/// Collects outcomes until `n` arrived or `limit` passed.
pub fn collect(client: &mut VerifierClient, n: usize, limit: Duration) -> Vec<Outcome> {
    let end = Instant::now() + limit;
    let mut all = Vec::new();
    while all.len() < n && Instant::now() < end {
        all.extend(client.wait(end.saturating_duration_since(Instant::now())));
    }
    all
}

/// A grey image and its size.
pub struct Gray {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
}

/// `file` in the shared data (its layout, e.g. `kitti_gt/06.txt`), or
/// `None` after a line saying the test is skipped (a failure under
/// `CI=true`; [`turnprint_eval::data::require`]).
pub fn data(file: &str) -> Option<PathBuf> {
    turnprint_eval::data::require(file)
}

/// Loads a real KITTI 06 frame (left grey camera, 1226x370) from the shared
/// data (`images/kitti06_pyslam/kitti06-FRAME.png`); `None` when absent.
pub fn kitti06(frame: u32) -> Option<Gray> {
    use opencv::prelude::*;
    let path = data(&format!("images/kitti06_pyslam/kitti06-{frame}.png"))?;
    let mat =
        opencv::imgcodecs::imread(path.to_str().unwrap(), opencv::imgcodecs::IMREAD_GRAYSCALE)
            .unwrap();
    assert!(!mat.empty(), "{} did not load", path.display());
    let (width, height) = (mat.cols() as u32, mat.rows() as u32);
    let pixels = mat.data_bytes().unwrap().to_vec();
    assert_eq!(pixels.len(), (width * height) as usize);
    Some(Gray {
        width,
        height,
        pixels,
    })
}

/// KITTI 06 frames 12 and 13 (one frame apart); `None` when absent.
pub fn kitti06_pair() -> Option<(Gray, Gray)> {
    Some((kitti06(12)?, kitti06(13)?))
}

/// The KITTI odometry left grey camera of sequences 04-12 (rectified).
pub fn kitti_camera(width: u32, height: u32) -> CameraParams {
    let c = CameraParams::pinhole(width, height, 707.0912, 707.0912, 601.8873, 183.1104);
    assert_eq!(c.kind, camera_kind::PINHOLE);
    c
}
