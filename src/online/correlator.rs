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

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

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

/// Pieces shared by several workers, each with the same history: the first
/// to reach a boundary computes its piece, the others take it if it is
/// there by then. Nobody waits, so the workers stay as free of each other
/// as before (waiting for a piece's owner coupled them: KITTI 00 streamed
/// in 31 ms instead of 22).
pub struct SharedPieces {
    slots: Mutex<Slots>,
}

/// The workers still taking pieces, and each piece by boundary number with
/// how many of them have it.
struct Slots {
    workers: usize,
    held: HashMap<usize, (Arc<Piece>, usize)>,
}

impl SharedPieces {
    /// Pieces shared by `workers` workers.
    pub fn new(workers: usize) -> Self {
        SharedPieces {
            slots: Mutex::new(Slots {
                workers,
                held: HashMap::new(),
            }),
        }
    }

    /// A worker stops taking pieces (it was lost): the pieces every other
    /// worker has are freed now, and later ones once the others have them.
    pub fn leave(&self) {
        if let Ok(mut slots) = self.slots.lock() {
            let Slots { workers, held } = &mut *slots;
            *workers = workers.saturating_sub(1);
            held.retain(|_, (_, taken)| *taken < *workers);
        }
    }

    /// The piece of boundary `k`: another worker's, or `compute`d.
    pub fn piece(&self, k: usize, compute: impl FnOnce() -> Piece) -> Arc<Piece> {
        let held = self
            .slots
            .lock()
            .ok()
            .and_then(|s| s.held.get(&k).map(|s| s.0.clone()));
        let piece = held.unwrap_or_else(|| Arc::new(compute()));
        let Ok(mut slots) = self.slots.lock() else {
            return piece;
        };
        let Slots { workers, held } = &mut *slots;
        // The first piece stored is the one handed out (two workers may
        // compute it at once). Every worker asks for every boundary once:
        // the last one frees it.
        let slot = held.entry(k).or_insert((piece, 0));
        slot.1 += 1;
        let piece = slot.0.clone();
        if slot.1 >= *workers {
            held.remove(&k);
        }
        piece
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
        let t = &self.transform;
        let block = t.block();
        // The inverse transform's 1/M folded into the piece's spectrum.
        let mut query = Vec::new();
        t.spectrum_into(p, 1.0 / (2 * block) as f32, &mut query, &mut self.scratch);
        let mut buf = Vec::new();
        // The finished blocks' spectra, and those of the rest (the open
        // tail) made for this piece only.
        let rest: Vec<_> = a[(self.spectra.len() * block).min(h)..]
            .chunks(block)
            .map(|chunk| t.spectrum(chunk, &mut self.scratch))
            .collect();
        for (j, spectrum) in self.spectra.iter().chain(&rest).enumerate() {
            t.add_block(
                j,
                spectrum,
                &query,
                len,
                &mut forward,
                &mut reversed,
                &mut buf,
                &mut self.scratch,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shared_piece_is_computed_once_and_freed_once_every_worker_has_it() {
        let shared = SharedPieces::new(2);
        let computed = std::cell::Cell::new(0);
        let compute = || {
            computed.set(computed.get() + 1);
            Piece {
                start: 0,
                len: 1,
                forward: vec![1.0],
                reversed: vec![-1.0],
            }
        };
        let first = shared.piece(7, compute);
        let second = shared.piece(7, compute);
        assert_eq!(computed.get(), 1);
        assert!(Arc::ptr_eq(&first, &second));
        assert!(shared.slots.lock().unwrap().held.is_empty());
        // Asked for once more after every worker had it: computed anew.
        shared.piece(7, compute);
        assert_eq!(computed.get(), 2);
    }

    /// Regression: a lost worker never took its pieces, so every later
    /// piece stayed held for it, for ever.
    #[test]
    fn a_lost_worker_leaves_no_piece_held_for_it() {
        let shared = SharedPieces::new(3);
        let compute = || Piece {
            start: 0,
            len: 1,
            forward: vec![1.0],
            reversed: vec![-1.0],
        };
        shared.piece(1, compute);
        shared.piece(1, compute);
        shared.piece(2, compute);
        shared.leave();
        // Boundary 1: both remaining workers have it; 2: one of them.
        assert_eq!(shared.slots.lock().unwrap().held.len(), 1);
        shared.piece(2, compute);
        assert!(shared.slots.lock().unwrap().held.is_empty());
    }
}
