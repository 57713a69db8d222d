//! The matching worker: a thread that owns the history, takes finalised
//! samples from a bounded queue and answers with candidates on a channel.
//!
//! Overflow policy ([`Overflow`]): the caller never loses samples, only
//! matching work. With [`Overflow::MergeLatest`] (the default for live use)
//! a push that finds the queue full keeps its samples in the caller's outbox
//! and tries again on the next push; when the merged message finally goes
//! through, the worker caches every new segment but runs the queries of the
//! newest one only: the older ones are counted as `skipped`. Every deferred
//! send is counted as `deferred`. With [`Overflow::Block`] (file replay,
//! evaluation) the caller waits for room instead, so results do not depend
//! on timing: its queue holds at least 64 messages, and once full it is
//! waited out until half empty, so the worker neither starves between cheap
//! probes nor wakes the caller for every message it takes.

use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam::channel::{Receiver, Sender};
use serde::Serialize;

use super::events::{CandidateEvent, KeyframePair, Source};
use super::frontend::Outbox;
use super::history::History;
use super::network::register_newest;
use super::probe::{probe_newest, Probed};
use super::search::{verify_all, Frame, Searcher};
use super::OnlineConfig;

/// What to do when the worker's queue is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Overflow {
    /// Keep the samples, merge them into the next message, match only the
    /// newest segment of a merged message (live use: push never waits).
    #[default]
    MergeLatest,
    /// Wait for room (replaying a file: deterministic).
    Block,
}

/// One hand-over from the caller.
#[derive(Debug)]
pub struct Message {
    /// Sealed outboxes of deferred hand-overs, oldest first (their records
    /// come before `out`'s).
    pub earlier: Vec<Outbox>,
    /// Finalised samples.
    pub out: Outbox,
    /// Pose whose arrival produced the last of them.
    pub at_pose: usize,
    /// Track parameters.
    pub frame: Frame,
    /// Samples of deferred sends were merged into this message: only its
    /// newest segment is matched.
    pub merged: bool,
}

/// What the worker did.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct WorkerStats {
    /// Messages taken.
    pub messages: u64,
    /// Segments finalised.
    pub segments: u64,
    /// Segments whose queries ran.
    pub matched: u64,
    /// Segments whose queries were skipped (merged messages).
    pub skipped: u64,
    /// Periodic proximity probes run.
    pub probes: u64,
    /// Candidates emitted.
    pub candidates: u64,
    /// Time spent matching and verifying (seconds).
    pub busy_s: f64,
    /// Longest single matching (seconds).
    pub max_match_s: f64,
    /// History bytes at the end (samples, spectra, caches, index).
    pub history_bytes: u64,
    /// Track samples in the history.
    pub grid_samples: u64,
    /// Signature samples in the history.
    pub sig_samples: u64,
}

/// Starts the worker thread. `room`, if any, hears once the queue is half
/// empty (the replay's caller waits for that when the queue is full).
pub fn spawn(
    config: OnlineConfig,
    rx: Receiver<Message>,
    tx: Sender<CandidateEvent>,
    room: Option<Sender<()>>,
) -> JoinHandle<WorkerStats> {
    std::thread::Builder::new()
        .name("turnprint-online".into())
        .spawn(move || run(config, rx, tx, room))
        .expect("spawning the matching thread")
}

/// The state a worker keeps: exposed so benches can drive it without a
/// thread.
pub struct WorkerState {
    /// The history.
    pub history: History,
    /// The search state.
    pub searcher: Searcher,
    /// Statistics.
    pub stats: WorkerStats,
    next_id: u64,
    config: OnlineConfig,
}

impl WorkerState {
    /// An empty worker state.
    pub fn new(config: OnlineConfig) -> Self {
        WorkerState {
            history: History::default(),
            searcher: Searcher::new(&config),
            stats: WorkerStats::default(),
            next_id: 1,
            config,
        }
    }

    /// Takes one message: appends its samples, caches each new segment,
    /// matches the newest one. Returns the candidates.
    pub fn take(&mut self, m: Message) -> Vec<CandidateEvent> {
        self.stats.messages += 1;
        // The caller's deferred chunks and the newest, appended in order
        // straight into the history: joining them first would build (and
        // then free) one large buffer per merged message, and freeing
        // hundreds of megabytes stalls the caller's own allocations.
        let chunks: Vec<Outbox> = m.earlier.into_iter().chain([m.out]).collect();
        let h = &mut self.history;
        let ng = chunks.iter().map(|c| c.grid.len()).sum();
        let ns = chunks.iter().map(|c| c.sig.len()).sum();
        grow(&mut h.xy, ng);
        grow(&mut h.s, ng);
        grow(&mut h.curvature, ng);
        grow(&mut h.pose, ng);
        grow(&mut h.sig_value, ns);
        grow(&mut h.sig_grid, ns);
        let mut bounds = Vec::new();
        for c in &chunks {
            for g in &c.grid {
                h.xy.push([g.xy.x as f32, g.xy.y as f32]);
                h.s.push(g.s);
                h.curvature.push(g.curvature as f32);
                h.pose.push(g.pose.round().max(0.0) as u32);
            }
            for p in &c.sig {
                h.sig_value.push(p.value as f32);
                h.sig_grid.push(p.grid);
            }
            h.keyframes
                .extend(c.keyframes.iter().map(|&(p, k)| (p as u32, k)));
            bounds.extend_from_slice(&c.bounds);
        }
        drop(chunks);
        h.index_new_samples();
        self.searcher.update(h, &m.frame);
        let keep = self.config.pipeline.query.max_segments;
        let new = bounds.len();
        let mut events = Vec::new();
        for (i, &b) in bounds.iter().enumerate() {
            // A boundary already held is not new: the history's boundaries
            // stay increasing, which `History::window` bisects on.
            if self.history.bounds.last().is_some_and(|&l| l >= b) {
                continue;
            }
            self.history.bounds.push(b);
            let k = self.history.bounds.len() - 1;
            if k == 0 {
                continue;
            }
            self.stats.segments += 1;
            if m.merged && i + 1 < new {
                // Only the newest segment of a merged message is matched,
                // and its queries need only the last `keep` pieces.
                if i + keep >= new {
                    self.searcher.add_piece(&self.history, k, keep);
                }
                self.stats.skipped += 1;
                continue;
            }
            self.searcher.add_piece(&self.history, k, keep);
            events.extend(self.match_newest(&m.frame, m.at_pose, true));
        }
        if new == 0 && self.config.proximity {
            // A periodic hand-over without a new segment: the proximity
            // probe alone (straight revisits finalise no segment for long).
            events.extend(self.match_newest(&m.frame, m.at_pose, false));
        }
        events
    }

    /// Runs the queries of the newest segment.
    pub fn match_newest(
        &mut self,
        frame: &Frame,
        at_pose: usize,
        shape: bool,
    ) -> Vec<CandidateEvent> {
        let start = Instant::now();
        let h = &self.history;
        let segments = shape;
        let shape = if shape {
            self.stats.matched += 1;
            self.searcher.shape_candidates(h, &self.config)
        } else {
            self.stats.probes += 1;
            Vec::new()
        };
        let probed = match (&self.searcher.spatial, self.config.proximity) {
            (Some(sp), true) => probe_newest(
                h,
                sp,
                segments,
                2 * self.config.probe_every,
                // A periodic probe covers the newest two probe periods, so
                // every other one covers each sample once.
                match segments || self.stats.probes.is_multiple_of(2) {
                    true => self.config.drift_radius(),
                    false => 0.0,
                },
            ),
            _ => None,
        };
        let seed = probed.as_ref().and_then(Probed::seed);
        let mut found = verify_all(h, frame, &shape, seed, &self.config);
        // Where the probe found a road but nothing came of it, the newest
        // stretch placed on the whole network (a drifting map's search). A
        // proximity candidate short of the cut counts as nothing: the
        // consistent map's probe found it, and the drifting probe, which
        // would have looked farther, did not run.
        let weak = found
            .iter()
            .all(|f| f.source == Source::Proximity && f.hypothesis.score < self.config.min_score);
        if let (true, Some(probed)) = (weak, &probed) {
            found.extend(register_newest(
                h,
                &mut self.searcher,
                frame,
                probed,
                &self.config,
            ));
            // The registration adds up to two places after the ranking:
            // still at most `top_k` candidates, the best scores first.
            if found.len() > self.config.top_k {
                found.sort_by(|a, b| b.hypothesis.score.total_cmp(&a.hypothesis.score));
                found.truncate(self.config.top_k);
            }
        }
        let mut events = Vec::new();
        for f in found {
            let hy = f.hypothesis;
            events.push(CandidateEvent {
                id: self.next_id,
                at_pose,
                keyframes: keyframe_pair(h, &hy),
                query_keyframes: h.keyframes_in(hy.a_range, 8),
                match_keyframes: h.keyframes_in(hy.b_range, 8),
                hypothesis: hy,
                source: f.source,
            });
            self.next_id += 1;
        }
        self.stats.candidates += events.len() as u64;
        let dt = start.elapsed().as_secs_f64();
        self.stats.busy_s += dt;
        self.stats.max_match_s = self.stats.max_match_s.max(dt);
        events
    }

    /// Final figures.
    pub fn finish_stats(&mut self) -> WorkerStats {
        let h = &self.history;
        let pieces: usize = self
            .searcher
            .pieces
            .iter()
            .map(|p| (p.forward.capacity() + p.reversed.capacity()) * 4)
            .sum();
        let spatial = self.searcher.spatial.as_ref().map_or(0, |s| s.bytes());
        self.stats.history_bytes =
            (h.bytes() + self.searcher.correlator.bytes() + pieces + spatial) as u64;
        self.stats.grid_samples = h.xy.len() as u64;
        self.stats.sig_samples = h.sig_value.len() as u64;
        self.stats
    }
}

/// Makes room for `extra` more items, growing by an eighth at least
/// instead of doubling: still amortised O(1) per item, but at most 12.5 %
/// unused capacity in the history (memory per pose).
fn grow<T>(v: &mut Vec<T>, extra: usize) {
    if v.capacity() - v.len() < extra {
        v.reserve_exact(extra.max(v.len() / 8));
    }
}

/// The keyframe pair to verify a hypothesis with: the query keyframe
/// nearest the middle correspondence, and the match keyframe nearest the
/// pose that corresponds to it.
fn keyframe_pair(h: &History, hy: &crate::Hypothesis) -> Option<KeyframePair> {
    let mid = hy.correspondences.get(hy.correspondences.len() / 2)?;
    let (query_keyframe, query_pose) = h.keyframe_near(mid.0, hy.a_range)?;
    let corr = hy
        .correspondences
        .iter()
        .min_by_key(|c| c.0.abs_diff(query_pose))?;
    let (match_keyframe, match_pose) = h.keyframe_near(corr.1, hy.b_range)?;
    Some(KeyframePair {
        query_keyframe,
        query_pose,
        match_keyframe,
        match_pose,
    })
}

fn run(
    config: OnlineConfig,
    rx: Receiver<Message>,
    tx: Sender<CandidateEvent>,
    room: Option<Sender<()>>,
) -> WorkerStats {
    let mut state = WorkerState::new(config);
    let half = rx.capacity().unwrap_or(0) / 2;
    while let Ok(m) = rx.recv() {
        if let Some(room) = &room {
            if rx.len() <= half {
                // Full already when the caller has not taken the last word.
                let _ = room.try_send(());
            }
        }
        for e in state.take(m) {
            // The caller may have dropped its receiver: keep working.
            let _ = tx.send(e);
        }
    }
    state.finish_stats()
}

/// How long [`super::Detector::finish`] waits for the worker.
pub const FINISH_TIMEOUT: Duration = Duration::from_secs(600);
