//! Segmentation into G2 clothoid pieces, scale-free.
//!
//! In the `K` domain a path is a sequence of turns. The local radius of
//! curvature per unit turn, `r = ln(ds/dK)`, is low at a corner's apex and
//! high on the straights and inflections between corners. Boundaries are the
//! prominent extrema of `r`: straights/inflections (maxima) and apexes
//! (minima). Between an apex and a straight the curvature rises or falls
//! monotonically, which is what a clothoid (curvature linear in arc length)
//! models, so each piece is fitted as one, continuous at the boundaries.
//!
//! Everything is measured in `K` samples and in ratios of `ds/dK`: scaling
//! the path shifts `r` by a constant and moves no boundary; rotation and
//! translation change nothing; reversing the path reverses the sequence.

use crate::signature::Signature;

/// Settings of the segmentation.
#[derive(Debug, Clone, Copy)]
pub struct SegmentConfig {
    /// Half-width of the window (radians of `K`) in which a boundary must be
    /// the extremum: about half a typical corner.
    pub window: f64,
    /// Minimal ratio between `ds/dK` at an extremum and at the opposite
    /// extremes on both sides of it.
    pub prominence_ratio: f64,
}

impl Default for SegmentConfig {
    fn default() -> Self {
        SegmentConfig {
            window: 40f64.to_radians(),
            prominence_ratio: 2.0,
        }
    }
}

/// One clothoid piece between two boundaries, in `K` samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// First signature sample.
    pub start: usize,
    /// Last signature sample (the next segment's start).
    pub end: usize,
    /// Curvature at the start and end (path units), linear in arc length between.
    pub kappa: [f64; 2],
    /// Arc length at the start and end.
    pub s: [f64; 2],
}

/// Boundaries (signature sample indices, increasing, first and last
/// included): the [`BoundaryStream`] fed the whole signature.
pub fn boundaries(sig: &Signature, config: &SegmentConfig) -> Vec<usize> {
    let mut stream = BoundaryStream::new(config, sig.dk);
    let mut out = Vec::new();
    for &s in &sig.s {
        out.extend(stream.push(s));
    }
    out.extend(stream.flush());
    out
}

/// Segment boundaries one signature sample at a time.
///
/// `r_j = ln(s_{j+1} - s_j)` (the arc length per `K` step after sample
/// `j`) needs sample `j + 1`; sample `j` is a boundary when it
/// is the prominent extremum of `r` within `±w` samples, so it is final once
/// sample `j + w + 1` has arrived: a bounded lag of `w + 1` samples
/// (`window` radians of `K` plus one step).
#[derive(Debug, Clone)]
pub struct BoundaryStream {
    w: usize,
    p: f64,
    /// Arc length of the first sample and of the last two.
    s0: f64,
    s_prev: [f64; 2],
    /// `r` of samples `r_base ..`, the last `2w + 1` of them.
    r: std::collections::VecDeque<f64>,
    r_base: usize,
    /// Samples received.
    n: usize,
    /// Next sample to test.
    next: usize,
}

impl BoundaryStream {
    /// A stream for signature step `dk` (radians).
    pub fn new(config: &SegmentConfig, dk: f64) -> Self {
        BoundaryStream {
            w: ((config.window / dk).round() as usize).max(2),
            p: config.prominence_ratio.ln(),
            s0: 0.0,
            s_prev: [0.0; 2],
            r: std::collections::VecDeque::new(),
            r_base: 0,
            n: 0,
            next: 1,
        }
    }

    /// Lag in samples between a sample's arrival and its boundary decision.
    pub fn lag(&self) -> usize {
        self.w + 1
    }

    /// Samples received so far.
    pub fn received(&self) -> usize {
        self.n
    }

    /// Feeds the arc length of the next signature sample; returns the
    /// boundary it finalises, if any (sample 0 is always one).
    pub fn push(&mut self, s: f64) -> Option<usize> {
        let n = self.n;
        self.n += 1;
        if n == 0 {
            self.s0 = s;
            self.s_prev = [s, s];
            return Some(0);
        }
        // r of sample n-1: the gap to the next sample. (One-sided on
        // purpose: a straight lies in one gap, so it is one clear maximum,
        // not a near-tie of two samples that travel direction would break
        // differently.)
        self.push_r(s - self.s_prev[1], s);
        self.s_prev = [self.s_prev[1], s];
        // Sample j = n-1-w now has its whole window.
        let j = (n - 1).checked_sub(self.w)?;
        if j < self.next || j == 0 {
            return None;
        }
        self.next = j + 1;
        self.test(j, n - 1).then_some(j)
    }

    /// The boundaries still owed at the end of the signature, its last
    /// sample included.
    pub fn flush(&mut self) -> Vec<usize> {
        let n = self.n;
        if n == 0 {
            return vec![];
        }
        if n == 1 {
            return vec![0];
        }
        // r of the last sample, one-sided.
        let ds = self.s_prev[1] - self.s_prev[0];
        self.push_r(ds, self.s_prev[1]);
        let mut out = Vec::new();
        if n >= 3 {
            while self.next + 1 < n {
                let j = self.next;
                self.next += 1;
                if self.test(j, n - 1) {
                    out.push(j);
                }
            }
        }
        out.push(n - 1);
        out
    }

    /// Appends `r = ln(ds)` (floored so that a stop in `s` cannot give
    /// `-inf`; the floor follows the arc length so far).
    fn push_r(&mut self, ds: f64, s: f64) {
        let floor = ((s - self.s0) * 1e-12).max(f64::MIN_POSITIVE);
        self.r.push_back(ds.max(floor).ln());
        while self.r.len() > 2 * self.w + 2 {
            self.r.pop_front();
            self.r_base += 1;
        }
    }

    /// Is sample `j` the prominent extremum of `r` over `[j-w, min(j+w, last)]`?
    fn test(&self, j: usize, last: usize) -> bool {
        let lo = j.saturating_sub(self.w);
        let hi = (j + self.w).min(last);
        let r = |i: usize| self.r[i - self.r_base];
        let v = r(j);
        let left = (lo..j).map(r);
        let right = (j + 1..=hi).map(r);
        let is_max = left.clone().all(|x| x < v) && right.clone().all(|x| x <= v);
        let is_min = left.clone().all(|x| x > v) && right.clone().all(|x| x >= v);
        if is_max {
            let lmin = left.fold(f64::INFINITY, f64::min);
            let rmin = right.fold(f64::INFINITY, f64::min);
            v - lmin >= self.p && v - rmin >= self.p
        } else if is_min {
            let lmax = left.fold(f64::NEG_INFINITY, f64::max);
            let rmax = right.fold(f64::NEG_INFINITY, f64::max);
            lmax - v >= self.p && rmax - v >= self.p
        } else {
            false
        }
    }
}

/// Arc length of boundary `k`: the middle of the step after it, so that a
/// boundary on a straight sits mid-straight whichever way the path runs.
pub fn boundary_arc(sig: &Signature, k: usize) -> f64 {
    match (sig.s.get(k), sig.s.get(k + 1)) {
        (Some(a), Some(b)) => 0.5 * (a + b),
        (Some(a), None) => *a,
        _ => 0.0,
    }
}

/// The clothoid pieces between boundaries, each fitted with curvature linear
/// in arc length and continuous across boundaries (G2).
pub fn segments(sig: &Signature, bounds: &[usize]) -> Vec<Segment> {
    // Curvature at each boundary: the signed compressed value squared back
    // (the signature stores sign(κ)|κ|^½). Using the boundary values for both
    // neighbours makes the piecewise-linear curvature continuous.
    let kappa_at = |j: usize| sig.value[j] * sig.value[j].abs();
    bounds
        .windows(2)
        .map(|b| Segment {
            start: b[0],
            end: b[1],
            kappa: [kappa_at(b[0]), kappa_at(b[1])],
            s: [boundary_arc(sig, b[0]), boundary_arc(sig, b[1])],
        })
        .collect()
}
