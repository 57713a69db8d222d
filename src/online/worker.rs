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
//!
//! Several workers ([`OnlineConfig::workers`]) each take every message (one
//! shared copy) into their own history and run every n-th matching. A
//! matching depends only on the history so far, so it runs wherever it
//! falls; what depends on earlier matchings (a registration too soon after
//! the previous one, the top-k after it, the ids) is settled in stream order
//! ([`Settle`]): the candidates are the same with any number of workers.
//! A segment's piece of correlations with the history, the same in every
//! worker, is computed by the first to need it and taken by the others
//! ([`super::correlator::SharedPieces`]). A worker lost to a panic (a bug)
//! reports it as its thread unwinds; the settler then passes over its
//! matchings, and the caller counts it (`Summary::workers_lost`).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use crossbeam::channel::{Receiver, Sender};
use serde::Serialize;

use super::correlator::SharedPieces;
use super::events::{CandidateEvent, KeyframePair, Source};
use super::frontend::Outbox;
use super::history::History;
use super::network::{register_newest, too_soon};
use super::probe::{probe_newest, Probed};
use super::search::{verify_all, Found, Frame, Searcher};
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
    /// Segments whose queries ran (summed over the workers).
    pub matched: u64,
    /// Segments whose queries were skipped (merged messages).
    pub skipped: u64,
    /// Periodic proximity probes run (summed over the workers).
    pub probes: u64,
    /// Candidates emitted (counted where they are settled, filled in by
    /// `Detector::finish`).
    pub candidates: u64,
    /// Time spent matching and verifying (seconds).
    pub busy_s: f64,
    /// Longest single matching (seconds).
    pub max_match_s: f64,
    /// History bytes at the end (samples, spectra, caches, index; every
    /// worker's copy).
    pub history_bytes: u64,
    /// Track samples in the history.
    pub grid_samples: u64,
    /// Signature samples in the history.
    pub sig_samples: u64,
}

impl WorkerStats {
    /// The figures of several workers as one: each takes every message and
    /// keeps every sample (the first one's counts), and runs its share of
    /// the matchings (summed); the history bytes are all the copies'. The
    /// candidates are counted where they are settled, not here.
    pub fn combined(workers: &[WorkerStats]) -> WorkerStats {
        let Some(first) = workers.first() else {
            return WorkerStats::default();
        };
        let sum = |f: fn(&WorkerStats) -> u64| workers.iter().map(f).sum();
        WorkerStats {
            matched: sum(|w| w.matched),
            probes: sum(|w| w.probes),
            history_bytes: sum(|w| w.history_bytes),
            busy_s: workers.iter().map(|w| w.busy_s).sum(),
            max_match_s: workers.iter().map(|w| w.max_match_s).fold(0.0, f64::max),
            ..*first
        }
    }
}

/// Where a worker's matchings go.
pub enum Sink {
    /// The only worker: its matchings settled in place, the candidates to
    /// the caller.
    Caller(Sender<CandidateEvent>, Settle),
    /// One of several: to the thread that settles them in stream order.
    Settler(Sender<Report>),
}

/// What a worker tells the settling thread.
#[derive(Debug)]
pub enum Report {
    /// One of its matchings.
    Matched(Matched),
    /// Worker `replica` stopped (it panicked): its later matchings will not
    /// come, and the settler no longer waits for them.
    Lost(usize),
}

/// Tells the settler and the shared pieces when its worker's thread
/// unwinds from a panic, so the other workers' candidates keep flowing
/// instead of waiting for matchings that will never come, and no piece is
/// held for ever for the lost worker.
struct Mourner {
    tx: Option<Sender<Report>>,
    pieces: Option<Arc<SharedPieces>>,
    replica: usize,
}

impl Drop for Mourner {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            return;
        }
        if let Some(tx) = &self.tx {
            let _ = tx.send(Report::Lost(self.replica));
        }
        if let Some(pieces) = &self.pieces {
            pieces.leave();
        }
    }
}

/// Starts a worker with `state`. `room`, if any, hears once its queue is
/// half empty (the replay's caller waits for that when the queue is full).
pub fn spawn(
    state: WorkerState,
    rx: Receiver<Arc<Message>>,
    sink: Sink,
    room: Option<Sender<()>>,
) -> JoinHandle<WorkerStats> {
    std::thread::Builder::new()
        .name(format!("turnprint-online-{}", state.replica))
        .spawn(move || run(state, rx, sink, room))
        .expect("spawning the matching thread")
}

/// Starts the thread that settles the matchings of several workers in
/// stream order with `settle` and hands their candidates to the caller.
pub fn spawn_settler(
    mut settle: Settle,
    workers: usize,
    rx: Receiver<Report>,
    tx: Sender<CandidateEvent>,
) -> JoinHandle<()> {
    let mut order = InOrder::new(workers);
    std::thread::Builder::new()
        .name("turnprint-settle".into())
        .spawn(move || {
            let mut send = |m: Matched| {
                for e in settle.settle(m) {
                    let _ = tx.send(e);
                }
            };
            for report in rx {
                order.take(report);
                while let Some(m) = order.next_ready() {
                    send(m);
                }
            }
            // Every worker has stopped: what still waits follows a gap that
            // will never be filled.
            while let Some((_, m)) = order.waiting.pop_first() {
                send(m);
            }
        })
        .expect("spawning the settling thread")
}

/// The matchings of several workers, put back in stream order.
struct InOrder {
    /// Matchings by number until their turn comes.
    waiting: BTreeMap<u64, Matched>,
    /// Lost workers: their numbers are passed over.
    lost: Vec<u64>,
    next: u64,
    workers: u64,
}

impl InOrder {
    fn new(workers: usize) -> Self {
        InOrder {
            waiting: BTreeMap::new(),
            lost: Vec::new(),
            next: 0,
            workers: workers.max(1) as u64,
        }
    }

    fn take(&mut self, report: Report) {
        match report {
            Report::Matched(m) => {
                self.waiting.insert(m.matching, m);
            }
            Report::Lost(replica) => self.lost.push(replica as u64),
        }
    }

    /// The next matching in stream order, if it has come. A lost worker
    /// sent every matching it finished before it reported the loss, so a
    /// number of its that has not come never will.
    fn next_ready(&mut self) -> Option<Matched> {
        loop {
            if let Some(m) = self.waiting.remove(&self.next) {
                self.next += 1;
                return Some(m);
            }
            let lost = self.lost.contains(&(self.next % self.workers));
            if !lost || self.lost.len() as u64 >= self.workers {
                return None;
            }
            self.next += 1;
        }
    }
}

/// One matching's candidates before they are settled: the searches', best
/// first, and the network registration's, if one was due (its window's
/// newest sample and candidates). Ids are given when settled.
#[derive(Debug)]
pub struct Matched {
    /// The matching's number in the stream (every worker counts them all).
    pub matching: u64,
    /// The searches' candidates.
    pub found: Vec<CandidateEvent>,
    /// The registration's, if due.
    pub registered: Option<(usize, Vec<CandidateEvent>)>,
}

/// What is decided across matchings, in stream order: a registration too
/// soon after the previous one is dropped, the top-k kept, ids given. With
/// several workers a matching runs while the previous one may still be
/// running elsewhere, so nothing a matching computes depends on these.
pub struct Settle {
    last_registered: Option<usize>,
    next_id: u64,
    /// Candidates settled, counted where the caller can read them even if
    /// the thread settling them is lost.
    emitted: Arc<AtomicU64>,
    top_k: usize,
    probe_every: usize,
}

impl Settle {
    /// Nothing settled yet; the candidates are counted in `emitted`.
    pub fn new(config: &OnlineConfig, emitted: Arc<AtomicU64>) -> Self {
        Settle {
            last_registered: None,
            next_id: 1,
            emitted,
            top_k: config.top_k,
            probe_every: config.probe_every,
        }
    }

    /// The candidates of the next matching in stream order.
    pub fn settle(&mut self, m: Matched) -> Vec<CandidateEvent> {
        let mut events = m.found;
        if let Some((g1, registered)) = m.registered {
            if !too_soon(self.last_registered, g1, self.probe_every) {
                self.last_registered = Some(g1);
                events.extend(registered);
                // The registration adds up to two places after the
                // ranking: still at most `top_k` candidates, the best
                // scores first.
                if events.len() > self.top_k {
                    events.sort_by(|a, b| b.hypothesis.score.total_cmp(&a.hypothesis.score));
                    events.truncate(self.top_k);
                }
            }
        }
        for e in &mut events {
            e.id = self.next_id;
            self.next_id += 1;
        }
        self.emitted
            .fetch_add(events.len() as u64, Ordering::Relaxed);
        events
    }
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
    config: OnlineConfig,
    /// This worker runs the matchings numbered `replica` modulo
    /// `config.workers`.
    replica: usize,
    /// Matchings so far, this worker's and the others'.
    matchings: u64,
    /// Periodic probes so far, this worker's and the others'.
    periodic: u64,
    /// A test's injected panic at this matching ([`FAIL_AT`]).
    #[cfg(test)]
    fail_at: Option<u64>,
}

#[cfg(test)]
thread_local! {
    /// A test's injected failure: worker `.0` of the detectors this thread
    /// builds panics at its matching numbered `.1`.
    pub(crate) static FAIL_AT: std::cell::Cell<Option<(usize, u64)>> =
        const { std::cell::Cell::new(None) };
}

impl WorkerState {
    /// An empty worker state (the only worker).
    pub fn new(config: OnlineConfig) -> Self {
        Self::replica(config, 0, None)
    }

    /// Worker `replica` of `config.workers`, sharing `pieces` with the
    /// others.
    pub fn replica(
        config: OnlineConfig,
        replica: usize,
        pieces: Option<Arc<SharedPieces>>,
    ) -> Self {
        let mut searcher = Searcher::new(&config);
        searcher.shared = pieces;
        WorkerState {
            history: History::default(),
            searcher,
            stats: WorkerStats::default(),
            config,
            replica,
            matchings: 0,
            periodic: 0,
            #[cfg(test)]
            fail_at: FAIL_AT.get().and_then(|(r, m)| (r == replica).then_some(m)),
        }
    }

    /// Takes one message: appends its samples, caches each new segment,
    /// matches the newest one. Returns this worker's matchings.
    pub fn take(&mut self, m: &Message) -> Vec<Matched> {
        self.stats.messages += 1;
        // The caller's deferred chunks and the newest, appended in order
        // straight into the history: joining them first would build (and
        // then free) one large buffer per merged message, and freeing
        // hundreds of megabytes stalls the caller's own allocations.
        let chunks: Vec<&Outbox> = m.earlier.iter().chain([&m.out]).collect();
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
        h.index_new_samples();
        self.searcher.update(h, &m.frame);
        let keep = self.config.pipeline.query.max_segments;
        let new = bounds.len();
        let mut matched = Vec::new();
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
            matched.extend(self.match_newest(&m.frame, m.at_pose, true));
        }
        if new == 0 && self.config.proximity {
            // A periodic hand-over without a new segment: the proximity
            // probe alone (straight revisits finalise no segment for long).
            matched.extend(self.match_newest(&m.frame, m.at_pose, false));
        }
        matched
    }

    /// Runs the queries of the newest segment (`shape`) or the periodic
    /// probe, if this matching is this worker's.
    pub fn match_newest(&mut self, frame: &Frame, at_pose: usize, shape: bool) -> Option<Matched> {
        let matching = self.matchings;
        self.matchings += 1;
        if !shape {
            self.periodic += 1;
        }
        if matching % self.config.workers.max(1) as u64 != self.replica as u64 {
            return None;
        }
        #[cfg(test)]
        if self.fail_at == Some(matching) {
            panic!(
                "injected failure of worker {} at matching {matching}",
                self.replica
            );
        }
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
                match segments || self.periodic.is_multiple_of(2) {
                    true => self.config.drift_radius(),
                    false => 0.0,
                },
            ),
            _ => None,
        };
        let seed = probed.as_ref().and_then(Probed::seed);
        let found = verify_all(h, frame, &shape, seed, &self.config);
        // Where the probe found a road but nothing came of it, the newest
        // stretch placed on the whole network (a drifting map's search). A
        // proximity candidate short of the cut counts as nothing: the
        // consistent map's probe found it, and the drifting probe, which
        // would have looked farther, did not run.
        let weak = found
            .iter()
            .all(|f| f.source == Source::Proximity && f.hypothesis.score < self.config.min_score);
        let registered = match (weak, &probed) {
            (true, Some(probed)) => register_newest(h, &self.searcher, frame, probed, &self.config),
            _ => None,
        };
        let event = |f: Found| {
            let hy = f.hypothesis;
            CandidateEvent {
                id: 0,
                at_pose,
                keyframes: keyframe_pair(h, &hy),
                query_keyframes: h.keyframes_in(hy.a_range, 8),
                match_keyframes: h.keyframes_in(hy.b_range, 8),
                hypothesis: hy,
                source: f.source,
            }
        };
        let matched = Matched {
            matching,
            found: found.into_iter().map(event).collect(),
            registered: registered.map(|(g1, r)| (g1, r.into_iter().map(event).collect())),
        };
        let dt = start.elapsed().as_secs_f64();
        self.stats.busy_s += dt;
        self.stats.max_match_s = self.stats.max_match_s.max(dt);
        Some(matched)
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
    mut state: WorkerState,
    rx: Receiver<Arc<Message>>,
    mut sink: Sink,
    room: Option<Sender<()>>,
) -> WorkerStats {
    let _mourner = Mourner {
        tx: match &sink {
            Sink::Settler(tx) => Some(tx.clone()),
            Sink::Caller(..) => None,
        },
        pieces: state.searcher.shared.clone(),
        replica: state.replica,
    };
    let half = rx.capacity().unwrap_or(0) / 2;
    while let Ok(m) = rx.recv() {
        if let Some(room) = &room {
            if rx.len() <= half {
                // Full already when the caller has not taken the last word.
                let _ = room.try_send(());
            }
        }
        for matched in state.take(&m) {
            // The caller may have dropped its receiver: keep working.
            match &mut sink {
                Sink::Caller(tx, settle) => {
                    for e in settle.settle(matched) {
                        let _ = tx.send(e);
                    }
                }
                Sink::Settler(tx) => {
                    let _ = tx.send(Report::Matched(matched));
                }
            }
        }
    }
    state.finish_stats()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(score: f64, source: Source) -> CandidateEvent {
        CandidateEvent {
            id: 0,
            at_pose: 0,
            hypothesis: crate::Hypothesis::scored(score, [0, 1], [0, 1], false),
            source,
            keyframes: None,
            query_keyframes: Vec::new(),
            match_keyframes: Vec::new(),
        }
    }

    fn scores(events: &[CandidateEvent]) -> Vec<(u64, f64)> {
        events.iter().map(|e| (e.id, e.hypothesis.score)).collect()
    }

    #[test]
    fn settling_drops_a_registration_too_soon_keeps_the_top_k_and_numbers_in_order() {
        let config = OnlineConfig::default();
        let every = config.probe_every;
        let emitted = Arc::new(AtomicU64::new(0));
        let mut settle = Settle::new(&config, emitted.clone());
        let registered = |g1: usize, scores: &[f64]| {
            Some((
                g1,
                scores.iter().map(|&s| event(s, Source::Network)).collect(),
            ))
        };
        // Registered: two searches' candidates and two places, best three
        // kept, best first.
        let first = settle.settle(Matched {
            matching: 0,
            found: vec![event(0.2, Source::Proximity), event(0.1, Source::Proximity)],
            registered: registered(1000, &[0.3, 0.05]),
        });
        assert_eq!(scores(&first), [(1, 0.3), (2, 0.2), (3, 0.1)]);
        // A few samples later: the registration is dropped, the searches'
        // candidate kept.
        let soon = settle.settle(Matched {
            matching: 1,
            found: vec![event(0.4, Source::Shape)],
            registered: registered(1000 + every - 1, &[0.9]),
        });
        assert_eq!(scores(&soon), [(4, 0.4)]);
        // A period after the last one that counted: kept.
        let later = settle.settle(Matched {
            matching: 2,
            found: Vec::new(),
            registered: registered(1000 + every, &[0.6]),
        });
        assert_eq!(scores(&later), [(5, 0.6)]);
        assert_eq!(emitted.load(Ordering::Relaxed), 5);
    }

    fn matched(matching: u64) -> Report {
        Report::Matched(Matched {
            matching,
            found: Vec::new(),
            registered: None,
        })
    }

    #[test]
    fn a_lost_workers_numbers_are_passed_over_and_the_others_still_come_in_order() {
        let mut order = InOrder::new(3);
        for m in [0, 2, 3, 5] {
            order.take(matched(m));
        }
        let ready = |order: &mut InOrder| {
            std::iter::from_fn(|| order.next_ready().map(|m| m.matching)).collect::<Vec<_>>()
        };
        // 1 is worker 1's: waited for.
        assert_eq!(ready(&mut order), vec![0]);
        // Worker 1 is lost: its 1 and 4 never come.
        order.take(Report::Lost(1));
        assert_eq!(ready(&mut order), vec![2, 3, 5]);
        order.take(matched(6));
        assert_eq!(ready(&mut order), vec![6]);
        // Every worker lost: nothing is skipped for ever.
        order.take(Report::Lost(0));
        order.take(Report::Lost(2));
        order.take(matched(9));
        assert_eq!(ready(&mut order), Vec::<u64>::new());
    }

    /// KITTI 00's ground truth replayed by `workers` workers, worker
    /// `fail.0` panicking at its matching `fail.1`: the candidates in
    /// arrival order, the summary, and the losses seen before `finish`.
    fn replay_failing(
        workers: usize,
        fail: Option<(usize, u64)>,
    ) -> (Vec<CandidateEvent>, super::super::Summary, u64) {
        use super::super::{Detector, PoseInput};
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/00.txt");
        let points = crate::io::read_trajectory(path.as_ref(), crate::io::Format::Kitti)
            .expect(path)
            .positions();
        FAIL_AT.set(fail);
        let config = OnlineConfig {
            workers,
            ..Default::default()
        };
        let mut det = Detector::new(config, Overflow::Block);
        FAIL_AT.set(None);
        let mut out = Vec::new();
        for p in &points {
            det.push(&PoseInput::at(*p));
            out.extend(det.poll());
        }
        let seen = det.workers_lost();
        let (rest, summary) = det.finish();
        out.extend(rest);
        (out, summary, seen)
    }

    /// Regression: a worker that panicked left the settler waiting for its
    /// matchings, and the other workers' later candidates never came.
    #[test]
    fn a_lost_worker_is_counted_and_the_others_candidates_keep_coming() {
        let printed = |events: &[CandidateEvent]| -> Vec<String> {
            events.iter().map(|e| format!("{e:?}")).collect()
        };
        for workers in [1, 2] {
            let (all, healthy, _) = replay_failing(workers, None);
            assert_eq!(healthy.workers_lost, 0);
            // Matching 101 of about 170 falls about two thirds of the way.
            let fail = (workers - 1, 101 + workers as u64 % 2);
            let (out, summary, seen) = replay_failing(workers, Some(fail));
            assert_eq!((summary.workers_lost, seen), (1, 1), "{workers} workers");
            assert_eq!(summary.worker.candidates, out.len() as u64);
            let (a, b) = (printed(&all), printed(&out));
            let same = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
            assert!(
                same >= 10 && same < a.len(),
                "{workers} workers: {same} of {}",
                a.len()
            );
            if workers == 1 {
                // The only worker: nothing after its loss, and no hang.
                assert_eq!(same, b.len());
            } else {
                // The other worker's matchings still come, in order, and it
                // still takes every message.
                assert!(b.len() >= same + 10, "{} after {same}", b.len());
                assert!(out.windows(2).all(|w| w[0].at_pose <= w[1].at_pose));
                assert!(summary.messages + 1 >= healthy.messages);
            }
        }
    }
}
