//! The scale-free signature: curvature resampled at uniform steps of the
//! integral of absolute curvature `K(s) = ∫|κ| ds`.
//!
//! `K` is measured on the heading after a dead band (a play operator of
//! width [`SignatureConfig::dead_band`]): heading wiggles smaller than the
//! band never add to `K`, so sensor noise on a straight does not count as a
//! turn. Arc length is carried beside each sample, because straights carry
//! no `K` and their length must be checked separately.

use crate::track::Track;

/// Settings of the signature.
#[derive(Debug, Clone, Copy)]
pub struct SignatureConfig {
    /// Step of the uniform `K` grid (radians).
    pub dk: f64,
    /// Heading changes smaller than this (radians) are not turns.
    pub dead_band: f64,
}

impl Default for SignatureConfig {
    fn default() -> Self {
        SignatureConfig {
            dk: 2f64.to_radians(),
            dead_band: 4f64.to_radians(),
        }
    }
}

/// Curvature at uniform steps of `K`, with arc length and track position.
#[derive(Debug, Clone, Default)]
pub struct Signature {
    /// `K` step (radians).
    pub dk: f64,
    /// Signed, magnitude-compressed curvature `sign(κ) |κ|^½` at each step.
    /// (A power law keeps ZNCC scale-free and tames sharp corners of densely
    /// sampled paths against the rounded ones of sparse paths.)
    pub value: Vec<f64>,
    /// Arc length of the track at each step.
    pub s: Vec<f64>,
    /// Fractional track grid index at each step.
    pub grid: Vec<f64>,
}

/// One signature sample: compressed curvature, arc length and fractional
/// track grid index at a multiple of `dk` of turning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigPoint {
    /// `sign(κ) |κ|^½`.
    pub value: f64,
    /// Arc length.
    pub s: f64,
    /// Fractional track grid index.
    pub grid: f64,
}

/// The last track sample the resampler saw.
#[derive(Debug, Clone, Copy)]
struct Seen {
    cumulative: f64,
    s: f64,
    curvature: f64,
}

/// The signature one track sample at a time: the dead-band play operator
/// and the resampling at uniform `K`. A sample at `K = j dk` is final as
/// soon as a track sample with `K >= j dk` has arrived (lag: one sample).
#[derive(Debug, Clone)]
pub struct SignatureStream {
    dk: f64,
    play: PlayOperator,
    /// Next `K` sample index.
    next: usize,
    /// Track samples seen.
    n: usize,
    last: Option<Seen>,
}

impl SignatureStream {
    /// A stream with these settings.
    pub fn new(config: &SignatureConfig) -> Self {
        SignatureStream {
            dk: config.dk,
            play: PlayOperator::new(config.dead_band),
            next: 0,
            n: 0,
            last: None,
        }
    }

    /// Signature samples emitted so far.
    pub fn emitted(&self) -> usize {
        self.next
    }

    /// Turning `K` so far (radians).
    pub fn turning(&self) -> f64 {
        self.play.total
    }

    /// Feeds the next track sample (its heading, curvature and arc length)
    /// and emits every `K` sample it completes.
    pub fn push(&mut self, heading: f64, curvature: f64, s: f64, out: &mut impl FnMut(SigPoint)) {
        let (cumulative, dir) = self.play.push(heading);
        let n = self.n;
        self.n += 1;
        let here = Seen {
            cumulative,
            s,
            curvature,
        };
        if let Some(prev) = self.last {
            loop {
                let target = self.next as f64 * self.dk;
                if target > cumulative || cumulative.is_nan() {
                    break;
                }
                // Crossing between samples n-1 and n, exactly as a whole-array
                // linear interpolation at the fractional index would do it.
                let (k0, k1) = (prev.cumulative, cumulative);
                let f = if k1 > k0 {
                    ((target - k0) / (k1 - k0)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let at = (n - 1) as f64 + f;
                let lerp = |a: f64, b: f64| {
                    if at >= n as f64 {
                        b
                    } else {
                        let g = at - (n - 1) as f64;
                        a * (1.0 - g) + b * g
                    }
                };
                let kappa = lerp(prev.curvature, curvature).abs();
                out(SigPoint {
                    value: dir * kappa.sqrt(),
                    s: lerp(prev.s, s),
                    grid: at,
                });
                self.next += 1;
            }
        }
        self.last = Some(here);
    }

    /// Emits the samples the end of the path still owes (`K` up to the
    /// total, placed at the last track sample).
    pub fn flush(&mut self, out: &mut impl FnMut(SigPoint)) {
        let Some(last) = self.last else {
            return;
        };
        let steps = (last.cumulative / self.dk).floor() as usize;
        while self.next <= steps {
            out(SigPoint {
                value: self.play.dir * last.curvature.abs().sqrt(),
                s: last.s,
                grid: (self.n - 1) as f64,
            });
            self.next += 1;
        }
    }
}

impl Signature {
    /// Resamples the track's curvature on a uniform `K` grid (the
    /// [`SignatureStream`] fed the whole track).
    pub fn build(track: &Track, config: &SignatureConfig) -> Signature {
        let mut sig = Signature {
            dk: config.dk,
            ..Signature::default()
        };
        let mut stream = SignatureStream::new(config);
        let mut sink = |p: SigPoint| sig.push(p);
        for i in 0..track.len() {
            stream.push(track.heading[i], track.curvature[i], track.s[i], &mut sink);
        }
        stream.flush(&mut sink);
        sig
    }

    /// Appends one sample.
    pub fn push(&mut self, p: SigPoint) {
        self.value.push(p.value);
        self.s.push(p.s);
        self.grid.push(p.grid);
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.value.len()
    }

    /// True when the path has no turn larger than the dead band.
    pub fn is_empty(&self) -> bool {
        self.value.is_empty()
    }

    /// Total turning `K` (radians).
    pub fn total(&self) -> f64 {
        self.dk * self.value.len().saturating_sub(1) as f64
    }
}

/// `K` along the track after the dead band, and the turn direction (+1 left,
/// -1 right) of each grid step.
pub struct DeadBandTurning {
    /// Cumulative dead-band turning at each grid sample.
    pub cumulative: Vec<f64>,
    /// Direction of the step arriving at each sample.
    pub direction: Vec<f64>,
}

/// Play operator: the output follows the heading only when the heading
/// leaves a band of width `band` around it; `K` is its total variation.
pub fn dead_band_turning(heading: &[f64], band: f64) -> DeadBandTurning {
    let mut play = PlayOperator::new(band);
    let mut cumulative = Vec::with_capacity(heading.len());
    let mut direction = Vec::with_capacity(heading.len());
    for &theta in heading {
        let (k, d) = play.push(theta);
        cumulative.push(k);
        direction.push(d);
    }
    DeadBandTurning {
        cumulative,
        direction,
    }
}

/// The play (backlash) operator of half-width `band / 2` on the heading,
/// with its total variation `K` and the direction of its last move.
#[derive(Debug, Clone, Copy)]
pub struct PlayOperator {
    half: f64,
    y: Option<f64>,
    /// Total variation so far (radians).
    pub total: f64,
    /// Direction of the last move (+1 left, -1 right; +1 before any move).
    pub dir: f64,
}

impl PlayOperator {
    /// A play operator with band width `band`, starting at the first input.
    pub fn new(band: f64) -> Self {
        PlayOperator {
            half: band / 2.0,
            y: None,
            total: 0.0,
            dir: 1.0,
        }
    }

    /// Feeds one heading: cumulative `K` and the current direction.
    pub fn push(&mut self, theta: f64) -> (f64, f64) {
        let y = *self.y.get_or_insert(theta);
        let next = y.clamp(theta - self.half, theta + self.half);
        let d = next - y;
        if d != 0.0 {
            self.dir = d.signum();
        }
        self.total += d.abs();
        self.y = Some(next);
        (self.total, self.dir)
    }
}
