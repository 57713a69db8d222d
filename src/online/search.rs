//! What a newly finalised segment triggers: the queries of its last
//! `N = min..=max` segments against the history (both directions), the
//! batch verification of the strongest of them and of the proximity
//! probe's seed ([`super::probe`]), the loop score with the drift prior,
//! and the top k as hypotheses (the network registration's candidate is
//! grown and emitted the same way: [`super::network`]). The drift prior's
//! gates before and after verification are in `gate`.

use std::collections::HashMap;
use std::sync::Arc;

use super::correlator::{BlockCorrelator, LazyPiece, Piece};
use super::drift_path::{self, PathMoments};
use super::events::Source;
use super::gate::{emitted, pre_gate, prior_may_pass, DRIFT_SCALE};
use super::history::{History, HistoryView, SpatialIndex, Window};
use super::scan;
use super::{Exclusion, OnlineConfig};
use nalgebra::Vector2;

use crate::align::grow::MAX_SCALE_CHANGE;
use crate::geometry::{Plane, Similarity2};
use crate::matching::{Candidate, Orientation};
use crate::pipeline::proximity::ProximitySeed;
use crate::pipeline::rank::{rank, Duplicates};
use crate::pipeline::{verify, Verified};
use crate::score::{loop_score, score};
use crate::Hypothesis;

/// Fraction of the cut a shape candidate's score must reach after the first
/// grow round for the rounds that follow to run. Over ground truth, ORB and
/// strong drift (seeds 1-80) of KITTI 00, 02, 05, 06 and 08, the 39 shape
/// candidates emitted scored at least 0.067 after one round (0.22 of the
/// cut; the next lowest 0.12), and 2 778 of the 3 127 grown only to score
/// below the cut stood under a tenth of it (median 0.007).
const FIRST_ROUND_CUT: f64 = 0.1;
/// Track parameters the search needs.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// The plane of the detector's 2D frame.
    pub plane: Plane,
    /// Grid step.
    pub step: f64,
    /// Smoothing bandwidth.
    pub bandwidth: f64,
    /// Poses pushed so far.
    pub poses: usize,
}

impl Frame {
    /// The history's track samples `[g0, g1]` (clamped) as a prepared
    /// path in this frame.
    pub fn window(&self, h: &HistoryView, g0: usize, g1: usize, dk: f64) -> Option<Window> {
        h.window(
            g0,
            g1,
            &self.plane,
            self.step,
            self.bandwidth,
            dk,
            self.poses,
        )
    }
}

/// Relative margin, on the arc lengths compared, by which two windows must
/// lie apart for [`apart`] to answer without interpolating: far above the
/// few units in the last place (about 1e-16 each) that the interpolation and
/// the difference round by, far below any gap between windows.
const APART_MARGIN: f64 = 1e-9;

/// Whether track sample `g` of the query window `qw` and fractional track
/// sample `v` of the target window `tw` lie more than `length` apart along
/// the path: the query's own neighbourhood is no revisit.
fn apart<'a>(
    h: &'a HistoryView<'a>,
    qw: &'a Window,
    tw: &'a Window,
    length: f64,
) -> impl Fn(usize, f64) -> bool + 'a {
    // Growth asks this of most target segments it looks at, and a revisit's
    // two windows usually lie apart as wholes: then every pair does (arc
    // length never decreases, and `v` stays on the target window), and the
    // answer is known without the interpolation.
    let span = |w: &Window| (h.s[w.grid0], h.s[w.grid0 + w.path.track.s.len() - 1]);
    let ((q_lo, q_hi), (t_lo, t_hi)) = (span(qw), span(tw));
    let margin = APART_MARGIN * (q_hi.abs() + t_hi.abs() + length.abs());
    let gap = (q_lo - t_hi).max(t_lo - q_hi);
    let always = gap > length + margin;
    move |g, v| {
        always || {
            let st = crate::track::Track::interp(h.s, v + tw.grid0 as f64);
            (h.s[g + qw.grid0] - st).abs() > length
        }
    }
}

/// Grows the history's track samples `query` (inside the window `q_range`)
/// against the window `t_range` from each of `starts` (`history_T_query`:
/// both windows are one map) and scores the first that verifies.
#[allow(clippy::too_many_arguments)]
pub(super) fn grow_seeded(
    h: &HistoryView,
    frame: &Frame,
    config: &OnlineConfig,
    query: [usize; 2],
    q_range: [usize; 2],
    t_range: [usize; 2],
    starts: impl IntoIterator<Item = Similarity2>,
    source: Source,
) -> Option<Found> {
    // A drifting source's candidate keeps its scale within DRIFT_SCALE
    // (`emitted`), and growth ends within MAX_SCALE_CHANGE of its start's:
    // a start beyond both is never emitted. (On KITTI 00's ground truth,
    // 27 of the drifting probe's 55 seeds start at scale 3-41: probe points
    // laid on a road crossing the window.)
    let reach = (DRIFT_SCALE * MAX_SCALE_CHANGE).ln();
    let mut starts = starts
        .into_iter()
        .filter(|start| {
            !config.prior_gate || source == Source::Proximity || start.scale.ln().abs() <= reach
        })
        .peekable();
    starts.peek()?;
    let pc = &config.pipeline;
    let qw = frame.window(h, q_range[0], q_range[1], pc.signature.dk)?;
    let tw = frame.window(h, t_range[0], t_range[1], pc.signature.dk)?;
    let allowed = apart(h, &qw, &tw, h.s[query[1]] - h.s[query[0]]);
    let xy = qw.path.points(false);
    let local = [
        query[0].checked_sub(qw.grid0)?,
        query[1].checked_sub(qw.grid0)?,
    ];
    let v = starts.find_map(|start| {
        verify::verify_seeded(&tw.path, &qw.path, &xy, local, start, false, pc, &allowed)
    })?;
    finish(h, &tw, &qw, &v, frame, config, source)
}

/// A verified, scored candidate of one query.
#[derive(Debug, Clone)]
pub struct Found {
    /// The hypothesis: `a_range` the later (query) part, `b_range` the match.
    pub hypothesis: Hypothesis,
    /// Which search found it (a drifting-map probe's candidate is emitted
    /// from [`OnlineConfig::drift_min_score`]).
    pub source: Source,
    /// Squared Mahalanobis distance of its correction under the drift prior
    /// along the path between its two passes ([`super::drift_path`]).
    pub drift_path: f64,
}

impl crate::pipeline::rank::Ranked for Found {
    fn hypothesis(&self) -> &Hypothesis {
        &self.hypothesis
    }
    fn hypothesis_mut(&mut self) -> &mut Hypothesis {
        &mut self.hypothesis
    }
}

/// Search state kept between segments.
pub struct Searcher {
    /// Block spectra and prefix sums of the history signature.
    pub correlator: BlockCorrelator,
    /// Raw correlations of the newest pieces (oldest first), each computed
    /// when first needed.
    pub pieces: Vec<Arc<LazyPiece>>,
    /// Decimated positions for the proximity probe.
    pub spatial: Option<SpatialIndex>,
}

impl Searcher {
    /// An empty searcher.
    pub fn new(config: &OnlineConfig) -> Self {
        Searcher {
            correlator: BlockCorrelator::new(config.block_len),
            pieces: Vec::new(),
            spatial: None,
        }
    }

    /// Takes in the history's new samples (spectra, prefix sums, index).
    pub fn update(&mut self, h: &History, frame: &Frame) {
        self.correlator.update(&h.sig_value);
        // The cell follows the grid step, which grows with the path's speed
        // (`frontend::Streams`): cells of a step 200 times smaller made the
        // probes' reach, a number of cells, 200 times shorter.
        let cell = 64.0 * frame.step;
        let spatial = match &mut self.spatial {
            Some(s) if s.cell() == cell => s,
            other => other.insert(SpatialIndex::new(cell, 4)),
        };
        spatial.update(&h.now());
    }

    /// Keeps the piece ending at boundary number `k` (`k >= 1`), to be
    /// computed when first needed.
    pub fn add_piece(&mut self, h: &History, k: usize, keep: usize) {
        let (b0, b1) = (h.bounds[k - 1], h.bounds[k]);
        let piece = LazyPiece::new(b0, b1 - b0, h.sig_value.len());
        self.pieces.push(Arc::new(piece));
        if self.pieces.len() > keep {
            self.pieces.remove(0);
        }
    }

    /// Shape candidates of the queries ending at the newest boundary of
    /// `h`, whose newest pieces are `newest` (oldest first).
    pub fn shape_candidates(
        &self,
        h: &HistoryView,
        newest: &[Arc<LazyPiece>],
        config: &OnlineConfig,
    ) -> Vec<Candidate> {
        let qc = &config.pipeline.query;
        let a = h.sig_value;
        let n_bounds = h.bounds.len();
        if n_bounds < 2 || newest.is_empty() {
            return Vec::new();
        }
        let q1 = h.bounds[n_bounds - 1];
        // The prefix sums as far as the matching's history goes.
        let hist = a.len();
        let (prefix, prefix_sq) = (
            &self.correlator.prefix[..=hist],
            &self.correlator.prefix_sq[..=hist],
        );
        let total_var = {
            let (s, sq) = self.correlator.window(0, hist);
            (sq / hist as f64 - (s / hist as f64).powi(2)).max(0.0)
        };
        let flat = crate::matching::zncc::FLAT_FRACTION * total_var;
        // The queries of the newest 1..=max_n pieces, as far as the history
        // leaves room for them outside the query's own neighbourhood.
        let mut queries = Vec::new();
        let mut pieces = Vec::new();
        let max_n = qc.max_segments.min(newest.len());
        for n in 1..=max_n {
            let lazy = &newest[newest.len() - n];
            let q0 = lazy.start;
            let len = q1 - q0 + 1;
            let margin = match config.exclusion {
                Exclusion::Turning(k) => (k / config.pipeline.signature.dk).round() as usize,
                Exclusion::Segments(s) => {
                    let back = (n + s).min(n_bounds - 1);
                    q0 - h.bounds[n_bounds - 1 - back]
                }
            };
            let Some(end) = q0.checked_sub(margin) else {
                break;
            };
            // Windows lie in [0, end): forward x in [len-1, end-1], reversed
            // x in [0, end-len]; both shrink as n grows.
            if end < len {
                break;
            }
            let q = &a[q0..=q1];
            let mean = q.iter().map(|&v| v as f64).sum::<f64>() / len as f64;
            let norm2: f64 = q.iter().map(|&v| (v as f64 - mean).powi(2)).sum();
            queries.push(scan::Query {
                len,
                // Windows start at st in [0, count): forward x = st + len - 1
                // (x = target of the newest sample), reversed x = st.
                count: end - len + 1,
                stats: (n >= qc.min_segments && norm2 > 0.0).then_some(scan::QueryStats {
                    mean,
                    norm2,
                    last: a[q1] as f64,
                }),
            });
            let piece: &Piece = lazy.get(&self.correlator, a);
            pieces.push(piece);
        }
        let history = scan::History {
            values: a,
            prefix,
            prefix_sq,
            flat,
        };
        let found = scan::scan(&pieces, &queries, &history, qc.min_zncc);
        let mut pooled: HashMap<(bool, i64), Candidate> = HashMap::new();
        for (query, found) in queries.iter().zip(found) {
            let len = query.len;
            let q0 = q1 + 1 - len;
            let spacing = (len - 1).div_ceil(2).max(1);
            for (is_rev, found) in [false, true].into_iter().zip(found) {
                for (st, z) in scan::best_spaced(found, qc.peaks_per_query, spacing) {
                    // The alignment line through x, the target of the newest
                    // sample (st reversed, st + len - 1 forward).
                    let line = if is_rev {
                        st as i64 + q1 as i64
                    } else {
                        (st + len - 1) as i64 - q1 as i64
                    };
                    let cand = Candidate {
                        orientation: Orientation {
                            reversed: is_rev,
                            mirrored: false,
                        },
                        query: [q0, q1],
                        seed: [q0, q1],
                        line,
                        zncc: z,
                        strength: z * z * len as f64,
                    };
                    let key = (is_rev, line.div_euclid(qc.line_tolerance.max(1) as i64));
                    pooled
                        .entry(key)
                        .and_modify(|p| {
                            p.strength += cand.strength;
                            p.query = [p.query[0].min(q0), q1];
                            // The best vote (as the batch pool): highest
                            // ZNCC, longer queries winning near-ties.
                            if z * (q1 - q0) as f64 > p.zncc * (p.seed[1] - p.seed[0]) as f64 {
                                p.zncc = z;
                                p.line = line;
                                p.seed = [q0, q1];
                            }
                        })
                        .or_insert(cand);
                }
            }
        }
        let mut out: Vec<Candidate> = pooled.into_values().collect();
        out.sort_by(|x, y| y.strength.total_cmp(&x.strength));
        out.truncate(config.max_verify);
        out
    }
}

/// Verifies, scores and converts the candidates of one query: each shape
/// candidate, then the probe's seed.
pub fn verify_all(
    h: &HistoryView,
    frame: &Frame,
    shape: &[Candidate],
    seed: Option<&ProximitySeed>,
    config: &OnlineConfig,
) -> Vec<Found> {
    let mut query_windows = Vec::new();
    let mut found: Vec<Found> = shape
        .iter()
        .filter_map(|cand| verify_shape(h, frame, cand, config, &mut query_windows))
        .collect();
    found.extend(seed.and_then(|seed| grow_seed(h, frame, seed, config)));
    found.retain(|f| emitted(f, config, frame.step));
    rank(found, config.top_k, f64::NEG_INFINITY, Duplicates::Place)
}

/// The query windows cut so far for one segment's candidates, by track
/// sample range.
type QueryWindows = Vec<([usize; 2], Option<Window>)>;

/// One shape candidate verified and scored, if it may pass the cut.
/// `query_windows` keeps the query windows cut for the candidates before:
/// the candidates of one segment often share their query, whose window is
/// as costly to cut as the target's.
fn verify_shape(
    h: &HistoryView,
    frame: &Frame,
    cand: &Candidate,
    config: &OnlineConfig,
    query_windows: &mut QueryWindows,
) -> Option<Found> {
    let pc = &config.pipeline;
    let dk = pc.signature.dk;
    let window = |g0: usize, g1: usize| frame.window(h, g0, g1, dk);
    let (q0, q1) = (cand.query[0], cand.query[1]);
    let t = [cand.target_of(q0), cand.target_of(q1)];
    let (t0, t1) = (
        t[0].min(t[1]).max(0) as usize,
        t[0].max(t[1]).max(0) as usize,
    );
    if t1 >= h.sig_grid.len() {
        return None;
    }
    let (gq0, gq1) = (
        h.sig_grid[q0].floor() as usize,
        h.sig_grid[q1].ceil() as usize,
    );
    let (gt0, gt1) = (
        h.sig_grid[t0].floor() as usize,
        h.sig_grid[t1].ceil() as usize,
    );
    // Room to grow: the query's own length on each side.
    let room = gq1 - gq0;
    let seed_len = h.sig_s(q1) - h.sig_s(q0);
    let room_len = {
        let s = |g: usize| h.s[g.min(h.s.len() - 1)];
        (s(gq1 + room) - s(gq0.saturating_sub(room)))
            .max(s(gt1 + room) - s(gt0.saturating_sub(room)))
    };
    let between = (h.sig_s(q0) - h.sig_s(t1)).abs();
    let may_pass = |sim: &Similarity2, pairs: &[(Vector2<f64>, Vector2<f64>)], widen| {
        prior_may_pass(
            sim,
            pairs,
            [0.5 * seed_len, room_len],
            between,
            config,
            widen,
            config.min_score,
        )
    };
    // The gate below, on the history itself with wider slack, before any
    // window is cut (most candidates stop here).
    if !pre_gate(h, cand, pc, |sim, pairs| may_pass(sim, pairs, 2.0)) {
        return None;
    }
    let q_range = [gq0.saturating_sub(room), gq1 + room];
    let at = match query_windows.iter().position(|(r, _)| *r == q_range) {
        Some(at) => at,
        None => {
            query_windows.push((q_range, window(q_range[0], q_range[1])));
            query_windows.len() - 1
        }
    };
    let qw = query_windows[at].1.as_ref()?;
    let tw = window(gt0.saturating_sub(room), gt1 + room)?;
    let (qs, ts) = (qw.sig0 as i64, tw.sig0 as i64);
    let local = Candidate {
        query: [q0 - qw.sig0, q1 - qw.sig0],
        seed: [cand.seed[0] - qw.sig0, cand.seed[1] - qw.sig0],
        line: if cand.orientation.reversed {
            cand.line - qs - ts
        } else {
            cand.line + qs - ts
        },
        ..cand.clone()
    };
    if local.query[1] >= qw.path.signature.len() {
        return None;
    }
    let allowed = apart(h, qw, &tw, seed_len);
    let xy = qw.path.points(false);
    // Most shape candidates are look-alikes far from identity whose
    // drift prior alone keeps them below the cut: known from the RANSAC
    // similarity, before the growth that costs most of the time.
    let gate =
        |sim: &Similarity2, pairs: &[(Vector2<f64>, Vector2<f64>)]| may_pass(sim, pairs, 1.0);
    // Of the rest, look-alikes show after the first grow round: scored as
    // they stand then, they lie far below the cut, true revisits near it.
    let promising = |v: &Verified| {
        finish(h, &tw, qw, v, frame, config, Source::Shape)
            .is_some_and(|f| f.hypothesis.score >= FIRST_ROUND_CUT * config.min_score)
    };
    let promising: Option<&dyn Fn(&Verified) -> bool> = match config.prior_gate {
        true => Some(&promising),
        false => None,
    };
    let v = verify::verify(
        &tw.path, &qw.path, &xy, &local, pc, &allowed, &gate, promising,
    )?;
    finish(h, &tw, qw, &v, frame, config, Source::Shape)
}

/// The proximity probe's seed grown and scored, if it may pass the cut.
fn grow_seed(
    h: &HistoryView,
    frame: &Frame,
    seed: &ProximitySeed,
    config: &OnlineConfig,
) -> Option<Found> {
    let (range, target, start) = (seed.query, seed.target, seed.start);
    let room = range[1] - range[0];
    // A drifted seed must still be able to reach the cut under the
    // drift prior, from its start similarity (as the shape candidates'
    // pre-gate): most of them are other roads within the wide radius.
    let seed_len = h.s[range[1]] - h.s[range[0]];
    let between = (h.s[range[0]] - h.s[target]).abs();
    let may_pass = !seed.drifted
        || prior_may_pass(
            &start,
            &seed.pairs,
            [0.5 * seed_len, 5.0 * seed_len],
            between,
            config,
            2.0,
            config.drift_min_score,
        );
    if !may_pass {
        return None;
    }
    let source = match seed.drifted {
        true => Source::DriftProbe,
        false => Source::Proximity,
    };
    grow_seeded(
        h,
        frame,
        config,
        range,
        [
            range[0].saturating_sub(room),
            (range[1] + room).min(h.xy.len() - 1),
        ],
        [target.saturating_sub(2 * room), target + 2 * room],
        seed.starts(seed_len),
        source,
    )
}

/// A verified overlap as a loop hypothesis (query = later part), scored
/// with the drift prior like the batch `loops`.
#[allow(non_snake_case)]
fn finish(
    h: &HistoryView,
    tw: &Window,
    qw: &Window,
    v: &Verified,
    frame: &Frame,
    config: &OnlineConfig,
    source: Source,
) -> Option<Found> {
    let o = &v.overlap;
    let pose_t = |g: f64| tw.path.pose_of_grid(g);
    let pose_q = |g: f64| qw.path.pose_of_grid(g);
    let mut a_range = [pose_q(o.query[0] as f64), pose_q(o.query[1] as f64)];
    let mut b_range = [pose_t(o.target[0]), pose_t(o.target[1])];
    // The windows are one map: a_T_b maps target (earlier) onto query.
    let mut a_T_b = o.a_T_b.inverse();
    let step = (o.pairs.len() / 50).max(1);
    let mut correspondences: Vec<(usize, usize)> = o
        .pairs
        .iter()
        .step_by(step)
        .map(|&(t, q)| (pose_q(q as f64), pose_t(t)))
        .collect();
    if b_range[0] > a_range[0] {
        std::mem::swap(&mut a_range, &mut b_range);
        a_T_b = a_T_b.inverse();
        for c in &mut correspondences {
            *c = (c.1, c.0);
        }
    }
    let lifted = frame.plane.lift(&frame.plane, &a_T_b);
    let pc = &config.pipeline;
    let s_of = |w: &Window, g: f64| crate::track::Track::interp(h.s, g + w.grid0 as f64);
    let between = (s_of(qw, o.query[0] as f64) - s_of(tw, o.target[1])).abs();
    let length = o.target_length.max(o.query_length);
    // Drift prior: the angle and offset of `map_T_query` as the drift along
    // the path between the two parts' middles makes them agree, the scale
    // change as the batch prior has it.
    let drift_path = pc.drift_prior.as_ref().map_or(0.0, |prior| {
        let n = o.pairs.len().max(1) as f64;
        let x = o
            .pairs
            .iter()
            .map(|&(_, q)| qw.path.track.xy[q])
            .sum::<Vector2<f64>>()
            / n;
        let mid = |w: &Window, a: f64, b: f64| w.grid0 + (0.5 * (a + b)).round() as usize;
        let path = PathMoments::between(
            h,
            mid(tw, o.target[0], o.target[1]),
            mid(qw, o.query[0] as f64, o.query[1] as f64),
        );
        drift_path::mahalanobis2(prior, &o.a_T_b, x, &path, length)
    });
    let s = match &pc.drift_prior {
        Some(prior) => loop_score(
            &v.evidence,
            drift_path::factor(drift_path) * prior.scale_factor(a_T_b.scale, length, between),
            &pc.score,
        ),
        None => score(&v.evidence, &pc.score),
    };
    if !s.is_finite() {
        return None;
    }
    Some(Found {
        hypothesis: Hypothesis {
            rank: 0,
            score: s,
            zncc: v.evidence.zncc,
            reversed: v.candidate.orientation.reversed,
            a_range,
            b_range,
            scale: lifted.scale,
            rotation: lifted.rotation,
            translation: lifted.translation,
            rmse: o.rmse,
            turning: v.evidence.turning,
            length,
            length_ratio: v.evidence.length_ratio,
            correspondences,
        },
        source,
        drift_path,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The answer known from the windows' spans is the interpolated one for
    /// every pair: windows far apart, overlapping, and apart by about the
    /// length itself (where only the interpolation can tell).
    #[test]
    fn apart_answers_as_the_interpolation() {
        let mut h = History::default();
        let mut s = 1e4;
        for i in 0..3000u32 {
            let t = i as f64 * 0.01;
            h.xy.push([(40.0 * t.cos()) as f32, (25.0 * (1.3 * t).sin()) as f32]);
            h.s.push(s);
            // Uneven steps, a stop among them: arc length only never
            // decreases.
            s += if i % 97 == 0 {
                0.0
            } else {
                0.4 + 0.3 * (0.7 * t).sin().abs()
            };
            h.curvature.push(0.0);
            h.pose.push(i);
        }
        h.index_new_samples();
        let points: Vec<_> = (0..50)
            .map(|i| nalgebra::Vector3::new(i as f64, (i * i % 7) as f64, 0.0))
            .collect();
        let frame = Frame {
            plane: Plane::fit(&points),
            step: 0.5,
            bandwidth: 1.0,
            poses: 3000,
        };
        let view = h.now();
        let exact = |qw: &Window, tw: &Window, length: f64, g: usize, v: f64| {
            let st = crate::track::Track::interp(view.s, v + tw.grid0 as f64);
            (view.s[g + qw.grid0] - st).abs() > length
        };
        let qw = frame.window(&view, 2400, 2900, 1.0).expect("query window");
        for (t0, t1) in [(100, 600), (1800, 2300), (2200, 2700), (2600, 2999)] {
            let tw = frame.window(&view, t0, t1, 1.0).expect("target window");
            let gap = view.s[2400] - view.s[t1];
            for length in [10.0, 0.5 * gap.abs(), gap.abs(), gap.abs() + 0.2, 2e3] {
                let allowed = apart(&view, &qw, &tw, length);
                for g in (0..qw.path.track.s.len()).step_by(7) {
                    for k in 0..=400 {
                        let v = k as f64 / 400.0 * (tw.path.track.s.len() - 1) as f64;
                        assert_eq!(
                            allowed(g, v),
                            exact(&qw, &tw, length, g, v),
                            "target {t0}..{t1}, length {length}, g {g}, v {v}"
                        );
                    }
                }
            }
        }
    }
}
