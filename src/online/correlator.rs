//! ZNCC of the newest queries against the whole history, sub-linear per
//! new segment.
//!
//! The history signature `a` is cut into blocks of `B` samples; each
//! finished block keeps its spectrum (FFT of size `M = 2B`, `f32`), so a
//! block is transformed once in its life. When a segment is finalised, its
//! samples `p` (a *piece*: `[b_{i-1}, b_i)`) are correlated with every block
//! by one multiply and one inverse FFT per block, both directions at once:
//! `IFFT(A P̄ + i A P)` carries the correlation in its real part and the
//! convolution in its imaginary part (as in [`crate::matching::zncc`]).
//! The piece's raw correlations are cached:
//!
//! `G_i[e] = Σ_j p_j a[e + j]` (forward, `e` = target of the piece's first
//! sample), `R_i[e] = -Σ_j p_j a[e - j]` (reversed).
//!
//! A query of the last `N` segments is the concatenation of the last `N`
//! pieces and the newest boundary sample, so its raw correlation at every
//! alignment is a sum of cached arrays: each new segment costs one piece
//! transform against the history plus `O(N_max)` array passes, instead of
//! `N_max` full correlations. Means and deviations come from prefix sums, so
//! the ZNCC equals the batch correlator's (to `f32` rounding).

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

/// A piece's cached raw correlations with the history as it was then.
#[derive(Debug, Clone)]
pub struct Piece {
    /// First signature sample of the piece.
    pub start: usize,
    /// Number of samples.
    pub len: usize,
    /// `G[e]`, forward.
    pub forward: Vec<f32>,
    /// `R[e]`, reversed.
    pub reversed: Vec<f32>,
}

/// Block spectra of the history and its prefix sums.
pub struct BlockCorrelator {
    block: usize,
    fft: Arc<dyn Fft<f32>>,
    ifft: Arc<dyn Fft<f32>>,
    spectra: Vec<Vec<Complex<f32>>>,
    scratch: Vec<Complex<f32>>,
    /// Prefix sums of the values and their squares.
    pub prefix: Vec<f64>,
    /// See `prefix`.
    pub prefix_sq: Vec<f64>,
}

impl BlockCorrelator {
    /// Blocks of `block` samples.
    pub fn new(block: usize) -> Self {
        let block = block.max(16);
        let mut planner = FftPlanner::new();
        let fft = planner.plan_fft_forward(2 * block);
        let ifft = planner.plan_fft_inverse(2 * block);
        let scratch = vec![
            Complex::new(0.0, 0.0);
            fft.get_inplace_scratch_len()
                .max(ifft.get_inplace_scratch_len())
        ];
        BlockCorrelator {
            block,
            fft,
            ifft,
            spectra: Vec::new(),
            scratch,
            prefix: vec![0.0],
            prefix_sq: vec![0.0],
        }
    }

    /// Longest piece the block transform handles (longer ones are correlated
    /// directly).
    pub fn max_piece(&self) -> usize {
        self.block + 1
    }

    /// Takes in the history's new values (`a` is the whole history).
    pub fn update(&mut self, a: &[f32]) {
        for &x in &a[self.prefix.len() - 1..] {
            let x = x as f64;
            self.prefix.push(self.prefix.last().unwrap() + x);
            self.prefix_sq.push(self.prefix_sq.last().unwrap() + x * x);
        }
        while (self.spectra.len() + 1) * self.block <= a.len() {
            let b = self.spectra.len();
            let spec = self.spectrum(&a[b * self.block..(b + 1) * self.block]);
            self.spectra.push(spec);
        }
    }

    fn spectrum(&mut self, x: &[f32]) -> Vec<Complex<f32>> {
        let mut buf: Vec<Complex<f32>> = x.iter().map(|&v| Complex::new(v, 0.0)).collect();
        buf.resize(2 * self.block, Complex::new(0.0, 0.0));
        self.fft.process_with_scratch(&mut buf, &mut self.scratch);
        buf
    }

    /// Raw correlations of the piece `a[start..start+len]` with all of `a`.
    pub fn piece(&mut self, a: &[f32], start: usize, len: usize) -> Piece {
        let h = a.len();
        let p = &a[start..start + len];
        let mut forward = vec![0f32; h];
        let mut reversed = vec![0f32; h];
        if len > self.max_piece() {
            for e in 0..h {
                let (mut f, mut r) = (0f32, 0f32);
                for (j, &pj) in p.iter().enumerate() {
                    if e + j < h {
                        f += pj * a[e + j];
                    }
                    if e >= j {
                        r -= pj * a[e - j];
                    }
                }
                forward[e] = f;
                reversed[e] = r;
            }
            return Piece {
                start,
                len,
                forward,
                reversed,
            };
        }
        let m = 2 * self.block;
        let mut pf: Vec<Complex<f32>> = p.iter().map(|&v| Complex::new(v, 0.0)).collect();
        pf.resize(m, Complex::new(0.0, 0.0));
        self.fft.process_with_scratch(&mut pf, &mut self.scratch);
        let blocks = h.div_ceil(self.block);
        let norm = 1.0 / m as f32;
        let i = Complex::new(0.0f32, 1.0);
        let mut buf = vec![Complex::new(0.0f32, 0.0); m];
        for b in 0..blocks {
            let tail;
            let spec: &[Complex<f32>] = if b < self.spectra.len() {
                &self.spectra[b]
            } else {
                tail = self.spectrum(&a[b * self.block..h.min((b + 1) * self.block)]);
                &tail
            };
            for k in 0..m {
                let (x, q) = (spec[k], pf[k]);
                buf[k] = x * q.conj() + i * (x * q);
            }
            self.ifft.process_with_scratch(&mut buf, &mut self.scratch);
            let base = (b * self.block) as i64;
            // Forward: e - base in [-(len-1), B-1].
            let lo = (base - (len as i64 - 1)).max(0);
            let hi = (base + self.block as i64 - 1).min(h as i64 - 1);
            for e in lo..=hi {
                let k = (e - base).rem_euclid(m as i64) as usize;
                forward[e as usize] += buf[k].re * norm;
            }
            // Reversed: e - base in [0, B + len - 2].
            let hi = (base + (self.block + len) as i64 - 2).min(h as i64 - 1);
            for e in base..=hi {
                reversed[e as usize] -= buf[(e - base) as usize].im * norm;
            }
        }
        Piece {
            start,
            len,
            forward,
            reversed,
        }
    }

    /// Sum and sum of squares of `a[lo..lo+len]`.
    pub fn window(&self, lo: usize, len: usize) -> (f64, f64) {
        (
            self.prefix[lo + len] - self.prefix[lo],
            self.prefix_sq[lo + len] - self.prefix_sq[lo],
        )
    }

    /// Bytes held by the block spectra and prefix sums.
    pub fn bytes(&self) -> usize {
        self.spectra.iter().map(|s| s.capacity() * 8).sum::<usize>()
            + (self.prefix.capacity() + self.prefix_sq.capacity()) * 8
    }
}
