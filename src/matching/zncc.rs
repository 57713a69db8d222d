//! ZNCC of a short query against every offset of a long signature.
//!
//! `zncc(d) = Σ_j (q_j - q̄)(a_{d+j} - ā_d) / (L σ_q σ_a(d))` for forward
//! travel. Travelling the query the other way reverses it and flips the sign
//! of curvature, `q'_j = -q_{L-1-j}`, which turns the correlation into a
//! convolution. Both come from one FFT of the query and one inverse FFT:
//! since both results are real, `IFFT(A Q̄ + i A Q)` carries the correlation
//! in its real part and the convolution in its imaginary part. Window means
//! and deviations of `a` come from prefix sums. Mirroring (the path seen
//! from the other side of its plane) negates every score.
//!
//! A query much shorter than the signature is correlated block by block
//! (overlap-add): the signature is cut into blocks of `B >= L` samples, each
//! block's spectrum at size `2B` computed once for all queries of that size
//! class, and every block's products summed into place. That costs about
//! `2n log 2B` per query instead of `2 · 2n log 2n` for one transform of the
//! whole length: the search of a long path is dominated by short queries.
//! The block arithmetic ([`crate::matching::blocks`]) is the online
//! detector's too.

use std::sync::{Arc, OnceLock};

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use super::blocks::BlockTransform;

/// Below this fraction of the signature's variance a window is flat: no
/// score (the online detector's scan uses the same).
pub const FLAT_FRACTION: f64 = 1e-4;

/// Smallest block of the block-wise correlation.
const MIN_BLOCK: usize = 64;

/// Scores of one query at every offset `d` in `0..=n-L`.
#[derive(Debug, Clone, Default)]
pub struct ZnccScores {
    /// Same direction of travel.
    pub forward: Vec<f64>,
    /// Opposite direction of travel (query reversed, curvature negated).
    pub reversed: Vec<f64>,
}

/// A long signature prepared for many queries: its spectrum and prefix sums.
pub struct Correlator {
    shared: Arc<Prepared>,
    fft: Arc<dyn Fft<f64>>,
    ifft: Arc<dyn Fft<f64>>,
    scratch: Vec<Complex<f64>>,
    buf: Vec<Complex<f64>>,
    /// The query's spectrum (block-wise path).
    query: Vec<Complex<f64>>,
    /// Raw correlation and convolution of the last query.
    corr: Vec<f64>,
    conv: Vec<f64>,
}

/// What every query reads: the signature, its prefix sums and spectrum.
struct Prepared {
    a: Vec<f64>,
    prefix: Vec<f64>,
    prefix_sq: Vec<f64>,
    flat: f64,
    fft_len: usize,
    spectrum: Vec<Complex<f64>>,
    /// Block spectra by `log2` of the block size, made on first use.
    blocks: [OnceLock<Blocks>; 32],
}

/// The signature cut into blocks of `block` samples, each zero-padded to
/// `2 · block` and transformed.
struct Blocks {
    transform: BlockTransform<f64>,
    spectra: Vec<Vec<Complex<f64>>>,
}

impl Blocks {
    fn new(a: &[f64], block: usize) -> Blocks {
        let transform = BlockTransform::new(block);
        let spectra = transform.spectra(a);
        Blocks { transform, spectra }
    }
}

impl Correlator {
    /// Prepares `a` for queries up to `max_query` samples long.
    pub fn new(a: &[f64], max_query: usize) -> Correlator {
        let n = a.len();
        let fft_len = (n + max_query).max(2).next_power_of_two();
        let mut planner = FftPlanner::new();
        let fft = planner.plan_fft_forward(fft_len);
        let ifft = planner.plan_fft_inverse(fft_len);
        let mut spectrum: Vec<Complex<f64>> = a.iter().map(|&x| Complex::new(x, 0.0)).collect();
        spectrum.resize(fft_len, Complex::new(0.0, 0.0));
        let scratch_len = fft
            .get_inplace_scratch_len()
            .max(ifft.get_inplace_scratch_len());
        let mut scratch = vec![Complex::new(0.0, 0.0); scratch_len];
        fft.process_with_scratch(&mut spectrum, &mut scratch);
        let mut prefix = vec![0.0; n + 1];
        let mut prefix_sq = vec![0.0; n + 1];
        for i in 0..n {
            prefix[i + 1] = prefix[i] + a[i];
            prefix_sq[i + 1] = prefix_sq[i] + a[i] * a[i];
        }
        let mean = if n > 0 { prefix[n] / n as f64 } else { 0.0 };
        let var = if n > 0 {
            (prefix_sq[n] / n as f64 - mean * mean).max(0.0)
        } else {
            0.0
        };
        Correlator {
            shared: Arc::new(Prepared {
                a: a.to_vec(),
                prefix,
                prefix_sq,
                flat: FLAT_FRACTION * var,
                fft_len,
                spectrum,
                blocks: std::array::from_fn(|_| OnceLock::new()),
            }),
            fft,
            ifft,
            scratch,
            buf: Vec::new(),
            query: Vec::new(),
            corr: Vec::new(),
            conv: Vec::new(),
        }
    }

    /// A second correlator over the same prepared signature, with its own
    /// buffers: one per thread.
    pub fn fork(&self) -> Correlator {
        Correlator {
            shared: Arc::clone(&self.shared),
            fft: Arc::clone(&self.fft),
            ifft: Arc::clone(&self.ifft),
            scratch: vec![Complex::new(0.0, 0.0); self.scratch.len()],
            buf: Vec::new(),
            query: Vec::new(),
            corr: Vec::new(),
            conv: Vec::new(),
        }
    }

    /// Length of the prepared signature.
    pub fn len(&self) -> usize {
        self.shared.a.len()
    }

    /// True when the prepared signature is empty.
    pub fn is_empty(&self) -> bool {
        self.shared.a.is_empty()
    }

    /// The prepared signature.
    pub fn signal(&self) -> &[f64] {
        &self.shared.a
    }

    /// ZNCC of `q` at every offset, by FFT. Falls back to [`zncc_direct`]
    /// when `q` is longer than the correlator was prepared for.
    pub fn scores(&mut self, q: &[f64]) -> ZnccScores {
        let Correlator {
            shared,
            fft,
            ifft,
            scratch,
            buf,
            query,
            corr,
            conv,
        } = self;
        let (n, l) = (shared.a.len(), q.len());
        if l < 2 || l > n {
            return ZnccScores::default();
        }
        if n + l > shared.fft_len {
            return zncc_direct(&shared.a, q);
        }
        let Some((qz, q_norm)) = centred(q) else {
            return ZnccScores::default();
        };
        let i = Complex::new(0.0, 1.0);
        let block = l.next_power_of_two().max(MIN_BLOCK);
        // `corr(d)` and `conv(d + l - 1)` of the raw signature, unscaled.
        corr.clear();
        corr.resize(n, 0.0);
        conv.clear();
        conv.resize(n, 0.0);
        let norm = if 4 * block <= shared.fft_len {
            let blocks = shared.blocks[block.trailing_zeros() as usize]
                .get_or_init(|| Blocks::new(&shared.a, block));
            let t = &blocks.transform;
            t.spectrum_into(&qz, 1.0, query, scratch);
            // Offsets past `n - l` are not scored.
            let offsets = n - l + 1;
            for (j, spectrum) in blocks.spectra.iter().enumerate() {
                t.add_block(
                    j,
                    spectrum,
                    query,
                    l,
                    &mut corr[..offsets],
                    conv,
                    buf,
                    scratch,
                );
            }
            1.0 / (2 * t.block()) as f64
        } else {
            buf.clear();
            buf.extend(qz.iter().map(|&x| Complex::new(x, 0.0)));
            buf.resize(shared.fft_len, Complex::new(0.0, 0.0));
            fft.process_with_scratch(buf, scratch);
            for (b, a) in buf.iter_mut().zip(&shared.spectrum) {
                *b = a * b.conj() + i * (a * *b);
            }
            ifft.process_with_scratch(buf, scratch);
            for ((c, v), b) in corr.iter_mut().zip(conv.iter_mut()).zip(buf.iter()) {
                (*c, *v) = (b.re, b.im);
            }
            1.0 / shared.fft_len as f64
        };
        let count = n - l + 1;
        let mut out = ZnccScores {
            forward: Vec::with_capacity(count),
            reversed: Vec::with_capacity(count),
        };
        for d in 0..count {
            let denom = shared.window_norm(d, l) * q_norm;
            if denom <= 0.0 {
                out.forward.push(0.0);
                out.reversed.push(0.0);
                continue;
            }
            let forward = corr[d] * norm;
            let backward = conv[d + l - 1] * norm;
            out.forward.push((forward / denom).clamp(-1.0, 1.0));
            out.reversed.push((-backward / denom).clamp(-1.0, 1.0));
        }
        out
    }
}

impl Prepared {
    /// `sqrt(Σ (a - ā)^2)` over the window `d..d+l`, 0 when flat.
    fn window_norm(&self, d: usize, l: usize) -> f64 {
        let sum = self.prefix[d + l] - self.prefix[d];
        let sq = self.prefix_sq[d + l] - self.prefix_sq[d];
        let var = sq / l as f64 - (sum / l as f64).powi(2);
        if var <= self.flat {
            0.0
        } else {
            (var * l as f64).sqrt()
        }
    }
}

/// `q - q̄` and its norm; `None` when `q` is constant.
fn centred(q: &[f64]) -> Option<(Vec<f64>, f64)> {
    let mean = q.iter().sum::<f64>() / q.len() as f64;
    let qz: Vec<f64> = q.iter().map(|x| x - mean).collect();
    let norm = qz.iter().map(|x| x * x).sum::<f64>().sqrt();
    (norm > 0.0).then_some((qz, norm))
}

/// ZNCC at every offset computed directly, O(n L): the reference the FFT
/// path is tested and benchmarked against.
pub fn zncc_direct(a: &[f64], q: &[f64]) -> ZnccScores {
    let (n, l) = (a.len(), q.len());
    if l < 2 || l > n {
        return ZnccScores::default();
    }
    let Some((qz, q_norm)) = centred(q) else {
        return ZnccScores::default();
    };
    let total_mean = a.iter().sum::<f64>() / n as f64;
    let total_var = a.iter().map(|x| (x - total_mean).powi(2)).sum::<f64>() / n as f64;
    let flat = FLAT_FRACTION * total_var;
    let mut out = ZnccScores::default();
    for d in 0..=n - l {
        let w = &a[d..d + l];
        let mean = w.iter().sum::<f64>() / l as f64;
        let var = w.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / l as f64;
        if var <= flat {
            out.forward.push(0.0);
            out.reversed.push(0.0);
            continue;
        }
        let denom = (var * l as f64).sqrt() * q_norm;
        let fwd: f64 = (0..l).map(|j| qz[j] * w[j]).sum();
        let rev: f64 = (0..l).map(|j| -qz[l - 1 - j] * w[j]).sum();
        out.forward.push((fwd / denom).clamp(-1.0, 1.0));
        out.reversed.push((rev / denom).clamp(-1.0, 1.0));
    }
    out
}

/// ZNCC of two equally long vectors (0 when either is constant).
pub fn zncc_pair(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let (ma, mb) = (
        a[..n].iter().sum::<f64>() / n as f64,
        b[..n].iter().sum::<f64>() / n as f64,
    );
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (x, y) = (a[i] - ma, b[i] - mb);
        ab += x * y;
        aa += x * x;
        bb += y * y;
    }
    if aa <= 0.0 || bb <= 0.0 {
        return 0.0;
    }
    (ab / (aa * bb).sqrt()).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Whole-length and block-wise transforms both give the direct scores,
    /// for queries from a few samples to nearly the signature's length, at
    /// lengths that are and are not multiples of the block.
    #[test]
    fn fft_and_blockwise_scores_equal_the_direct_ones() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for n in [50, 257, 1000, 3001] {
            let a: Vec<f64> = (0..n)
                .map(|i| (i as f64 * 0.05).sin() + rng.random_range(-0.3..0.3))
                .collect();
            let mut correlator = Correlator::new(&a, n);
            for l in [2, 3, 17, 64, 65, 200, n / 2, n - 1] {
                if l > n {
                    continue;
                }
                let start = rng.random_range(0..=n - l);
                let q: Vec<f64> = a[start..start + l]
                    .iter()
                    .map(|x| 2.0 * x + rng.random_range(-0.1..0.1))
                    .collect();
                let (fast, direct) = (correlator.scores(&q), zncc_direct(&a, &q));
                for (f, d) in [
                    (&fast.forward, &direct.forward),
                    (&fast.reversed, &direct.reversed),
                ] {
                    assert_eq!(f.len(), d.len(), "n {n} l {l}");
                    for (x, y) in f.iter().zip(d) {
                        assert!((x - y).abs() < 1e-9, "n {n} l {l}: {x} vs {y}");
                    }
                }
            }
        }
    }
}
