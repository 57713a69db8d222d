//! A robot's history as this process holds it: the library's online
//! [`History`] rebuilt from the robot's chunks (the decimated track filled
//! in linearly), and the chunks cut from a detector's finalised samples.
//! The process's own history goes through the same two steps, so that both
//! sides of a match are what every robot of the fleet sees.

use turnprint::online::frontend::Outbox;
use turnprint::online::history::History;
use turnprint::pipeline::PreparedPath;

use crate::payload::{Chunk, FrameInfo, KeptSample, DECIMATION};

/// Cuts a detector's finalised samples into chunks.
#[derive(Debug)]
pub struct Encoder {
    epoch: u64,
    seq: u32,
    grid: u32,
    sig: u32,
}

impl Encoder {
    /// An encoder for the session `epoch`.
    pub fn new(epoch: u64) -> Encoder {
        Encoder {
            epoch,
            seq: 0,
            grid: 0,
            sig: 0,
        }
    }

    /// The chunk of `out` (the samples finalised since the last chunk),
    /// after `poses` poses, in `frame`; `last` when the stream ends.
    pub fn chunk(&mut self, out: &Outbox, poses: usize, frame: FrameInfo, last: bool) -> Chunk {
        let g0 = self.grid as usize;
        let n = out.grid.len();
        let kept = out
            .grid
            .iter()
            .enumerate()
            .filter(|(i, _)| (g0 + i).is_multiple_of(DECIMATION) || i + 1 == n)
            .map(|(i, g)| KeptSample {
                index: (g0 + i) as u32,
                xy: [g.xy.x as f32, g.xy.y as f32],
                s: g.s,
                curvature: g.curvature as f32,
                pose: g.pose.max(0.0) as f32,
            })
            .collect();
        let chunk = Chunk {
            epoch: self.epoch,
            seq: self.seq,
            last,
            poses: poses as u32,
            frame,
            grid_end: (g0 + n) as u32,
            kept,
            sig0: self.sig,
            sig: out.sig.iter().map(|p| (p.value as f32, p.grid)).collect(),
            bounds: out.bounds.iter().map(|&b| b as u32).collect(),
        };
        self.seq += 1;
        self.grid += n as u32;
        self.sig += out.sig.len() as u32;
        chunk
    }
}

/// Bytes a robot's history may hold (its track, signature and index:
/// [`History::bytes`]) before its older half is dropped: 64 MiB, about
/// 500 000 poses at the 80-160 bytes a pose of a peer's rebuilt history
/// takes (14 hours of a robot at 10 poses a second), so that a fleet's
/// memory stays bounded by its robots rather than by how long they run.
pub const HISTORY_BUDGET: usize = 64 << 20;

/// What a history dropped from its start: the held parts' first items'
/// indices in the robot's whole history.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Dropped {
    /// Track samples.
    pub grid: usize,
    /// Signature samples.
    pub sig: usize,
    /// Segment boundaries.
    pub bounds: usize,
}

/// One robot's history, rebuilt from its chunks in order; past its budget,
/// only its newer half is held.
pub struct RobotHistory {
    /// The samples held, as the online search reads them (indices from the
    /// first held item; pose indices and arc lengths are the robot's own).
    pub history: History,
    /// The robot's frame (its plane from its first chunk, its grid step and
    /// bandwidth from its newest).
    pub frame: Option<FrameInfo>,
    /// Poses the robot had pushed at its last chunk.
    pub poses: usize,
    /// Its last kept track sample (the start of the next fill; its index
    /// is the robot's own).
    last: Option<KeptSample>,
    /// What was dropped from the start.
    dropped: Dropped,
    /// Arc length where the robot's track starts.
    origin: Option<f64>,
    /// Bytes held at most ([`HISTORY_BUDGET`]).
    budget: usize,
    /// Joined late and not started yet: the first chunk with track samples
    /// starts the history wherever it lies in the robot's track.
    late: bool,
}

impl Default for RobotHistory {
    fn default() -> Self {
        Self::with_budget(HISTORY_BUDGET)
    }
}

impl RobotHistory {
    /// An empty history that holds at most `budget` bytes.
    pub fn with_budget(budget: usize) -> Self {
        RobotHistory {
            history: History::default(),
            frame: None,
            poses: 0,
            last: None,
            dropped: Dropped::default(),
            origin: None,
            budget,
            late: false,
        }
    }

    /// An empty history of a robot whose older chunks are served no more
    /// (the sender's store is bounded): it starts at the first track sample
    /// of the first chunk given, wherever that lies in the robot's track,
    /// and counts segments from there ([`Self::dropped`] holds where it
    /// started, with no boundaries).
    pub fn joining_late(budget: usize) -> Self {
        RobotHistory {
            late: true,
            ..Self::with_budget(budget)
        }
    }

    /// What the history dropped from its start.
    pub fn dropped(&self) -> Dropped {
        self.dropped
    }

    /// Appends the next chunk: its track samples filled in between the
    /// kept ones, its signature samples and boundaries. A chunk that does
    /// not continue the history is refused whole (the history is left as
    /// it was). Past the budget, the older half is dropped at a segment boundary.
    pub fn apply(&mut self, c: &Chunk) -> Result<(), String> {
        if self.late {
            return self.start(c);
        }
        let h = &self.history;
        let d = self.dropped;
        let sig_held = d.sig + h.sig_value.len();
        if c.sig0 as usize != sig_held {
            return Err(format!(
                "signature samples from {} where {sig_held} are held",
                c.sig0
            ));
        }
        // The grid step and bandwidth grow with the robot's speed
        // (`turnprint::online::frontend`): the newest hold. Its plane and
        // signature step are fixed for its session.
        if self
            .frame
            .is_some_and(|f| f.plane != c.frame.plane || f.dk != c.frame.dk)
        {
            return Err("the robot's frame changed within its session".into());
        }
        let held = d.grid + h.xy.len();
        match (c.kept.first(), self.last) {
            (None, _) if c.grid_end as usize != held => {
                return Err("track samples announced but not sent".into())
            }
            (Some(k), None) if k.index as usize != d.grid => {
                return Err(format!("the track does not start at {}", d.grid))
            }
            (Some(k), Some(l)) if k.index <= l.index || k.s < l.s || k.pose < l.pose => {
                return Err("the track does not continue".into())
            }
            _ => {}
        }
        let grid_of = |g: f64| g + d.grid as f64;
        let sig_ok = c.sig.first().is_none_or(|s| {
            h.sig_grid.last().is_none_or(|&g| grid_of(g) <= s.1) && s.1 <= c.grid_end as f64
        }) && c.sig.last().is_none_or(|s| s.1 <= c.grid_end as f64)
            && c.sig.windows(2).all(|w| w[0].1 <= w[1].1);
        if !sig_ok {
            return Err("signature samples outside the track".into());
        }
        let n_sig = sig_held + c.sig.len();
        let bounds_ok = c
            .bounds
            .first()
            .is_none_or(|&b| h.bounds.last().is_none_or(|&l| d.sig + l < b as usize))
            && c.bounds.windows(2).all(|w| w[0] < w[1])
            && c.bounds
                .iter()
                .all(|&b| b as usize >= d.sig && b as usize <= n_sig);
        if !bounds_ok {
            return Err("segment boundaries outside the signature".into());
        }
        let h = &mut self.history;
        for k in &c.kept {
            let from = self.last.unwrap_or(*k);
            let span = (k.index - from.index).max(1) as f64;
            for i in (from.index + u32::from(self.last.is_some()))..=k.index {
                let t = (i - from.index) as f64 / span;
                let lerp = |a: f64, b: f64| a + t * (b - a);
                h.xy.push([
                    lerp(from.xy[0] as f64, k.xy[0] as f64) as f32,
                    lerp(from.xy[1] as f64, k.xy[1] as f64) as f32,
                ]);
                h.s.push(lerp(from.s, k.s));
                h.curvature
                    .push(lerp(from.curvature as f64, k.curvature as f64) as f32);
                h.pose
                    .push(lerp(from.pose as f64, k.pose as f64).round() as u32);
            }
            self.origin.get_or_insert(k.s);
            self.last = Some(*k);
        }
        for &(v, g) in &c.sig {
            h.sig_value.push(v);
            h.sig_grid.push(g - d.grid as f64);
        }
        h.bounds
            .extend(c.bounds.iter().map(|&b| b as usize - d.sig));
        h.index_new_samples();
        self.frame = Some(c.frame);
        self.poses = self.poses.max(c.poses as usize);
        if self.history.bytes() > self.budget {
            self.trim();
        }
        Ok(())
    }

    /// The first chunk of a history joined late: its samples from its first
    /// kept track sample on (the signature samples and boundaries before
    /// it lie on track samples that were not sent). A chunk without track
    /// samples is passed over.
    fn start(&mut self, c: &Chunk) -> Result<(), String> {
        let Some(k0) = c.kept.first() else {
            return Ok(());
        };
        let skip = c.sig.iter().take_while(|s| s.1 < k0.index as f64).count();
        let sig0 = c.sig0.saturating_add(skip as u32);
        let tail = Chunk {
            sig0,
            sig: c.sig[skip..].to_vec(),
            bounds: c.bounds.iter().copied().filter(|&b| b >= sig0).collect(),
            ..c.clone()
        };
        self.late = false;
        self.dropped = Dropped {
            grid: k0.index as usize,
            sig: sig0 as usize,
            bounds: 0,
        };
        let applied = self.apply(&tail);
        if applied.is_err() {
            self.late = true;
            self.dropped = Dropped::default();
        }
        applied
    }

    /// Drops the older half of the history held: everything before the
    /// first segment boundary at or past its middle track sample (a cut
    /// between boundaries would leave a segment without its start). The
    /// places dropped can no longer be matched; where another robot was
    /// placed through them, its hypotheses stay.
    fn trim(&mut self) {
        let h = &mut self.history;
        let middle = (h.xy.len() / 2) as f64;
        let Some(first) = h
            .bounds
            .iter()
            .position(|&b| h.sig_grid.get(b).is_some_and(|&g| g >= middle))
            .filter(|&k| k > 0)
        else {
            return;
        };
        let sig_cut = h.bounds[first];
        let grid_cut = h.sig_grid[sig_cut].max(0.0) as usize;
        let pose_cut = h.pose[grid_cut];
        h.xy.drain(..grid_cut);
        h.s.drain(..grid_cut);
        h.curvature.drain(..grid_cut);
        h.pose.drain(..grid_cut);
        h.sig_value.drain(..sig_cut);
        h.sig_grid.drain(..sig_cut);
        for g in &mut h.sig_grid {
            *g -= grid_cut as f64;
        }
        h.bounds.drain(..first);
        for b in &mut h.bounds {
            *b -= sig_cut;
        }
        h.keyframes.retain(|&(p, _)| p >= pose_cut);
        h.xy.shrink_to_fit();
        h.s.shrink_to_fit();
        h.curvature.shrink_to_fit();
        h.pose.shrink_to_fit();
        h.sig_value.shrink_to_fit();
        h.sig_grid.shrink_to_fit();
        h.bounds.shrink_to_fit();
        h.keyframes.shrink_to_fit();
        h.index = Default::default();
        h.index_new_samples();
        self.dropped = Dropped {
            grid: self.dropped.grid + grid_cut,
            sig: self.dropped.sig + sig_cut,
            bounds: self.dropped.bounds + first,
        };
    }

    /// Segment boundaries the robot has sent (held and dropped).
    pub fn segments(&self) -> usize {
        self.dropped.bounds + self.history.bounds.len()
    }

    /// Arc length of the robot's whole track.
    pub fn length(&self) -> f64 {
        match (self.origin, self.history.s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// The history from segment boundary `k` (the robot's count, clamped
    /// to those held) to its end as a prepared path (pose indices are the
    /// robot's own).
    pub fn window_from(&self, k: usize) -> Option<PreparedPath> {
        self.window_between(k, None)
    }

    /// The history from segment boundary `k0` to boundary `k1` (its end
    /// with `None`; both the robot's count, clamped to those held) as a
    /// prepared path.
    pub fn window_between(&self, k0: usize, k1: Option<usize>) -> Option<PreparedPath> {
        let frame = self.frame?;
        let held = |k: usize| k.saturating_sub(self.dropped.bounds);
        let (k0, k1) = (held(k0), k1.map(held));
        let h = self.history.now();
        let last = h.xy.len().checked_sub(1)?;
        let grid = |k: usize| {
            let b = h.bounds.get(k.min(h.bounds.len().checked_sub(1)?))?;
            h.sig_grid.get(*b).map(|g| g.max(0.0) as usize)
        };
        let g0 = match k0 {
            0 => 0,
            _ => grid(k0).unwrap_or(0),
        };
        let g1 = match k1 {
            Some(k) if k + 1 < h.bounds.len() => grid(k).map_or(last, |g| (g + 1).min(last)),
            _ => last,
        };
        let w = h.window(
            g0,
            g1,
            &frame.plane,
            frame.step,
            frame.bandwidth,
            frame.dk,
            self.poses.max(1),
        )?;
        Some(w.path)
    }

    /// Where the robot was at its pose `pose`, in its 3D frame: the held
    /// track sample of that pose (or the next one); `None` when the pose is
    /// not held (dropped, or not yet received).
    pub fn position_of(&self, pose: usize) -> Option<nalgebra::Vector3<f64>> {
        let frame = self.frame?;
        let poses = &self.history.pose;
        if poses.first().is_none_or(|&p| p as usize > pose) {
            return None;
        }
        let i = poses.partition_point(|&p| (p as usize) < pose);
        Some(lifted(&frame, self.history.xy.get(i)?))
    }

    /// About `n` points of the track in the robot's 3D frame, evenly
    /// spread (for comparing placements).
    pub fn points3(&self, n: usize) -> Vec<nalgebra::Vector3<f64>> {
        let Some(frame) = self.frame else {
            return Vec::new();
        };
        let xy = &self.history.xy;
        let stride = xy.len().div_ceil(n.max(1)).max(1);
        xy.iter()
            .step_by(stride)
            .map(|p| lifted(&frame, p))
            .collect()
    }
}

/// A track sample's plane coordinates in the robot's 3D frame.
fn lifted(frame: &FrameInfo, p: &[f32; 2]) -> nalgebra::Vector3<f64> {
    frame.plane.origin
        + frame.plane.world_R_plane * nalgebra::Vector3::new(p[0] as f64, p[1] as f64, 0.0)
}
