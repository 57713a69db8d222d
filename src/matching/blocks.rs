//! Overlap-add correlation of a short query with a long signal cut into
//! blocks, shared by the batch search ([`crate::matching::zncc`], `f64`,
//! blocks made once per query size class) and the online detector
//! (`online::correlator`, `f32`, blocks made once in the history's life).
//!
//! The signal `a` is cut into blocks of `B` samples, each zero-padded to
//! `M = 2B` and transformed. For a query `q` of `L <= B + 1` samples with
//! spectrum `Q` (also at size `M`), block `j` (starting at `base = jB`)
//! contributes, through one inverse transform of `A_j Q̄ + i A_j Q`,
//!
//! - to the correlation `corr[d] = Σ_t q_t a[d + t]` at `d = base + t`,
//!   `t` in `1 - L..B` (its real part, negative `t` wrapped to `M + t`);
//! - to the convolution `conv[e] = Σ_t q_t a[e - t]` at `e = base + u`,
//!   `u` in `0..B + L - 1` (its imaginary part).
//!
//! Both sums are real, so one complex transform carries both; the sum over
//! all blocks is exact (up to rounding) because no index wraps twice when
//! `L <= B + 1`.

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftNum, FftPlanner};

/// Forward and inverse transforms of size `2B` for blocks of `B` samples.
pub struct BlockTransform<T: FftNum> {
    block: usize,
    fft: Arc<dyn Fft<T>>,
    ifft: Arc<dyn Fft<T>>,
}

impl<T: FftNum> BlockTransform<T> {
    /// Transforms for blocks of `block` samples (`block >= 1`).
    pub fn new(block: usize) -> Self {
        let block = block.max(1);
        let mut planner = FftPlanner::new();
        BlockTransform {
            block,
            fft: planner.plan_fft_forward(2 * block),
            ifft: planner.plan_fft_inverse(2 * block),
        }
    }

    /// Samples per block, `B`.
    pub fn block(&self) -> usize {
        self.block
    }

    /// Longest query the block sums hold exactly, `B + 1`.
    pub fn max_query(&self) -> usize {
        self.block + 1
    }

    /// Scratch length both transforms need.
    fn scratch_len(&self) -> usize {
        self.fft
            .get_inplace_scratch_len()
            .max(self.ifft.get_inplace_scratch_len())
    }

    /// Spectrum of `x` (at most `2B` samples, each times `gain`),
    /// zero-padded to `2B`, written into `out`.
    pub fn spectrum_into(
        &self,
        x: &[T],
        gain: T,
        out: &mut Vec<Complex<T>>,
        scratch: &mut Vec<Complex<T>>,
    ) {
        out.clear();
        out.extend(x.iter().map(|&v| Complex::new(v * gain, T::zero())));
        out.resize(2 * self.block, Complex::new(T::zero(), T::zero()));
        self.forward(out, scratch);
    }

    /// Spectrum of `x` (at most `B` samples), zero-padded to `2B`.
    pub fn spectrum(&self, x: &[T], scratch: &mut Vec<Complex<T>>) -> Vec<Complex<T>> {
        let mut out = Vec::with_capacity(2 * self.block);
        self.spectrum_into(x, T::one(), &mut out, scratch);
        out
    }

    /// Spectra of every block of `a` (the last one may be short).
    pub fn spectra(&self, a: &[T]) -> Vec<Vec<Complex<T>>> {
        let mut scratch = Vec::new();
        a.chunks(self.block)
            .map(|chunk| self.spectrum(chunk, &mut scratch))
            .collect()
    }

    fn forward(&self, x: &mut [Complex<T>], scratch: &mut Vec<Complex<T>>) {
        self.fit_scratch(scratch);
        self.fft.process_with_scratch(x, scratch);
    }

    fn fit_scratch(&self, scratch: &mut Vec<Complex<T>>) {
        let need = self.scratch_len();
        if scratch.len() < need {
            scratch.resize(need, Complex::new(T::zero(), T::zero()));
        }
    }

    /// Adds block `j`'s share (spectrum `block_spectrum`) of the raw
    /// correlation and convolution of a query of `len` samples (spectrum
    /// `query`, from [`BlockTransform::spectrum_into`]) into `corr` and
    /// `conv`; indices past either slice's end are not needed and skipped.
    /// A query longer than [`BlockTransform::max_query`] (or empty) adds
    /// nothing: its sums would wrap.
    #[allow(clippy::too_many_arguments)]
    pub fn add_block(
        &self,
        j: usize,
        block_spectrum: &[Complex<T>],
        query: &[Complex<T>],
        len: usize,
        corr: &mut [T],
        conv: &mut [T],
        buf: &mut Vec<Complex<T>>,
        scratch: &mut Vec<Complex<T>>,
    ) {
        let (b, m) = (self.block, 2 * self.block);
        if len == 0 || len > self.max_query() {
            return;
        }
        let i = Complex::new(T::zero(), T::one());
        buf.clear();
        buf.extend(
            block_spectrum
                .iter()
                .zip(query)
                .map(|(&a, &q)| a * q.conj() + i * (a * q)),
        );
        self.fit_scratch(scratch);
        self.ifft.process_with_scratch(buf, scratch);
        let base = j * b;
        // Correlation at `base + t`, `t` in `1 - len..b`.
        let first = base.saturating_sub(len - 1);
        let end = (base + b).min(corr.len());
        for (d, c) in corr.iter_mut().enumerate().take(end).skip(first) {
            *c = *c + buf[(d + m - base) % m].re;
        }
        // Convolution at `base + u`, `u` in `0..b + len - 1`.
        if let Some(tail) = conv.get_mut(base..) {
            for (c, x) in tail.iter_mut().zip(&buf[..b + len - 1]) {
                *c = *c + x.im;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both sums, directly.
    fn direct(a: &[f64], q: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = a.len();
        let corr = (0..n)
            .map(|d| {
                q.iter()
                    .enumerate()
                    .filter(|(t, _)| d + t < n)
                    .map(|(t, x)| x * a[d + t])
                    .sum()
            })
            .collect();
        let conv = (0..n)
            .map(|e| {
                q.iter()
                    .enumerate()
                    .filter(|(t, _)| *t <= e)
                    .map(|(t, x)| x * a[e - t])
                    .sum()
            })
            .collect();
        (corr, conv)
    }

    #[test]
    fn block_sums_equal_the_direct_correlation_and_convolution() {
        let a: Vec<f64> = (0..300).map(|i| ((i * 37 % 101) as f64).sin()).collect();
        for block in [1, 4, 16, 64] {
            let t = BlockTransform::<f64>::new(block);
            let spectra = t.spectra(&a);
            for len in [1, 2, block / 2 + 1, block, block + 1] {
                let q: Vec<f64> = (0..len).map(|i| (i as f64 * 0.7).cos()).collect();
                let (mut query, mut buf, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
                t.spectrum_into(&q, 1.0 / (2 * block) as f64, &mut query, &mut scratch);
                let (mut corr, mut conv) = (vec![0.0; a.len()], vec![0.0; a.len()]);
                for (j, s) in spectra.iter().enumerate() {
                    t.add_block(
                        j,
                        s,
                        &query,
                        len,
                        &mut corr,
                        &mut conv,
                        &mut buf,
                        &mut scratch,
                    );
                }
                let (c, v) = direct(&a, &q);
                for d in 0..a.len() {
                    assert!(
                        (corr[d] - c[d]).abs() < 1e-9,
                        "corr B={block} L={len} d={d}"
                    );
                    assert!(
                        (conv[d] - v[d]).abs() < 1e-9,
                        "conv B={block} L={len} d={d}"
                    );
                }
            }
        }
    }
}
