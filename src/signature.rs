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

impl Signature {
    /// Resamples the track's curvature on a uniform `K` grid.
    pub fn build(track: &Track, config: &SignatureConfig) -> Signature {
        let k = dead_band_turning(&track.heading, config.dead_band);
        let mut sig = Signature {
            dk: config.dk,
            ..Signature::default()
        };
        let total = *k.cumulative.last().unwrap_or(&0.0);
        let steps = (total / config.dk).floor() as usize;
        let mut i = 0;
        for j in 0..=steps {
            let target = j as f64 * config.dk;
            while i + 1 < k.cumulative.len() && k.cumulative[i + 1] < target {
                i += 1;
            }
            // Fractional grid index where K crosses `target`.
            let at = if i + 1 < k.cumulative.len() {
                let (k0, k1) = (k.cumulative[i], k.cumulative[i + 1]);
                let f = if k1 > k0 {
                    ((target - k0) / (k1 - k0)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                i as f64 + f
            } else {
                i as f64
            };
            let dir = k.direction[(i + 1).min(k.direction.len() - 1)];
            let kappa = Track::interp(&track.curvature, at).abs();
            sig.value.push(dir * kappa.sqrt());
            sig.s.push(Track::interp(&track.s, at));
            sig.grid.push(at);
        }
        sig
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
    let half = band / 2.0;
    let mut cumulative = Vec::with_capacity(heading.len());
    let mut direction = Vec::with_capacity(heading.len());
    let Some(&first) = heading.first() else {
        return DeadBandTurning {
            cumulative,
            direction,
        };
    };
    let (mut y, mut acc, mut dir) = (first, 0.0, 1.0);
    for &theta in heading {
        let next = y.clamp(theta - half, theta + half);
        let d = next - y;
        if d != 0.0 {
            dir = d.signum();
        }
        acc += d.abs();
        y = next;
        cumulative.push(acc);
        direction.push(dir);
    }
    DeadBandTurning {
        cumulative,
        direction,
    }
}
