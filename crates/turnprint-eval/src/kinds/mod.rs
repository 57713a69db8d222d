//! The evaluation over every kind of real path in the data folder: cars
//! (KITTI ground truth, monocular, LiDAR and stereo odometry, GPS), drones
//! (motion capture and VIO estimates), hand-held cameras, wheeled robots'
//! dead reckoning and pedestrians' GPS. Each kind gets merge cases (windows
//! of one session, and pairs of sessions recorded in one frame), negatives
//! against every other kind, and loop runs where its sessions revisit.
//!
//! Every rule is scale-free (fractions of a path's length or extent), so
//! that a 30 m flight and a 3 km drive are judged alike:
//! - the common road of two paths: poses within [`SAME_ROAD`] of the
//!   reference window's extent of the other path;
//! - a merge is correct when B's common poses land within [`MERGE_TOLERANCE`]
//!   of the common length (median) and both ranges touch the common road;
//! - a revisit: a pose within [`REVISIT_RADIUS`] of the path's extent of a
//!   pose at least [`REVISIT_GAP`] of its length earlier; an event spans
//!   [`EVENT_MIN_RADII`] radii of road.

pub mod catalog;
pub mod loops;
pub mod merge;
pub mod report;

use serde::Serialize;

pub use catalog::{catalog, Measured, Session};

/// Radius of the common road, as a fraction of the reference path's extent
/// (bounding-box diagonal): KITTI windows of 0.5-1 km span 300-600 m, so
/// 1.5 % is the 5-9 m of a road's lanes; a 10 m room's is 15 cm.
pub const SAME_ROAD: f64 = 0.015;
/// A merge is right when B's common poses land within this fraction of the
/// common road's length (median), as for KITTI without its 3 m floor.
pub const MERGE_TOLERANCE: f64 = 0.02;
/// Revisit radius as a fraction of the whole path's extent (KITTI 00: 14 m).
pub const REVISIT_RADIUS: f64 = 0.02;
/// A revisit's earlier pose lies at least this fraction of the path's length
/// back (KITTI 00: 370 m, about the 300 frames of the KITTI evaluation).
pub const REVISIT_GAP: f64 = 0.1;
/// An event spans at least this many revisit radii of road.
pub const EVENT_MIN_RADII: f64 = 5.0;
/// A loop is right when its query poses lie within this many revisit radii
/// of its match poses (median, in the truth).
pub const LOOP_RADII: f64 = 1.25;
/// Sessions longer than this many poses are thinned evenly (every k-th
/// pose): 200 Hz motion capture holds 30 000 poses where the matcher needs
/// far fewer, and the brute-force truth checks are quadratic.
pub const MAX_POSES: usize = 6000;

/// What kind of platform and sensor a path comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum Kind {
    /// KITTI ground truth (a car, RTK-GPS/INS).
    Car,
    /// A car's odometry without loop closure: monocular ORB-SLAM2, LiDAR
    /// (MULLS, A-LOAM, GICP, NDT), stereo S-PTAM; truth: KITTI's.
    CarOdometry,
    /// A car's GPS: KITTI's 1 Hz receiver, evo's georeferenced drive.
    CarGps,
    /// Drones under motion capture: EuRoC, UZH-FPV, KAIST-VIO.
    Drone,
    /// Drones' VIO estimates (EuRoC), truth by time.
    DroneVio,
    /// Hand-held cameras under motion capture: TUM-VI rooms, TUM fr2/desk.
    Handheld,
    /// Wheeled robots' dead reckoning indoors (CARMEN/Radish logs).
    Wheeled,
    /// Pedestrians' GPS (watches and phones).
    Walker,
}

impl Kind {
    /// Every kind, in table order.
    pub const ALL: [Kind; 8] = [
        Kind::Car,
        Kind::CarOdometry,
        Kind::CarGps,
        Kind::Drone,
        Kind::DroneVio,
        Kind::Handheld,
        Kind::Wheeled,
        Kind::Walker,
    ];

    /// Name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Car => "car, ground truth",
            Kind::CarOdometry => "car, odometry",
            Kind::CarGps => "car, GPS",
            Kind::Drone => "drone, motion capture",
            Kind::DroneVio => "drone, VIO",
            Kind::Handheld => "hand-held, motion capture",
            Kind::Wheeled => "wheeled robot, dead reckoning",
            Kind::Walker => "pedestrian, GPS",
        }
    }

    /// Short name for the command line (`--kinds`).
    pub fn key(self) -> &'static str {
        match self {
            Kind::Car => "car",
            Kind::CarOdometry => "car-odometry",
            Kind::CarGps => "car-gps",
            Kind::Drone => "drone",
            Kind::DroneVio => "drone-vio",
            Kind::Handheld => "handheld",
            Kind::Wheeled => "wheeled",
            Kind::Walker => "walker",
        }
    }
}

pub use turnprint::geometry::extent;

/// Settings of one run of the evaluation over every kind.
#[derive(Debug, Clone)]
pub struct KindsOptions {
    /// The data folder (the shared layout).
    pub data: std::path::PathBuf,
    /// Seed of every draw.
    pub seed: u64,
    /// Window cases per kind.
    pub windows: usize,
    /// Session-pair cases per kind at most (a random subset of the pairs).
    pub pairs: usize,
    /// Negatives per kind (A of the kind, B of another).
    pub negatives: usize,
    /// Loop runs per session and input (seeds `seed..seed + n`).
    pub loop_seeds: u64,
    /// Kinds to evaluate (all when empty).
    pub kinds: Vec<Kind>,
    /// Run the merge cases.
    pub merge: bool,
    /// Run the loops.
    pub loops: bool,
    /// Replay each loop run's input through the online detector too.
    pub online: bool,
}

impl Default for KindsOptions {
    fn default() -> Self {
        KindsOptions {
            data: std::path::PathBuf::from("../shared/data"),
            seed: 1,
            windows: 40,
            pairs: 40,
            negatives: 30,
            loop_seeds: 1,
            kinds: Vec::new(),
            merge: true,
            loops: true,
            online: false,
        }
    }
}

/// Runs the evaluation over every kind (or those asked for).
pub fn evaluate(opts: &KindsOptions) -> turnprint::Result<report::KindsReport> {
    use rand::{rngs::StdRng, seq::SliceRandom, Rng, SeedableRng};

    let dir = crate::data::resolve_data_dir(&opts.data)?;
    let found = catalog(&dir);
    let wanted = |k: Kind| opts.kinds.is_empty() || opts.kinds.contains(&k);
    let sessions = &found.sessions;
    let mut report = report::KindsReport {
        seed: opts.seed,
        skipped: found.skipped.clone(),
        ..Default::default()
    };
    for kind in Kind::ALL.into_iter().filter(|k| wanted(*k)) {
        let n = sessions.iter().filter(|s| s.kind == kind).count();
        report.sessions.push((kind, n));
    }
    let bar = indicatif::ProgressBar::new(0);
    let mut rng = StdRng::seed_from_u64(opts.seed);
    if opts.merge {
        for kind in Kind::ALL.into_iter().filter(|k| wanted(*k)) {
            let own: Vec<&Session> = sessions.iter().filter(|s| s.kind == kind).collect();
            if own.is_empty() {
                continue;
            }
            let mut pairs = merge::session_pairs(sessions, kind);
            pairs.shuffle(&mut rng);
            pairs.truncate(opts.pairs);
            bar.inc_length((opts.windows + pairs.len() + opts.negatives) as u64);
            let mut outcome = |o: merge::Outcome, how| match o {
                Some(Ok(case)) => {
                    report.cases.push(case);
                    bar.inc(1);
                    true
                }
                Some(Err(_)) => {
                    report.unattainable.push((kind, how));
                    false
                }
                None => false,
            };
            let (mut made, mut draws) = (0, 0);
            while made < opts.windows && draws < 20 * opts.windows {
                let s = own[rng.random_range(0..own.len())];
                made += outcome(
                    merge::window_case(&mut rng, s, made % 2 == 1),
                    merge::How::Window,
                ) as usize;
                draws += 1;
            }
            for (k, (ia, ib)) in pairs.into_iter().enumerate() {
                let o = merge::sessions_case(&mut rng, &sessions[ia], &sessions[ib], k % 2 == 1);
                if !outcome(o, merge::How::Sessions) {
                    bar.inc(1);
                }
            }
            let (mut made, mut draws) = (0, 0);
            while made < opts.negatives && draws < 20 * opts.negatives {
                if let Some(n) = merge::negative_case(&mut rng, sessions, kind, made % 2 == 1) {
                    report.negatives.push(n);
                    made += 1;
                    bar.inc(1);
                }
                draws += 1;
            }
        }
    }
    if opts.loops {
        let runs: Vec<(&Session, loops::Input)> = sessions
            .iter()
            .filter(|s| wanted(s.kind) && s.loops_judged())
            .flat_map(|s| loops::inputs(s).into_iter().map(move |i| (s, i)))
            .collect();
        bar.inc_length(runs.len() as u64 * opts.loop_seeds);
        for (k, (s, input)) in runs.into_iter().enumerate() {
            for n in 0..opts.loop_seeds {
                let seed = opts
                    .seed
                    .wrapping_mul(1_000_003)
                    .wrapping_add(k as u64 * 101 + n);
                report.loops.extend(loops::run(s, input, seed, opts.online));
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    Ok(report)
}
