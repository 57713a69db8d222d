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
//! With [`OnlineConfig::workers`] above 1, the worker takes in every
//! hand-over it finds queued before it matches (appending is cheap), then
//! runs their matchings on that many threads (scoped, one per batch), each
//! over the one history as it stood when its matching fell due
//! ([`Due`]): a matching reads nothing taken in after it, so it finds what
//! it would have found alone. What depends on earlier matchings (a
//! registration too soon after the previous one, the top-k after it, the
//! ids) is settled afterwards in stream order ([`Settle`]): the candidates
//! are the same with any number of threads, and the memory is one
//! history's. A batch is at most what the queue held, so a live detector,
//! whose queue is mostly empty, matches each hand-over as it comes. A
//! panic (a bug) in any of them loses the worker: the caller counts it
//! (`Summary::workers_lost`) and drops later samples.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use crossbeam::channel::{Receiver, Sender};
use serde::Serialize;

use super::correlator::LazyPiece;
use super::events::{CandidateEvent, KeyframePair, Source};
use super::frontend::Outbox;
use super::history::{History, HistoryView, Upto};
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
    /// Segments whose queries ran.
    pub matched: u64,
    /// Segments whose queries were skipped (merged messages).
    pub skipped: u64,
    /// Periodic proximity probes run.
    pub probes: u64,
    /// Candidates emitted (counted where they are settled, filled in by
    /// `Detector::finish`).
    pub candidates: u64,
    /// Batches of matchings shared out over more than one thread
    /// ([`OnlineConfig::workers`]; a live detector's queue seldom holds
    /// more than one hand-over, so it seldom has any).
    pub parallel_batches: u64,
    /// Time spent matching and verifying, summed over the threads
    /// (seconds).
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

/// Starts the worker with `state`: it settles its matchings with `settle`
/// and sends the candidates on `tx`. `room`, if any, hears once its queue
/// is half empty (the replay's caller waits for that when the queue is
/// full).
pub fn spawn(
    state: WorkerState,
    rx: Receiver<Message>,
    tx: Sender<CandidateEvent>,
    settle: Settle,
    room: Option<Sender<()>>,
) -> JoinHandle<WorkerStats> {
    std::thread::Builder::new()
        .name("turnprint-online".into())
        .spawn(move || run(state, rx, tx, settle, room))
        .expect("spawning the matching thread")
}

/// One matching's candidates before they are settled: the searches', best
/// first, and the network registration's, if one was due (its window's
/// newest sample and candidates). Ids are given when settled.
#[derive(Debug)]
pub struct Matched {
    /// The searches' candidates.
    pub found: Vec<CandidateEvent>,
    /// The registration's, if due.
    pub registered: Option<(usize, Vec<CandidateEvent>)>,
}

/// What is decided across matchings, in stream order: a registration too
/// soon after the previous one is dropped, the top-k kept, ids given. With
/// several threads a matching runs while the previous one may still be
/// running, so nothing a matching computes depends on these.
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
    /// A test's injected panic at this matching ([`FAIL_AT`]).
    #[cfg(test)]
    fail_at: Option<u64>,
}

#[cfg(test)]
thread_local! {
    /// A test's injected failure: the worker of the detectors this thread
    /// builds panics at its matching numbered so.
    pub(crate) static FAIL_AT: std::cell::Cell<Option<u64>> =
        const { std::cell::Cell::new(None) };
}

/// A matching that fell due, with what it may read: the history up to
/// `upto` and the pieces of the newest segments then.
pub struct Due {
    /// Its number in the stream (a test's injected failure names it).
    #[cfg(test)]
    matching: u64,
    /// The newest segment's queries (else the periodic probe alone).
    shape: bool,
    /// The drifting probe runs too (at segment boundaries and on every
    /// other periodic probe, which covers the newest two probe periods).
    drifting: bool,
    /// Pose whose arrival made it due.
    at_pose: usize,
    frame: Frame,
    upto: Upto,
    pieces: Vec<Arc<LazyPiece>>,
}

impl WorkerState {
    /// An empty worker state.
    pub fn new(config: OnlineConfig) -> Self {
        WorkerState {
            history: History::default(),
            searcher: Searcher::new(&config),
            stats: WorkerStats::default(),
            config,
            #[cfg(test)]
            fail_at: FAIL_AT.get(),
        }
    }

    /// Takes one message in: appends its samples, caches each new segment's
    /// piece. Returns the matchings that fell due (the newest segment's, or
    /// a periodic probe), to run with [`Self::run`].
    pub fn take(&mut self, m: &Message) -> Vec<Due> {
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
        let mut due = Vec::new();
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
            due.push(self.fall_due(&m.frame, m.at_pose, true));
        }
        if new == 0 && self.config.proximity {
            // A periodic hand-over without a new segment: the proximity
            // probe alone (straight revisits finalise no segment for long).
            due.push(self.fall_due(&m.frame, m.at_pose, false));
        }
        due
    }

    /// The next matching, over the history as it stands: the newest
    /// segment's queries (`shape`) or the periodic probe.
    fn fall_due(&mut self, frame: &Frame, at_pose: usize, shape: bool) -> Due {
        #[cfg(test)]
        let matching = self.stats.matched + self.stats.probes;
        let drifting = match shape {
            true => {
                self.stats.matched += 1;
                true
            }
            false => {
                self.stats.probes += 1;
                // A periodic probe covers the newest two probe periods, so
                // every other one covers each sample once.
                self.stats.probes.is_multiple_of(2)
            }
        };
        Due {
            #[cfg(test)]
            matching,
            shape,
            drifting,
            at_pose,
            frame: *frame,
            upto: self.history.upto(),
            pieces: match shape {
                true => self.searcher.pieces.clone(),
                false => Vec::new(),
            },
        }
    }

    /// Runs `due` matchings on up to [`OnlineConfig::workers`] threads
    /// (each reads the history as its matching fell due), in stream order.
    pub fn run(&mut self, due: &[Due]) -> Vec<Matched> {
        let threads = self.config.workers.clamp(1, due.len().max(1));
        let timed: Vec<(Matched, f64)> = if threads == 1 {
            due.iter().map(|d| self.matching(d)).collect()
        } else {
            self.stats.parallel_batches += 1;
            // Each thread takes the next matching not yet taken: the
            // matchings' costs differ by two orders of magnitude (a
            // periodic probe against a network registration). The costly
            // kinds go first (a segment's queries, then the drifting
            // probe's), so that the batch does not end waiting on one.
            let mut order: Vec<usize> = (0..due.len()).collect();
            order.sort_by_key(|&i| (!due[i].shape, !due[i].drifting));
            let next = AtomicUsize::new(0);
            let this = &*self;
            let share = || {
                let mut mine = Vec::new();
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&i) = order.get(k) else {
                        return mine;
                    };
                    mine.push((i, this.matching(&due[i])));
                }
            };
            let mut all = std::thread::scope(|scope| {
                let helpers: Vec<_> = (1..threads).map(|_| scope.spawn(share)).collect();
                let mut all = share();
                for helper in helpers {
                    // A helper's panic is the worker's (a bug): it unwinds
                    // with it.
                    all.extend(
                        helper
                            .join()
                            .unwrap_or_else(|e| std::panic::resume_unwind(e)),
                    );
                }
                all
            });
            all.sort_unstable_by_key(|(i, _)| *i);
            all.into_iter().map(|(_, m)| m).collect()
        };
        timed
            .into_iter()
            .map(|(matched, dt)| {
                self.stats.busy_s += dt;
                self.stats.max_match_s = self.stats.max_match_s.max(dt);
                matched
            })
            .collect()
    }

    /// Runs one matching, with the time it took.
    fn matching(&self, due: &Due) -> (Matched, f64) {
        #[cfg(test)]
        if self.fail_at == Some(due.matching) {
            panic!("injected failure at matching {}", due.matching);
        }
        let start = Instant::now();
        let config = &self.config;
        let h = &self.history.view(due.upto);
        let frame = &due.frame;
        let shape = match due.shape {
            true => self.searcher.shape_candidates(h, &due.pieces, config),
            false => Vec::new(),
        };
        let probed = match (&self.searcher.spatial, config.proximity) {
            (Some(sp), true) => probe_newest(
                h,
                sp,
                due.shape,
                2 * config.probe_every,
                match due.drifting {
                    true => config.drift_radius(),
                    false => 0.0,
                },
            ),
            _ => None,
        };
        let seed = probed.as_ref().and_then(Probed::seed);
        let found = verify_all(h, frame, &shape, seed, config);
        // Where the probe found a road but nothing came of it, the newest
        // stretch placed on the whole network (a drifting map's search). A
        // proximity candidate short of the cut counts as nothing: the
        // consistent map's probe found it, and the drifting probe, which
        // would have looked farther, did not run.
        let weak = found
            .iter()
            .all(|f| f.source == Source::Proximity && f.hypothesis.score < config.min_score);
        let registered = match (weak, &probed) {
            (true, Some(probed)) => register_newest(h, &self.searcher, frame, probed, config),
            _ => None,
        };
        let event = |f: Found| {
            let hy = f.hypothesis;
            CandidateEvent {
                id: 0,
                at_pose: due.at_pose,
                keyframes: keyframe_pair(h, &hy),
                query_keyframes: h.keyframes_in(hy.a_range, 8),
                match_keyframes: h.keyframes_in(hy.b_range, 8),
                hypothesis: hy,
                source: f.source,
            }
        };
        let matched = Matched {
            found: found.into_iter().map(event).collect(),
            registered: registered.map(|(g1, r)| (g1, r.into_iter().map(event).collect())),
        };
        (matched, start.elapsed().as_secs_f64())
    }

    /// Final figures.
    pub fn finish_stats(&mut self) -> WorkerStats {
        let h = &self.history;
        let pieces: usize = self.searcher.pieces.iter().map(|p| p.bytes()).sum();
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
fn keyframe_pair(h: &HistoryView, hy: &crate::Hypothesis) -> Option<KeyframePair> {
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
    rx: Receiver<Message>,
    tx: Sender<CandidateEvent>,
    mut settle: Settle,
    room: Option<Sender<()>>,
) -> WorkerStats {
    let half = rx.capacity().unwrap_or(0) / 2;
    let threads = state.config.workers.max(1);
    // A batch holds at most a queue's worth of hand-overs: the pieces its
    // matchings hold stay bounded, and so does the wait for its first
    // candidates.
    let batch = rx.capacity().unwrap_or(1).max(1);
    while let Ok(first) = rx.recv() {
        let mut due = Vec::new();
        let mut next = Some(first);
        let mut taken = 0;
        while let Some(m) = next {
            taken += 1;
            if let Some(room) = &room {
                if rx.len() <= half {
                    // Full already when the caller has not taken the last word.
                    let _ = room.try_send(());
                }
            }
            due.extend(state.take(&m));
            // With one thread each hand-over is matched as it comes; with
            // more, whatever else is queued is taken in first, and its
            // matchings shared out.
            next = match threads {
                1 => None,
                _ if taken >= batch => None,
                _ => rx.try_recv().ok(),
            };
        }
        for matched in state.run(&due) {
            // The caller may have dropped its receiver: keep working.
            for e in settle.settle(matched) {
                let _ = tx.send(e);
            }
        }
    }
    state.finish_stats()
}

#[cfg(test)]
mod tests;
