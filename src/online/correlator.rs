//! ZNCC of the newest queries against the whole history, sub-linear per
//! new segment.
//!
//! The history signature `a` is cut into blocks of `B` samples; each
//! finished block keeps its spectrum (FFT of size `M = 2B`, `f32`), so a
//! block is transformed once in its life. When a segment is finalised, its
//! samples `p` (a *piece*: `[b_{i-1}, b_i)`) are correlated with every block
//! by one multiply and one inverse FFT per block, both directions at once:
//! `IFFT(A P̄ + i A P)` carries the correlation in its real part and the
//! convolution in its imaginary part. The block arithmetic is the batch
//! search's own ([`crate::matching::blocks`]); only the caching differs.
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

use std::sync::OnceLock;

use rustfft::num_complex::Complex;

use crate::matching::blocks::BlockTransform;

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

/// A segment's piece, computed the first time a matching needs it (by the
/// thread that gets there first; another that needs it meanwhile waits for
/// it), against the history as it stood when the segment was finalised.
/// Computing it there rather than where the segment is taken in moves the
/// worker's largest serial cost into the matchings, which run in parallel.
#[derive(Debug)]
pub struct LazyPiece {
    /// First signature sample of the piece.
    pub start: usize,
    /// Number of samples.
    pub len: usize,
    /// Signature samples in the history when the segment was finalised.
    history: usize,
    piece: OnceLock<Piece>,
}

impl LazyPiece {
    /// The piece `[start, start + len)` against the first `history`
    /// signature samples.
    pub fn new(start: usize, len: usize, history: usize) -> Self {
        LazyPiece {
            start,
            len,
            history,
            piece: OnceLock::new(),
        }
    }

    /// The piece, computed now if no one has yet (`a` holds at least the
    /// history it is computed against).
    pub fn get(&self, correlator: &BlockCorrelator, a: &[f32]) -> &Piece {
        self.piece
            .get_or_init(|| correlator.piece(&a[..self.history], self.start, self.len))
    }

    /// Bytes held (none until computed).
    pub fn bytes(&self) -> usize {
        self.piece
            .get()
            .map_or(0, |p| (p.forward.capacity() + p.reversed.capacity()) * 4)
    }
}

/// Block spectra of the history and its prefix sums.
pub struct BlockCorrelator {
    transform: BlockTransform<f32>,
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
        BlockCorrelator {
            // The transforms size their scratch on first use.
            transform: BlockTransform::new(block.max(16)),
            spectra: Vec::new(),
            scratch: Vec::new(),
            prefix: vec![0.0],
            prefix_sq: vec![0.0],
        }
    }

    /// Longest piece the block transform handles (longer ones are correlated
    /// directly).
    pub fn max_piece(&self) -> usize {
        self.transform.max_query()
    }

    /// Takes in the history's new values (`a` is the whole history).
    pub fn update(&mut self, a: &[f32]) {
        for &x in &a[self.prefix.len() - 1..] {
            let x = x as f64;
            self.prefix.push(self.prefix.last().unwrap() + x);
            self.prefix_sq.push(self.prefix_sq.last().unwrap() + x * x);
        }
        let block = self.transform.block();
        while (self.spectra.len() + 1) * block <= a.len() {
            let b = self.spectra.len();
            let spec = self
                .transform
                .spectrum(&a[b * block..(b + 1) * block], &mut self.scratch);
            self.spectra.push(spec);
        }
    }

    /// Raw correlations of the piece `a[start..start+len]` with all of `a`
    /// (a prefix of the history taken in).
    pub fn piece(&self, a: &[f32], start: usize, len: usize) -> Piece {
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
        let t = &self.transform;
        let block = t.block();
        let mut scratch = Vec::new();
        // The inverse transform's 1/M folded into the piece's spectrum.
        let mut query = Vec::new();
        t.spectrum_into(p, 1.0 / (2 * block) as f32, &mut query, &mut scratch);
        let mut buf = Vec::new();
        // The blocks finished within `a` keep their spectra; those of the
        // rest (the open tail) are made for this piece only.
        let done = &self.spectra[..self.spectra.len().min(h / block)];
        let rest: Vec<_> = a[done.len() * block..]
            .chunks(block)
            .map(|chunk| t.spectrum(chunk, &mut scratch))
            .collect();
        for (j, spectrum) in done.iter().chain(&rest).enumerate() {
            t.add_block(
                j,
                spectrum,
                &query,
                len,
                &mut forward,
                &mut reversed,
                &mut buf,
                &mut scratch,
            );
        }
        // `add_block` adds the convolution; the reversed query negates it.
        for r in &mut reversed {
            *r = -*r;
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
