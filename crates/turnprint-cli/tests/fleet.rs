//! `turnprint stream --fleet`: robots as real `turnprint` processes talking
//! Zenoh on loopback with explicit endpoints (multicast scouting off).
//! Windows of one generated drive, each under a known random similarity,
//! are robots that share road; another drive is a stranger. Faults: a robot
//! that joins after the others have driven, one killed with `kill -9` and
//! restarted, a peer that sends garbage and a newer payload version.
//! With `--verify`, cross-robot candidates are verified on both robots'
//! keyframes, each robot's served to the other over Zenoh, and each
//! robot's own loops on its own.
//!
//! The tests run one at a time (each starts several processes on a
//! two-core machine) and wait by polling with generous deadlines, never
//! on a sleep that assumes a speed.

mod common;

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serde_json::Value;
use turnprint::geometry::Similarity3;
use turnprint_fleet::fixture::{curvy_drive, random_similarity, tum, Lcg};

/// One fleet test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Longest a robot process may take: far above the few seconds each needs.
const DEADLINE: Duration = Duration::from_secs(50);

/// Largest error of a placement, as a fraction of the common length.
const MAX_ERROR: f64 = 0.03;

/// A truth pose of another robot counts as shared road when it lies this
/// close to the robot's own truth path (units of the drive: one pose per
/// unit, lateral noise a few hundredths).
const SHARE_RADIUS: f64 = 2.0;

/// Shortest common road (units) for a pair to count as sharing road.
const MIN_COMMON: f64 = 100.0;

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The ports the system hands out to outgoing connections and to
/// `bind(0)` (Linux's default where it does not tell).
fn ephemeral_ports() -> (u16, u16) {
    std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|t| {
            let mut it = t.split_whitespace().map(|v| v.parse::<u16>().ok());
            Some((it.next()??, it.next()??))
        })
        .unwrap_or((32768, 60999))
}

/// A port free now on loopback, outside the ephemeral range: a port
/// taken from that range can be handed to another robot's outgoing
/// connection before its own robot listens on it.
fn free_port() -> u16 {
    use std::sync::atomic::{AtomicU32, Ordering};
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let (low, high) = ephemeral_ports();
    // Below the range where it starts high enough, else above it.
    let (first, last) = match low > 11000 {
        true => (10000u32, u32::from(low) - 1),
        false => (u32::from(high) + 1, 65535),
    };
    let span = last - first + 1;
    let start = std::process::id() * 7919;
    loop {
        let k = NEXT.fetch_add(1, Ordering::Relaxed);
        assert!(k < span, "no free port in {first}-{last}");
        let port = (first + (start + k) % span) as u16;
        if TcpListener::bind(("127.0.0.1", port)).is_ok() {
            return port;
        }
    }
}

fn endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

/// A robot of a test: its truth (drive frame) and its path file (its own
/// frame, `frame` applied to the truth).
struct Robot {
    name: String,
    truth: Vec<Vector3<f64>>,
    /// The drive its truth comes from: robots of different drives share
    /// no road.
    drive: String,
    /// Truth poses of another robot this close to this one's path are
    /// shared road (units of the truth).
    share_radius: f64,
    /// Shortest common road (units) for a pair to count as sharing road.
    min_common: f64,
    frame: Similarity3,
    file: PathBuf,
    /// More arguments of its `stream` command.
    extra: Vec<String>,
}

impl Robot {
    fn new(dir: &Path, name: &str, truth: Vec<Vector3<f64>>, rng: &mut Lcg) -> Robot {
        let frame = random_similarity(rng);
        let points: Vec<_> = truth.iter().map(|p| frame.apply(p)).collect();
        let file = dir.join(format!("{name}.tum"));
        std::fs::write(&file, tum(&points)).expect("writing a path");
        Robot {
            name: name.into(),
            truth,
            drive: "curvy".into(),
            share_radius: SHARE_RADIUS,
            min_common: MIN_COMMON,
            frame,
            file,
            extra: Vec::new(),
        }
    }
}

/// A running robot process, its output going to a file.
struct Running {
    child: Child,
    out: PathBuf,
    err: PathBuf,
}

fn start(
    dir: &Path,
    fleet: &str,
    robot: &Robot,
    (listen, connect): (u16, &[u16]),
    (rate, linger): (f64, f64),
    tag: &str,
) -> Running {
    let out = dir.join(format!("{}{tag}.out", robot.name));
    let err = dir.join(format!("{}{tag}.err", robot.name));
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_turnprint"));
    cmd.args(["stream", robot.file.to_str().expect("utf-8"), "--json"])
        .args(["--fleet", fleet, "--robot", &robot.name])
        .args(["--listen", &endpoint(listen)])
        .args(["--rate", &rate.to_string(), "--linger", &linger.to_string()]);
    for p in connect {
        cmd.args(["--connect", &endpoint(*p)]);
    }
    cmd.args(&robot.extra);
    let child = cmd
        .stdout(std::fs::File::create(&out).expect("stdout file"))
        .stderr(std::fs::File::create(&err).expect("stderr file"))
        .stdin(Stdio::null())
        .spawn()
        .expect("starting turnprint");
    Running { child, out, err }
}

/// Starts every robot of `robots`, each listening on a port of its own and
/// connected to those started before it.
fn start_all(dir: &Path, fleet: &str, robots: &[Robot], timing: (f64, f64)) -> Vec<Running> {
    let ports: Vec<u16> = (0..robots.len()).map(|_| free_port()).collect();
    robots
        .iter()
        .enumerate()
        .map(|(i, robot)| start(dir, fleet, robot, (ports[i], &ports[..i]), timing, ""))
        .collect()
}

impl Running {
    /// Waits for the process to end well; returns its summary.
    fn summary(mut self) -> Value {
        let t0 = Instant::now();
        let status = loop {
            if let Some(s) = self.child.try_wait().expect("waiting") {
                break s;
            }
            if t0.elapsed() > DEADLINE {
                let _ = self.child.kill();
                panic!("a robot ran past {DEADLINE:?}: {}", self.stderr());
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        assert!(status.success(), "{status}: {}", self.stderr());
        let text = std::fs::read_to_string(&self.out).expect("stdout");
        let last = text.lines().last().expect("a summary line");
        let v: Value = serde_json::from_str(last).expect("JSON");
        assert_eq!(v["event"], "summary", "{last}");
        // Every line is JSON; cross-robot candidates carry cli.md's fields.
        let mut cross = 0;
        for line in text.lines() {
            let e: Value = serde_json::from_str(line).expect("JSON line");
            if e["event"] == "candidate" && e.get("robot").is_some() {
                cross += 1;
                for range in ["query_range", "match_range"] {
                    let r = &e[range];
                    assert!(r[0].as_u64() <= r[1].as_u64(), "{line}");
                }
                assert!(e["at_pose"].is_u64(), "{line}");
                assert!(e["scale"].as_f64().is_some_and(|s| s > 0.0), "{line}");
                assert!(
                    e["score"]
                        .as_f64()
                        .is_some_and(|s| (0.0..=1.0).contains(&s)),
                    "{line}"
                );
                assert_eq!(e["rotation"].as_array().map(Vec::len), Some(3), "{line}");
                assert_eq!(e["translation"].as_array().map(Vec::len), Some(3), "{line}");
            }
        }
        assert_eq!(v["cross_candidates"], cross, "{}", v["cross_candidates"]);
        v
    }

    fn stderr(&self) -> String {
        std::fs::read_to_string(&self.err).unwrap_or_default()
    }
}

/// The similarity in a summary's `robots` entry.
fn similarity(v: &Value) -> Option<Similarity3> {
    if v["merged"] != true {
        return None;
    }
    let f = |v: &Value| v.as_f64().expect("a number");
    let r = &v["rotation"];
    let t = &v["translation"];
    Some(Similarity3 {
        scale: f(&v["scale"]),
        rotation: nalgebra::Matrix3::from_fn(|i, j| f(&r[i][j])),
        translation: Vector3::new(f(&t[0]), f(&t[1]), f(&t[2])),
    })
}

/// The common road of `other` with `own` (truth poses of `other` near
/// `own`'s path) and its length.
fn common(own: &Robot, other: &Robot) -> (Vec<Vector3<f64>>, f64) {
    let near = |p: &Vector3<f64>| {
        own.drive == other.drive && own.truth.iter().any(|q| (p - q).norm() < own.share_radius)
    };
    let shared: Vec<bool> = other.truth.iter().map(near).collect();
    let mut length = 0.0;
    for i in 1..other.truth.len() {
        if shared[i] && shared[i - 1] {
            length += (other.truth[i] - other.truth[i - 1]).norm();
        }
    }
    let points = other
        .truth
        .iter()
        .zip(&shared)
        .filter(|(_, s)| **s)
        .map(|(p, _)| *p)
        .collect();
    (points, length)
}

/// How one robot placed another.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Placed {
    /// They share at least the robot's `min_common` of road: the error as a
    /// fraction of the common length (infinite: left out).
    Shared(f64),
    /// They share less: left out, or placed with this error.
    Little(Option<f64>),
    /// They share no road: left out (`true`) or merged.
    Stranger(bool),
}

/// How `own`'s summary placed `other`.
fn placement(summary: &Value, own: &Robot, other: &Robot) -> Placed {
    let entry = &summary["robots"][&other.name];
    let estimate = similarity(entry);
    let (points, length) = common(own, other);
    if points.is_empty() {
        return Placed::Stranger(estimate.is_none());
    }
    // own_T_other = own.frame * other.frame^-1, on other's coordinates.
    let truth = own.frame.compose(&other.frame.inverse());
    let error = estimate.map(|est| {
        let mut d: Vec<f64> = points
            .iter()
            .map(|p| {
                let q = other.frame.apply(p);
                (est.apply(&q) - truth.apply(&q)).norm()
            })
            .collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2] / (length.max(own.min_common) * own.frame.scale)
    });
    match length >= own.min_common {
        true => Placed::Shared(error.unwrap_or(f64::INFINITY)),
        false => Placed::Little(error),
    }
}

/// Checks every ordered pair: shared road placed within [`MAX_ERROR`],
/// strangers left out, a little shared road left out or placed right.
fn check(robots: &[&Robot], summaries: &[&Value]) {
    for (own, s) in robots.iter().zip(summaries) {
        for other in robots {
            if other.name == own.name {
                continue;
            }
            let placed = placement(s, own, other);
            let ok = match placed {
                Placed::Shared(e) => e < MAX_ERROR,
                Placed::Little(e) => e.is_none_or(|e| e < MAX_ERROR),
                Placed::Stranger(left_out) => left_out,
            };
            assert!(
                ok,
                "{} placed {}: {placed:?}; {}",
                own.name, other.name, s["robots"]
            );
        }
    }
}

/// The test's robots: three windows of one drive (the second driven
/// backwards) and a stranger.
fn robots(dir: &Path) -> Vec<Robot> {
    let drive = curvy_drive(1, 2400);
    let mut rng = Lcg::new(11);
    vec![
        Robot::new(dir, "a", drive[..1400].to_vec(), &mut rng),
        Robot::new(
            dir,
            "b",
            drive[1000..].iter().rev().copied().collect(),
            &mut rng,
        ),
        Robot::new(dir, "c", drive[600..1800].to_vec(), &mut rng),
        Robot {
            drive: "stranger".into(),
            ..Robot::new(dir, "s", curvy_drive(2, 1200), &mut rng)
        },
    ]
}

fn fleet_name(test: &str) -> String {
    format!("test-{test}-{}", std::process::id())
}

/// Poses per second of the replays: each robot drives for 3-4 s.
const RATE: f64 = 400.0;

#[test]
fn three_robots_and_a_stranger_place_each_other() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("temp dir");
    let r = robots(dir.path());
    let fleet = fleet_name("three");
    let running = start_all(dir.path(), &fleet, &r, (RATE, 4.0));
    let summaries: Vec<Value> = running.into_iter().map(Running::summary).collect();
    for s in &summaries {
        assert_eq!(s["refused"]["garbage"], 0, "{s}");
        eprintln!("{}: {} {}", s["robot"], s["robots"], s["sent"]);
    }
    check(
        &r.iter().collect::<Vec<_>>(),
        &summaries.iter().collect::<Vec<_>>(),
    );
}

#[test]
fn a_robot_that_joins_late_catches_up() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("temp dir");
    let r = robots(dir.path());
    let fleet = fleet_name("late");
    let ports: Vec<u16> = (0..3).map(|_| free_port()).collect();
    // A and B stay until C has driven its whole path.
    let a = start(dir.path(), &fleet, &r[0], (ports[0], &[]), (RATE, 15.0), "");
    let b = start(
        dir.path(),
        &fleet,
        &r[1],
        (ports[1], &ports[..1]),
        (RATE, 15.0),
        "",
    );
    // C starts once A and B have driven their paths (the time their
    // replays take, and a second for the start).
    std::thread::sleep(Duration::from_secs_f64(1400.0 / RATE + 1.0));
    let c = start(
        dir.path(),
        &fleet,
        &r[2],
        (ports[2], &ports[..2]),
        (RATE, 3.0),
        "",
    );
    let (sa, sb, sc) = (a.summary(), b.summary(), c.summary());
    // C holds every chunk A and B published, most of them before it
    // started: it asked for their histories.
    for (s, name) in [(&sa, "a"), (&sb, "b")] {
        assert!(
            s["sent"]["queries_answered"].as_u64() >= Some(1),
            "{}",
            s["sent"]
        );
        let held = &sc["fleet_state"]["peers"][name];
        assert_eq!(held["chunks"], s["sent"]["chunks"], "{held}");
        assert_eq!(held["ended"], true, "{held}");
    }
    check(&[&r[0], &r[1], &r[2]], &[&sa, &sb, &sc]);
}

#[test]
fn a_robot_killed_and_restarted_is_placed_again_without_stale_state() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("temp dir");
    let r = robots(dir.path());
    let fleet = fleet_name("kill");
    let ports: Vec<u16> = (0..4).map(|_| free_port()).collect();
    let a = start(dir.path(), &fleet, &r[0], (ports[0], &[]), (RATE, 12.0), "");
    let c = start(
        dir.path(),
        &fleet,
        &r[2],
        (ports[2], &ports[..1]),
        (RATE, 12.0),
        "",
    );
    let mut b = start(
        dir.path(),
        &fleet,
        &r[1],
        (ports[1], &[ports[0], ports[2]]),
        (RATE, 1.0),
        "-1",
    );
    // Killed once it has published a chunk (an observer connected to A
    // hears it as A does), about halfway through its path.
    let (tx, rx) = crossbeam::channel::unbounded();
    let endpoints = turnprint_fleet::Endpoints {
        listen: Vec::new(),
        connect: vec![endpoint(ports[0])],
    };
    let observer = turnprint_fleet::transport::Transport::open(&fleet, "observer", &endpoints, tx)
        .expect("the observer's session");
    let t0 = Instant::now();
    loop {
        let m = rx.recv_timeout(DEADLINE).expect("a payload");
        let chunk = matches!(
            turnprint_fleet::payload::decode(&m.bytes),
            Ok(turnprint_fleet::payload::Message::Chunk(_))
        );
        if m.robot == "b" && chunk {
            break;
        }
        assert!(t0.elapsed() < DEADLINE, "no chunk of B");
    }
    drop(observer);
    std::thread::sleep(Duration::from_secs_f64(300.0 / RATE));
    Command::new("kill")
        .args(["-9", &b.child.id().to_string()])
        .status()
        .expect("kill -9");
    let status = b.child.wait().expect("the killed robot");
    assert!(!status.success());
    // Restarted under the same name, on another port.
    let b2 = start(
        dir.path(),
        &fleet,
        &r[1],
        (ports[3], &[ports[0], ports[2]]),
        (RATE, 3.0),
        "-2",
    );
    let (sa, sb, sc) = (a.summary(), b2.summary(), c.summary());
    for s in [&sa, &sc] {
        assert!(
            s["fleet_state"]["restarts_seen"].as_u64() >= Some(1),
            "the restart went unseen: {}",
            s["fleet_state"]
        );
        // B's new session only: its whole path, once.
        let peer = &s["fleet_state"]["peers"]["b"];
        assert_eq!(peer["poses"], 1400, "{peer}");
        assert_eq!(peer["ended"], true, "{peer}");
    }
    check(&[&r[0], &r[1], &r[2]], &[&sa, &sb, &sc]);
}

#[test]
fn garbage_and_a_newer_version_are_refused_and_counted() {
    let _serial = serial();
    let dir = tempfile::tempdir().expect("temp dir");
    let r = robots(dir.path());
    let fleet = fleet_name("garbage");
    let ports: Vec<u16> = (0..2).map(|_| free_port()).collect();
    let a = start(dir.path(), &fleet, &r[0], (ports[0], &[]), (RATE, 6.0), "");
    let b = start(
        dir.path(),
        &fleet,
        &r[1],
        (ports[1], &ports[..1]),
        (RATE, 6.0),
        "",
    );
    // A peer of the fleet that sends what no robot should.
    let (tx, rx) = crossbeam::channel::unbounded();
    let endpoints = turnprint_fleet::Endpoints {
        listen: Vec::new(),
        connect: vec![endpoint(ports[0])],
    };
    let evil = turnprint_fleet::transport::Transport::open(&fleet, "evil", &endpoints, tx)
        .expect("the evil peer's session");
    // Once A's status arrives, A hears what the peer publishes.
    rx.recv_timeout(DEADLINE).expect("A's status");
    let newer = {
        let mut p = turnprint_fleet::payload::encode_status(1, 0, 0);
        p[4..6].copy_from_slice(&(turnprint_fleet::payload::VERSION + 1).to_le_bytes());
        p
    };
    let garbage: [Vec<u8>; 3] = [
        b"hello".to_vec(),
        vec![0xff; 300],
        turnprint_fleet::payload::encode_status(1, 0, 0)[..10].to_vec(),
    ];
    for g in garbage {
        evil.publish(g).expect("publishing");
    }
    for _ in 0..2 {
        evil.publish(newer.clone()).expect("publishing");
    }
    let (sa, sb) = (a.summary(), b.summary());
    drop(evil);
    assert_eq!(sa["refused"]["garbage"], 3, "{}", sa["refused"]);
    assert_eq!(sa["refused"]["version"], 2, "{}", sa["refused"]);
    assert!(sa["robots"].get("evil").is_none(), "{}", sa["robots"]);
    check(&[&r[0], &r[1]], &[&sa, &sb]);
}

/// Bad options end with one clear line and a failure, never a panic.
#[test]
fn bad_fleet_options_are_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("a.tum");
    std::fs::write(&path, tum(&curvy_drive(1, 100))).expect("writing");
    for args in [
        vec!["--fleet", "f/x", "--robot", "a"],
        vec!["--fleet", "f", "--robot", "*"],
        vec!["--fleet", "f", "--robot", "a", "--rate", "0"],
        vec!["--fleet", "f", "--robot", "a", "--linger", "nan"],
        vec!["--fleet", "f"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_turnprint"))
            .args(["stream", path.to_str().expect("utf-8"), "--json"])
            .args(&args)
            .output()
            .expect("running turnprint");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(!err.trim().is_empty(), "{args:?}");
    }
}

/// KITTI's ground truth: 4 m is about a lane and a half, so a road driven
/// again in either direction is shared road, a parallel street is not.
const KITTI_SHARE_RADIUS: f64 = 4.0;

/// Shortest common road (m) on KITTI for a pair to count as sharing road:
/// a block and a half of a city grid (KITTI 00's blocks are 100-150 m),
/// less is a single street that looks like many others.
const KITTI_MIN_COMMON: f64 = 200.0;

/// Windows of KITTI drives' ground truth as robots: `(sequence, first
/// pose, poses)`.
fn kitti_robots(dir: &Path, windows: &[(&str, usize, usize)], seed: u64) -> Option<Vec<Robot>> {
    let mut rng = Lcg::new(seed);
    let mut robots = Vec::new();
    for (i, &(seq, first, n)) in windows.iter().enumerate() {
        let path = common::data(&format!("kitti_gt/{seq}.txt"))?;
        let t = turnprint::io::read_trajectory(path.as_ref(), turnprint::io::Format::Kitti)
            .expect("KITTI ground truth");
        let truth: Vec<_> = t.positions()[first..(first + n).min(t.len())].to_vec();
        let mut r = Robot::new(dir, &format!("k{i}"), truth, &mut rng);
        r.share_radius = KITTI_SHARE_RADIUS;
        r.min_common = KITTI_MIN_COMMON;
        r.drive = seq.into();
        robots.push(r);
    }
    Some(robots)
}

/// Fleet figures of one run: ordered pairs sharing road and placed within
/// [`MAX_ERROR`], strangers and strangers left out, bytes published per km
/// of path, CPU seconds per robot.
#[derive(Debug, Default)]
struct Figures {
    shared: usize,
    placed: usize,
    strangers: usize,
    left_out: usize,
    little_wrong: usize,
    bytes: f64,
    replied: f64,
    km: f64,
    cpu: Vec<f64>,
}

fn figures(robots: &[&Robot], summaries: &[&Value], metres_per_unit: f64) -> Figures {
    let mut f = Figures::default();
    for (own, s) in robots.iter().zip(summaries) {
        for other in robots {
            if other.name == own.name {
                continue;
            }
            let placed = placement(s, own, other);
            eprintln!("{} -> {}: {placed:?}", own.name, other.name);
            match placed {
                Placed::Shared(e) => {
                    f.shared += 1;
                    f.placed += usize::from(e < MAX_ERROR);
                }
                Placed::Little(e) => {
                    f.little_wrong += usize::from(e.is_some_and(|e| e >= MAX_ERROR))
                }
                Placed::Stranger(left_out) => {
                    f.strangers += 1;
                    f.left_out += usize::from(left_out);
                }
            }
        }
        let sent = &s["sent"];
        f.bytes += sent["published_bytes"].as_f64().unwrap_or(0.0);
        f.replied += sent["replied_bytes"].as_f64().unwrap_or(0.0);
        let length: f64 = own.truth.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
        f.km += length * metres_per_unit / 1000.0;
        f.cpu.push(s["cpu_s"].as_f64().unwrap_or(f64::NAN));
    }
    f
}

/// Robots on windows of KITTI 00 and 05 ground truth (00 revisits its
/// roads, so windows far apart in time share road too), each under a
/// random similarity, and a window of 02 as a stranger to all.
const KITTI_WINDOWS: [[(&str, usize, usize); 5]; 2] = [
    [
        ("00", 0, 1600),
        ("00", 1200, 1600),
        ("00", 2800, 1700),
        ("05", 0, 1500),
        ("02", 0, 1500),
    ],
    [
        ("00", 500, 1500),
        ("00", 1800, 1500),
        ("00", 3000, 1541),
        ("05", 1200, 1500),
        ("02", 2000, 1500),
    ],
];

fn run_kitti(windows: &[(&str, usize, usize)], seed: u64, rate: f64) -> Option<Figures> {
    let dir = tempfile::tempdir().expect("temp dir");
    let r = kitti_robots(dir.path(), windows, seed)?;
    let fleet = fleet_name(&format!("kitti{seed}"));
    let running = start_all(dir.path(), &fleet, &r, (rate, 5.0));
    let summaries: Vec<Value> = running.into_iter().map(Running::summary).collect();
    if std::env::var_os("TURNPRINT_FLEET_KEEP").is_some() {
        eprintln!("kept in {}", dir.keep().display());
    }
    let f = figures(
        &r.iter().collect::<Vec<_>>(),
        &summaries.iter().collect::<Vec<_>>(),
        1.0,
    );
    eprintln!("{f:?}");
    Some(f)
}

/// Windows of real drives: the pairs that share road place each other, the
/// stranger is left out.
#[test]
fn kitti_windows_place_each_other() {
    let _serial = serial();
    let Some(f) = run_kitti(&KITTI_WINDOWS[0], 1, 1000.0) else {
        return;
    };
    assert!(f.placed as f64 >= 0.9 * f.shared as f64, "{f:?}");
    assert_eq!(f.left_out, f.strangers, "{f:?}");
    assert_eq!(f.little_wrong, 0, "{f:?}");
}

/// The figures of EVALUATION_ONLINE.md ("Fleet"): several random sets of
/// similarities on the KITTI windows. `cargo test --release -p
/// turnprint-cli --test fleet -- --ignored --nocapture fleet_figures`
#[test]
#[ignore = "a measurement, not a check: the figures of EVALUATION_ONLINE.md (Fleet), several minutes"]
fn fleet_figures() {
    let _serial = serial();
    let mut all = Figures::default();
    for seed in 1..=6 {
        let windows = &KITTI_WINDOWS[seed as usize % 2];
        let Some(f) = run_kitti(windows, seed, 1000.0) else {
            return;
        };
        all.shared += f.shared;
        all.placed += f.placed;
        all.strangers += f.strangers;
        all.left_out += f.left_out;
        all.little_wrong += f.little_wrong;
        all.bytes += f.bytes;
        all.replied += f.replied;
        all.km += f.km;
        all.cpu.extend(f.cpu);
    }
    all.cpu.sort_by(f64::total_cmp);
    println!(
        "pairs sharing road placed: {}/{}; strangers left out: {}/{}; pairs sharing little misplaced: {}; {:.0} bytes published per km, {:.0} more in answers to catch-up queries; CPU per robot median {:.2} s, max {:.2} s",
        all.placed,
        all.shared,
        all.left_out,
        all.strangers,
        all.little_wrong,
        all.bytes / all.km,
        all.replied / all.km,
        all.cpu[all.cpu.len() / 2],
        all.cpu[all.cpu.len() - 1]
    );
}

/// The test world's frame (KITTI's camera frame: the ground is x-z) of a
/// drive in the plane z = 0, one line `x y z` per pose.
fn on_the_ground(points: &[Vector3<f64>]) -> String {
    points
        .iter()
        .map(|p| format!("{:.6} 0 {:.6}\n", p.x, p.y))
        .collect()
}

/// Two keyframes may see one place when their true positions lie within
/// this (units of the drive, metres of the test world): its facades stand
/// 9 m off the road, so views of one street up to about three street
/// widths apart share facades (a wrong candidate whose keyframes lie on
/// one street, 11-25 m apart, is confirmed as such). Farther apart, a
/// confirmation is false.
const SAME_PLACE: f64 = 30.0;

/// Whether a verdict's query poses (of `own`) lie on its match poses (of
/// `other`) in the truth: median distance within the share radius.
fn truly_shared(e: &Value, own: &Robot, other: &Robot) -> bool {
    let range = |k: &str| {
        let r = &e[k];
        let (a, b) = (
            r[0].as_u64().expect("range") as usize,
            r[1].as_u64().expect("range") as usize,
        );
        a..=b
    };
    let mut d: Vec<f64> = range("query_range")
        .map(|i| {
            range("match_range")
                .map(|j| (own.truth[i] - other.truth[j]).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2] <= own.share_radius
}

#[test]
fn cross_robot_candidates_are_verified_on_both_robots_keyframes() {
    if common::verifier_binary().is_none() {
        eprintln!("skipped: the verifier binary is not built (cargo build --release --bins)");
        return;
    }
    let _serial = serial();
    let dir = tempfile::tempdir().expect("temp dir");
    // Two windows of one drive sharing 600 poses, each in a frame of its
    // own, both driven the same way (cameras looking ahead see little of
    // a road driven the other way); every robot renders in the world built
    // along the drive.
    let drive = curvy_drive(1, 2000);
    let mut rng = Lcg::new(23);
    let world = dir.path().join("world.xyz");
    std::fs::write(&world, on_the_ground(&drive)).expect("writing the world");
    let r = [("a", &drive[..1300]), ("b", &drive[700..])].map(|(name, truth)| {
        let mut robot = Robot::new(dir.path(), name, truth.to_vec(), &mut rng);
        let file = dir.path().join(format!("{name}.truth.xyz"));
        std::fs::write(&file, on_the_ground(truth)).expect("writing a truth");
        robot.extra = [("--truth", &file), ("--world", &world)]
            .into_iter()
            .flat_map(|(flag, path)| [flag.to_string(), path.display().to_string()])
            .chain(["--verify".to_string()])
            .collect();
        robot
    });
    let fleet = fleet_name("verify");
    let running = start_all(dir.path(), &fleet, &r, (RATE, 4.0));
    let outputs: Vec<(Value, String)> = running
        .into_iter()
        .map(|run| {
            let out = run.out.clone();
            (run.summary(), std::fs::read_to_string(out).expect("stdout"))
        })
        .collect();
    let mut confirmed_true = 0;
    for (k, (summary, text)) in outputs.iter().enumerate() {
        let (own, other) = (&r[k], &r[1 - k]);
        let events: Vec<Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).expect("JSON"))
            .collect();
        let cross = |e: &&Value| e.get("robot").is_some_and(|v| v == other.name.as_str());
        let mine = |e: &&Value| e.get("robot").is_none();
        let ids = |event: &[&str], whose: &dyn Fn(&&Value) -> bool| -> Vec<u64> {
            let mut ids: Vec<u64> = events
                .iter()
                .filter(|e| event.contains(&e["event"].as_str().unwrap_or("")))
                .filter(|e| whose(e))
                .map(|e| e["id"].as_u64().expect("an id"))
                .collect();
            ids.sort_unstable();
            ids
        };
        // Every candidate, cross-robot or its own, ends once.
        let endings = ["confirmed", "rejected", "expired"];
        let candidates = ids(&["candidate"], &cross);
        assert_eq!(
            ids(&endings, &cross),
            candidates,
            "{}: cross candidates and endings differ",
            own.name
        );
        let loops = ids(&["candidate"], &mine);
        assert_eq!(
            ids(&endings, &mine),
            loops,
            "{}: own candidates and endings differ",
            own.name
        );
        // No candidate is confirmed on views of different places; true
        // ones are.
        for e in events.iter().filter(|e| e["event"] == "confirmed") {
            let seen = |k: &str, r: &Robot| r.truth[e[k].as_u64().expect("a keyframe") as usize];
            let theirs = if cross(&e) { other } else { own };
            let apart = (seen("query_keyframe", own) - seen("match_keyframe", theirs)).norm();
            assert!(
                apart <= SAME_PLACE,
                "{}: keyframes {apart:.1} apart confirmed: {e}",
                own.name
            );
            assert!(e["inliers"].as_u64().is_some_and(|n| n > 0), "{e}");
            confirmed_true += usize::from(cross(&e) && truly_shared(e, own, other));
        }
        // A confirmed cross candidate leads the estimate of the other robot,
        // and it is placed right.
        let confirmed = ids(&["confirmed"], &cross);
        if !confirmed.is_empty() {
            let estimate = &summary["robots"][&other.name];
            assert!(
                estimate["confirmed"].as_u64().is_some_and(|n| n > 0),
                "{estimate}"
            );
            let placed = placement(summary, own, other);
            assert!(
                matches!(placed, Placed::Shared(e) if e < MAX_ERROR),
                "{} placed {}: {placed:?}",
                own.name,
                other.name
            );
        }
        let v = &summary["verify"];
        assert_eq!(
            v["submitted"].as_u64(),
            Some(candidates.len() as u64),
            "{summary}"
        );
        assert_eq!(v["refused_keyframes"]["garbage"], 0, "{summary}");
        assert!(
            summary["sent"]["keyframes_served"]
                .as_u64()
                .is_some_and(|n| n > 0),
            "{summary}"
        );
        eprintln!(
            "{}: {} cross candidates, verify {v}, sent {}",
            own.name,
            candidates.len(),
            summary["sent"]
        );
    }
    assert!(
        confirmed_true > 0,
        "no true cross-robot candidate was confirmed"
    );
}
