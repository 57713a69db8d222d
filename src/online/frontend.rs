//! The caller's side of the detector: every pose goes through the guards and
//! the incremental stages (plane, chord, smoothing, differentials, signature,
//! boundaries) and leaves finalised samples in an [`Outbox`] for the worker.
//!
//! Parameters the batch path chooses from the whole path are chosen here
//! from a warm-up prefix: the plane, the stationary threshold, the typical
//! step (grid step = half of it) and the smoothing bandwidth (GCV on the
//! prefix, among the same multiples of the typical step). The warm-up poses
//! are then replayed through the streams, so nothing is lost. A path that
//! later moves many times faster than at its warm-up has them scaled with
//! its speed (`Streams::follow_speed`).

use nalgebra::{Vector2, Vector3};

use super::guard::{GuardCounts, JumpFilter, Passed};
use super::OnlineConfig;
use crate::geometry::Plane;
use crate::segments::BoundaryStream;
use crate::signature::{SigPoint, SignatureStream};
use crate::track::{
    ChordParam, ChordStream, DiffStream, GridPoint, GridStream, Smoother, TrackPoint,
};

/// Parameters of the incremental track, chosen at warm-up (or given).
#[derive(Debug, Clone, Copy)]
pub struct TrackParams {
    /// Plane of the path (3D -> 2D).
    pub plane: Plane,
    /// Stationary threshold (path units).
    pub min_step: f64,
    /// Typical step between kept poses.
    pub typical_step: f64,
    /// Grid step in the chord parameter.
    pub grid_step: f64,
    /// Kernel smoother.
    pub smoother: Smoother,
}

impl TrackParams {
    /// Chooses the parameters from a prefix of 3D positions, as the batch
    /// path does from a whole path. `None` when the prefix does not move.
    pub fn from_prefix(positions: &[Vector3<f64>]) -> Option<TrackParams> {
        let plane = Plane::fit(positions);
        let points: Vec<Vector2<f64>> = positions.iter().map(|p| plane.to_2d(p)).collect();
        let chord = ChordParam::new(&points)?;
        let smoother = Smoother::choose(&chord);
        let min_step = ChordParam::min_step_of(&points)?;
        Some(TrackParams {
            plane,
            min_step,
            typical_step: chord.typical_step,
            grid_step: crate::track::grid_step(chord.typical_step, smoother.bandwidth),
            smoother,
        })
    }
}

/// A finalised track sample as the history stores it.
#[derive(Debug, Clone, Copy)]
pub struct GridRec {
    /// Smoothed position (detector frame).
    pub xy: Vector2<f64>,
    /// Arc length.
    pub s: f64,
    /// Curvature.
    pub curvature: f64,
    /// Fractional pose index.
    pub pose: f64,
}

/// Finalised samples not yet handed to the worker.
#[derive(Debug, Clone, Default)]
pub struct Outbox {
    /// Track samples.
    pub grid: Vec<GridRec>,
    /// Signature samples.
    pub sig: Vec<SigPoint>,
    /// Finalised boundaries (signature sample indices).
    pub bounds: Vec<usize>,
    /// Keyframe ids by pose index.
    pub keyframes: Vec<(usize, u64)>,
}

impl Outbox {
    /// True when there is nothing to send.
    pub fn is_empty(&self) -> bool {
        self.grid.is_empty()
            && self.sig.is_empty()
            && self.bounds.is_empty()
            && self.keyframes.is_empty()
    }
}

/// The incremental stages after warm-up.
#[derive(Debug, Clone)]
pub struct Streams {
    /// Parameters in use.
    pub params: TrackParams,
    chord: ChordStream,
    grid: GridStream,
    diff: DiffStream,
    sig: SignatureStream,
    bounds: BoundaryStream,
    jumps: JumpFilter,
    /// The last position pushed (before the jump filter).
    raw_last: Option<Vector2<f64>>,
    /// Running median of the length of the moving steps (see
    /// [`Streams::follow_speed`]).
    median_step: f64,
}

/// The track's parameters are scaled with the path's speed once its moving
/// step has grown this many times past the one they were chosen for. A
/// drone that sits on the ground creeping a few hundredths of a millimetre
/// per pose through the warm-up flies at 200 times that: kept at the
/// warm-up's step, every flying step is a jump (92-96 % of UZH-FPV's
/// poses) and the grid hundreds of times finer than the poses. 8 stays a
/// third of the jump limit (`jump_factor`, 25 typical steps), so the
/// running median catches up before the steps are taken for jumps, and
/// above the 4-8 times by which walkers, hand-held cameras and drones that
/// take off by hand speed up after their warm-up, for which the warm-up's
/// choice holds (EuRoC and TUM-VI covered fewer revisit events when scaled
/// at 4). Only upwards: a
/// path that slows down is sampled as the batch path samples one whose
/// median step is its fast parts'.
const SPEED_CHANGE: f64 = 8.0;

/// The factor by which each moving step moves the running median of the
/// step length toward its own ([`Streams::follow_speed`]), e^0.02: a
/// sustained speed change of `SPEED_CHANGE` is followed within ln 8 / 0.02
/// = 104 steps, while the median of steadily mixed steps (back steps, stop
/// and go) stays within a few per cent.
const SPEED_RATE: f64 = 1.020_201_340_026_755_8;

impl Streams {
    /// Streams with these parameters.
    pub fn new(params: TrackParams, config: &OnlineConfig) -> Streams {
        let pc = &config.pipeline;
        Streams {
            params,
            chord: ChordStream::new(params.min_step),
            grid: GridStream::new(params.smoother, params.grid_step),
            diff: DiffStream::new(),
            sig: SignatureStream::new(&pc.signature),
            bounds: BoundaryStream::new(&pc.segments, pc.signature.dk),
            jumps: JumpFilter::new(params.typical_step, config.jump_factor),
            raw_last: None,
            median_step: params.typical_step,
        }
    }

    /// Follows the length of the moving steps (a running median in log
    /// length, steps below the stationary threshold left out) and scales
    /// the typical step, grid step, smoothing bandwidth and stationary
    /// threshold together once it has grown `SPEED_CHANGE` times: the same
    /// parameters the warm-up chose, at the speed the path now has. The
    /// steps are measured before the jump filter, which re-anchors the
    /// steps it takes for jumps to one typical step each.
    fn follow_speed(&mut self, xy: Vector2<f64>) {
        let last = self.raw_last.replace(xy);
        // Squared lengths: no square root nor logarithm on the caller's thread.
        let Some(d2) = last.map(|l| (xy - l).norm_squared()) else {
            return;
        };
        if d2 < self.chord.min_step * self.chord.min_step {
            return;
        }
        if d2 > self.median_step * self.median_step {
            self.median_step *= SPEED_RATE;
        } else {
            self.median_step /= SPEED_RATE;
        }
        let k = self.median_step / self.params.typical_step;
        if k < SPEED_CHANGE {
            return;
        }
        let p = &mut self.params;
        p.typical_step *= k;
        p.min_step *= k;
        p.smoother.bandwidth *= k;
        p.grid_step = crate::track::grid_step(p.typical_step, p.smoother.bandwidth);
        self.chord.min_step = p.min_step;
        self.grid.retune(p.smoother, p.grid_step);
        self.jumps.retune(p.typical_step);
    }

    /// Feeds pose `index` (3D position, already checked finite).
    pub fn push(
        &mut self,
        index: usize,
        p: &Vector3<f64>,
        counts: &mut GuardCounts,
        out: &mut Outbox,
    ) {
        let xy = self.params.plane.to_2d(p);
        self.follow_speed(xy);
        match self.jumps.push(index, xy, counts) {
            Passed::None => {}
            Passed::One((i, q)) => self.feed(i, q, out),
            Passed::Two([(i, q), (j, r)]) => {
                self.feed(i, q, out);
                self.feed(j, r, out);
            }
        }
    }

    /// Ends the stream: every remaining sample and boundary is finalised.
    pub fn flush(&mut self, counts: &mut GuardCounts, out: &mut Outbox) {
        if let Some((i, q)) = self.jumps.flush(counts) {
            self.feed(i, q, out);
        }
        let count = self.grid.count_for(self.chord.u());
        let Self {
            grid,
            diff,
            sig,
            bounds,
            ..
        } = self;
        grid.flush(count, &mut |g| on_grid(g, diff, sig, bounds, out));
        diff.flush(&mut |t| on_track(t, sig, bounds, out));
        sig.flush(&mut |p| on_sig(p, bounds, out));
        out.bounds.extend(bounds.flush());
    }

    fn feed(&mut self, index: usize, xy: Vector2<f64>, out: &mut Outbox) {
        let (u, kept) = self.chord.push(xy);
        if !kept {
            return;
        }
        let Self {
            grid,
            diff,
            sig,
            bounds,
            ..
        } = self;
        grid.push(u, xy, index, &mut |g| on_grid(g, diff, sig, bounds, out));
    }
}

fn on_grid(
    g: GridPoint,
    diff: &mut DiffStream,
    sig: &mut SignatureStream,
    bounds: &mut BoundaryStream,
    out: &mut Outbox,
) {
    diff.push(g, &mut |t| on_track(t, sig, bounds, out));
}

fn on_track(
    t: TrackPoint,
    sig: &mut SignatureStream,
    bounds: &mut BoundaryStream,
    out: &mut Outbox,
) {
    out.grid.push(GridRec {
        xy: t.xy,
        s: t.s,
        curvature: t.curvature,
        pose: t.pose,
    });
    sig.push(t.heading, t.curvature, t.s, &mut |p| on_sig(p, bounds, out));
}

fn on_sig(p: SigPoint, bounds: &mut BoundaryStream, out: &mut Outbox) {
    out.sig.push(p);
    if let Some(b) = bounds.push(p.s) {
        out.bounds.push(b);
    }
}

/// Warm-up buffer, then the streams.
#[derive(Debug, Clone)]
pub enum Frontend {
    /// Collecting the prefix that chooses the parameters.
    Warmup(Vec<(usize, Vector3<f64>)>),
    /// Running.
    Running(Box<Streams>),
}

impl Frontend {
    /// Feeds one checked pose; may end the warm-up (then replays it).
    pub fn push(
        &mut self,
        index: usize,
        p: Vector3<f64>,
        config: &OnlineConfig,
        counts: &mut GuardCounts,
        out: &mut Outbox,
    ) {
        match self {
            Frontend::Running(s) => s.push(index, &p, counts, out),
            Frontend::Warmup(buf) => {
                buf.push((index, p));
                // Past `warmup_max_poses` the prefix need only be moving
                // now: a robot idling with jitter for minutes gives no
                // parameters, and waits.
                let ready = match buf.len() {
                    n if n < config.warmup_min_poses => false,
                    n if n >= config.warmup_max_poses => moving_now(buf, config.warmup_min_poses),
                    _ => spans_plane(buf, config.plane_ratio),
                };
                if ready {
                    self.start(config, counts, out);
                }
            }
        }
    }

    /// Ends the warm-up now (with whatever prefix there is) and replays it.
    /// Returns false when the prefix does not move.
    pub fn start(
        &mut self,
        config: &OnlineConfig,
        counts: &mut GuardCounts,
        out: &mut Outbox,
    ) -> bool {
        let Frontend::Warmup(buf) = self else {
            return true;
        };
        let positions: Vec<Vector3<f64>> = buf.iter().map(|(_, p)| *p).collect();
        let Some(params) = TrackParams::from_prefix(&positions) else {
            return false;
        };
        let buf = std::mem::take(buf);
        self.start_with(params, config, counts, out, buf);
        true
    }

    /// Starts with given parameters (replaying `buf`).
    pub fn start_with(
        &mut self,
        params: TrackParams,
        config: &OnlineConfig,
        counts: &mut GuardCounts,
        out: &mut Outbox,
        buf: Vec<(usize, Vector3<f64>)>,
    ) {
        let mut streams = Box::new(Streams::new(params, config));
        for (i, p) in &buf {
            streams.push(*i, p, counts, out);
        }
        *self = Frontend::Running(streams);
    }

    /// The parameters, once running.
    pub fn params(&self) -> Option<&TrackParams> {
        match self {
            Frontend::Running(s) => Some(&s.params),
            Frontend::Warmup(_) => None,
        }
    }
}

/// Do the newest `n` poses go somewhere: most of them (three quarters) end
/// a run of [`RUN`] steps whose chord is at least [`STRAIGHT`] of its
/// length? Jitter of a robot standing still wanders (a random walk's chord
/// over 8 steps is about a third of its length), a robot that moves does
/// not, however slowly. Checked every 32 poses.
fn moving_now(buf: &[(usize, Vector3<f64>)], n: usize) -> bool {
    if !buf.len().is_multiple_of(32) || buf.len() < n + RUN {
        return false;
    }
    let recent = &buf[buf.len() - n - RUN..];
    let going = recent
        .windows(RUN + 1)
        .filter(|w| {
            let path: f64 = w.windows(2).map(|s| (s[1].1 - s[0].1).norm()).sum();
            path > 0.0 && (w[RUN].1 - w[0].1).norm() >= STRAIGHT * path
        })
        .count();
    4 * going >= 3 * n
}

/// Steps per run in [`moving_now`].
const RUN: usize = 8;
/// Chord over length of a run that moves.
const STRAIGHT: f64 = 0.7;

/// Does the prefix span a plane (not just a line)?
fn spans_plane(buf: &[(usize, Vector3<f64>)], ratio: f64) -> bool {
    // Checked every 32 poses: the eigen decomposition is not free.
    if !buf.len().is_multiple_of(32) {
        return false;
    }
    let n = buf.len() as f64;
    let c = buf.iter().fold(Vector3::zeros(), |a, (_, p)| a + p) / n;
    let mut m = nalgebra::Matrix3::zeros();
    for (_, p) in buf {
        let d = p - c;
        m += d * d.transpose();
    }
    let mut ev: Vec<f64> = nalgebra::SymmetricEigen::new(m)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    ev[1] > ratio * ev[2].max(0.0) && ev[1] > 1e-4 * ev[0]
}
