//! Part-to-part matching: queries of N consecutive segments of one path are
//! correlated against the whole signature of the other, and the peaks vote
//! for alignments.
//!
//! A true overlap aligns every query inside it along one line of the
//! (query sample, target sample) plane: `a = b + c` for the same direction of
//! travel, `a = c - b` for the opposite one. Peaks are therefore pooled by
//! that line, so a long overlap seen by many short queries becomes one strong
//! candidate instead of many weak ones.

use std::collections::HashMap;

use super::Correlator;

/// How the query path runs along the target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Orientation {
    /// Opposite direction of travel.
    pub reversed: bool,
    /// Seen from the other side of its plane (curvature negated).
    pub mirrored: bool,
}

/// A proposed alignment of query samples onto target samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Direction and side.
    pub orientation: Orientation,
    /// Inclusive range of query signature samples (union of the votes).
    pub query: [usize; 2],
    /// The best single vote's query range: the cleanest seed for alignment.
    pub seed: [usize; 2],
    /// The alignment line: target sample = `line + b` (forward) or
    /// `line - b` (reversed) for query sample `b`.
    pub line: i64,
    /// Best ZNCC among the queries that voted for this line.
    pub zncc: f64,
    /// Pooled evidence: Σ zncc² · length over the voting queries.
    pub strength: f64,
}

impl Candidate {
    /// Target sample aligned with query sample `b` (may fall outside).
    pub fn target_of(&self, b: usize) -> i64 {
        if self.orientation.reversed {
            self.line - b as i64
        } else {
            self.line + b as i64
        }
    }
}

/// Settings of the part-to-part search.
#[derive(Debug, Clone, Copy)]
pub struct QueryConfig {
    /// Fewest consecutive segments in a query (the paper's N1).
    pub min_segments: usize,
    /// Most consecutive segments in a query (the paper's N2).
    pub max_segments: usize,
    /// Peaks kept per query and orientation.
    pub peaks_per_query: usize,
    /// Lowest ZNCC kept.
    pub min_zncc: f64,
    /// Also try the query seen from the other side of its plane.
    pub mirror: bool,
    /// Alignment lines closer than this many samples are pooled.
    pub line_tolerance: usize,
    /// Queries turning less than this (radians of K) are not run.
    pub min_turning: f64,
    /// Turning of the sliding-window queries (radians of K).
    pub window_turning: [f64; 3],
}

impl Default for QueryConfig {
    fn default() -> Self {
        QueryConfig {
            min_segments: 2,
            max_segments: 12,
            peaks_per_query: 3,
            min_zncc: 0.5,
            mirror: true,
            line_tolerance: 4,
            min_turning: 30f64.to_radians(),
            window_turning: [90f64.to_radians(), 180f64.to_radians(), 360f64.to_radians()],
        }
    }
}

/// Query ranges (inclusive signature samples): every run of
/// `min..=max` consecutive segments (the paper's part-to-part queries), plus
/// windows of fixed turning sliding along the path, so that a path with few
/// segments, or an overlap shorter than two of its segments, still has
/// queries that fit inside the common part. Queries turning less than
/// `min_turning` carry too little shape to match and are left out.
pub fn queries(bounds: &[usize], n: usize, dk: f64, config: &QueryConfig) -> Vec<[usize; 2]> {
    let mut out = Vec::new();
    let min_len = (config.min_turning / dk).ceil() as usize;
    let n_seg = bounds.len().saturating_sub(1);
    for first in 0..n_seg {
        for k in config.min_segments..=config.max_segments {
            if first + k > n_seg {
                break;
            }
            let (q0, q1) = (bounds[first], bounds[first + k]);
            if q1 - q0 >= min_len {
                out.push([q0, q1]);
            }
        }
    }
    for &turning in &config.window_turning {
        let len = (turning / dk).round() as usize;
        let step = (len / 4).max(1);
        if len < min_len || len >= n {
            continue;
        }
        let mut q0 = 0;
        while q0 + len < n {
            out.push([q0, q0 + len]);
            q0 += step;
        }
    }
    out
}

/// Runs every query range of `query_sig` against the correlator's signature
/// and pools the peaks by alignment line. `keep` rejects trivial alignments
/// (self-matches). The queries run on every core; their votes are pooled in
/// query order, so the result does not depend on the number of cores.
pub fn search(
    target: &Correlator,
    query_sig: &[f64],
    query_ranges: &[[usize; 2]],
    config: &QueryConfig,
    keep: impl Fn(&Candidate) -> bool,
) -> Vec<Candidate> {
    let n = target.len();
    let runnable: Vec<[usize; 2]> = query_ranges
        .iter()
        .copied()
        .filter(|&[q0, q1]| q1 - q0 < n && q1 > q0 + 1)
        .collect();
    let votes = crate::parallel::map_with(
        &runnable,
        || target.fork(),
        |correlator, &range| Some(votes(correlator, query_sig, range, config)),
    );
    let mut pooled: HashMap<(Orientation, i64), Vec<Candidate>> = HashMap::new();
    for cand in votes.into_iter().flatten() {
        if keep(&cand) {
            let key = (
                cand.orientation,
                cand.line.div_euclid(config.line_tolerance as i64),
            );
            pool(&mut pooled, key, cand);
        }
    }
    let mut out: Vec<Candidate> = pooled.into_values().flatten().collect();
    out.sort_by(|a, b| b.strength.total_cmp(&a.strength));
    out
}

/// The peaks of one query range, each a vote for its alignment line.
fn votes(
    target: &mut Correlator,
    query_sig: &[f64],
    [q0, q1]: [usize; 2],
    config: &QueryConfig,
) -> Vec<Candidate> {
    let scores = target.scores(&query_sig[q0..=q1]);
    let len = (q1 - q0 + 1) as f64;
    let mut out = Vec::new();
    for (reversed, s) in [(false, &scores.forward), (true, &scores.reversed)] {
        for sign in [1.0, -1.0] {
            if sign < 0.0 && !config.mirror {
                continue;
            }
            for (d, z) in peaks(s, sign, config, (q1 - q0).div_ceil(2)) {
                let line = if reversed {
                    (d + (q1 - q0)) as i64 + q0 as i64
                } else {
                    d as i64 - q0 as i64
                };
                out.push(Candidate {
                    orientation: Orientation {
                        reversed,
                        mirrored: sign < 0.0,
                    },
                    query: [q0, q1],
                    seed: [q0, q1],
                    line,
                    zncc: z,
                    strength: z * z * len,
                });
            }
        }
    }
    out
}

impl Candidate {
    /// The same alignment seen from the other side: the target's samples
    /// become the query. `query_len` is the new query's signature length.
    pub fn swapped(&self, query_len: usize) -> Option<Candidate> {
        let (a0, a1) = (self.query[0] as i64, self.query[1] as i64);
        // Target samples of the old query range become the new query range.
        let (t0, t1) = {
            let (x, y) = (self.target_of(self.query[0]), self.target_of(self.query[1]));
            (x.min(y), x.max(y))
        };
        let (b0, b1) = (t0.max(0), t1.min(query_len as i64 - 1));
        if b1 <= b0 + 1 {
            return None;
        }
        // forward: t = a + line  <=>  a = t - line; reversed: t = line - a.
        let line = if self.orientation.reversed {
            self.line
        } else {
            -self.line
        };
        let _ = (a0, a1);
        let (s0, s1) = {
            let (x, y) = (self.target_of(self.seed[0]), self.target_of(self.seed[1]));
            (x.min(y).max(b0), x.max(y).min(b1))
        };
        Some(Candidate {
            orientation: self.orientation,
            query: [b0 as usize, b1 as usize],
            seed: if s1 > s0 {
                [s0 as usize, s1 as usize]
            } else {
                [b0 as usize, b1 as usize]
            },
            line,
            zncc: self.zncc,
            strength: self.strength,
        })
    }
}

/// The `strongest` candidates (`candidates` sorted by strength), then the
/// `best_correlating` of the rest by ZNCC that lie on none of the chosen
/// alignment lines (within `line_tolerance` samples; growing one of those
/// covers them): the ones worth verifying.
pub fn to_verify(
    candidates: &[Candidate],
    strongest: usize,
    best_correlating: usize,
    line_tolerance: usize,
) -> Vec<&Candidate> {
    let mut chosen: Vec<&Candidate> = candidates.iter().take(strongest).collect();
    let mut rest: Vec<&Candidate> = candidates.iter().skip(strongest).collect();
    rest.sort_by(|x, y| y.zncc.total_cmp(&x.zncc));
    let mut extra = 0;
    for c in rest {
        if extra >= best_correlating {
            break;
        }
        let on_chosen_line = chosen.iter().any(|k| {
            k.orientation == c.orientation && k.line.abs_diff(c.line) <= line_tolerance as u64
        });
        if !on_chosen_line {
            chosen.push(c);
            extra += 1;
        }
    }
    chosen
}

/// Merges a vote into the pool entry of its line whose query range it
/// overlaps (parts of one line far apart are coincidences, kept apart).
fn pool(
    pooled: &mut HashMap<(Orientation, i64), Vec<Candidate>>,
    key: (Orientation, i64),
    cand: Candidate,
) {
    let entries = pooled.entry(key).or_default();
    let overlapping = entries
        .iter_mut()
        .find(|p| p.query[0] <= cand.query[1] && cand.query[0] <= p.query[1]);
    match overlapping {
        None => entries.push(cand),
        Some(p) => {
            p.strength += cand.strength;
            p.query = [p.query[0].min(cand.query[0]), p.query[1].max(cand.query[1])];
            // The best vote: highest ZNCC, longer queries winning near-ties.
            if cand.zncc * (cand.query[1] - cand.query[0]) as f64
                > p.zncc * (p.seed[1] - p.seed[0]) as f64
            {
                p.zncc = cand.zncc;
                p.line = cand.line;
                p.seed = cand.query;
            }
        }
    }
}

/// The best `peaks_per_query` local maxima of `sign * s` above the threshold,
/// at least `spacing` apart: `(offset, score)`.
fn peaks(s: &[f64], sign: f64, config: &QueryConfig, spacing: usize) -> Vec<(usize, f64)> {
    let mut found: Vec<(usize, f64)> = Vec::new();
    super::peaks::local_maxima(s, sign, 0..s.len(), config.min_zncc, |d, v| {
        found.push((d, v))
    });
    found.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut kept: Vec<(usize, f64)> = Vec::with_capacity(config.peaks_per_query);
    for (d, v) in found {
        if kept.iter().all(|&(k, _)| k.abs_diff(d) >= spacing.max(1)) {
            kept.push((d, v));
            if kept.len() == config.peaks_per_query {
                break;
            }
        }
    }
    kept
}
