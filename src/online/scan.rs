//! The ZNCC scan of the newest queries over the whole history, tiled.
//!
//! Query `i` is the concatenation of the newest `i + 1` pieces; its raw
//! correlation at a window is the sum of those pieces' cached arrays
//! ([`super::correlator`]), its window means and deviations come from prefix
//! sums. Done query by query over the whole history, the sums, scores and
//! peak search stream tens of megabytes per segment through memory; done
//! tile by tile (all queries over one stretch of window starts, then the
//! next stretch) everything but the cached arrays stays in cache, which
//! took one segment against 100 000 poses from 3.2 to under 2 ms.

use super::correlator::Piece;
use crate::matching::peaks::local_maxima;

/// Window starts per tile (the tile's sums and scores fit in L1/L2).
const TILE: usize = 2048;

/// One query of the scan.
#[derive(Debug, Clone)]
pub struct Query {
    /// Samples of the query (its pieces and the newest boundary sample).
    pub len: usize,
    /// Window starts `st in [0, count)` allowed (shrinks as `len` grows).
    pub count: usize,
    /// Statistics of the query's own samples; `None` when it only adds its
    /// piece for the longer queries.
    pub stats: Option<QueryStats>,
}

/// Mean, centred norm and newest sample of a query.
#[derive(Debug, Clone, Copy)]
pub struct QueryStats {
    /// Mean of the query's samples.
    pub mean: f64,
    /// `Σ (q - mean)²`, positive.
    pub norm2: f64,
    /// The query's newest sample (its boundary sample, not in any piece).
    pub last: f64,
}

/// The history's prefix sums and the flatness floor.
pub struct History<'a> {
    /// Signature values.
    pub values: &'a [f32],
    /// Prefix sums of the values.
    pub prefix: &'a [f64],
    /// Prefix sums of their squares.
    pub prefix_sq: &'a [f64],
    /// Windows whose variance is at most this are flat.
    pub flat: f64,
}

/// Local maxima `(st, zncc)` at or above `min` of each query's forward
/// (`[0]`, window `[st, st + len)` with the newest sample at its end) and
/// reversed (`[1]`, the newest sample at `st`) ZNCC, in window order.
/// `pieces[i]` is the `i`-th newest piece (query `i`'s first piece).
pub fn scan(
    pieces: &[&Piece],
    queries: &[Query],
    h: &History,
    min: f64,
) -> Vec<[Vec<(usize, f64)>; 2]> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, detected just above.
        return unsafe { scan_avx2(pieces, queries, h, min) };
    }
    scan_any(pieces, queries, h, min)
}

/// [`scan`] compiled for AVX2: the score pass needs vector selects and
/// square roots (SSE2, the x86-64 baseline, runs it scalar at twice the
/// time). Same operations in the same order, so the same results.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn scan_avx2(
    pieces: &[&Piece],
    queries: &[Query],
    h: &History,
    min: f64,
) -> Vec<[Vec<(usize, f64)>; 2]> {
    scan_any(pieces, queries, h, min)
}

#[inline(always)]
fn scan_any(
    pieces: &[&Piece],
    queries: &[Query],
    h: &History,
    min: f64,
) -> Vec<[Vec<(usize, f64)>; 2]> {
    let mut found = vec![[Vec::new(), Vec::new()]; queries.len()];
    let (Some(first), Some(longest)) = (queries.first(), queries.last()) else {
        return found;
    };
    let (count_max, len_max) = (first.count, longest.len);
    // Flat windows score 0 when every window counts, else below any
    // threshold.
    let flat_value = if min <= 0.0 { 0.0 } else { -2.0 };
    let mut fwd = vec![0f64; TILE + len_max + 2];
    let mut rev = vec![0f64; TILE + 2];
    let (mut sf, mut sr) = (vec![0f64; TILE + 2], vec![0f64; TILE + 2]);
    let mut s0 = 0;
    while s0 < count_max {
        let s1 = (s0 + TILE).min(count_max);
        // One start before the tile and one after, for the peak test.
        let xb = s0.saturating_sub(1);
        fwd.fill(0.0);
        rev.fill(0.0);
        for (q, (query, piece)) in queries.iter().zip(pieces).enumerate() {
            let (len, count) = (query.len, query.count);
            let lm1 = len - 1;
            // Forward sums live at x = st + len - 1 (the newest sample's
            // target); the piece's own first sample is len - 1 earlier.
            let x_lo = xb.max(lm1);
            let x_hi = (lm1 + count.min(piece.forward.len())).min(s1 + len_max);
            if x_lo < x_hi {
                let src = &piece.forward[x_lo - lm1..x_hi - lm1];
                for (acc, &g) in fwd[x_lo - xb..x_hi - xb].iter_mut().zip(src) {
                    *acc += g as f64;
                }
            }
            // Reversed sums live at x = st.
            let r_from = lm1.min(piece.reversed.len());
            let st_hi = count.min(piece.reversed.len() - r_from).min(s1 + 1);
            if xb < st_hi {
                let src = &piece.reversed[xb + r_from..st_hi + r_from];
                for (acc, &g) in rev[..st_hi - xb].iter_mut().zip(src) {
                    *acc += g as f64;
                }
            }
            let Some(stats) = query.stats else {
                continue;
            };
            let e = (s1 + 1).min(count);
            if xb >= e {
                continue;
            }
            let m = e - xb;
            scores(
                h,
                &stats,
                len,
                xb,
                m,
                (&fwd[lm1..lm1 + m], &rev[..m]),
                (&mut sf[..m], &mut sr[..m]),
                flat_value,
            );
            // `sc[k]` is window `xb + k`; window `count - 1`, when in the
            // tile, is the last of `sc[..m]`.
            for (dir, sc) in [&sf, &sr].into_iter().enumerate() {
                let out = &mut found[q][dir];
                let tested = s0 - xb..s1.min(count) - xb;
                local_maxima(&sc[..m], 1.0, tested, min, |k, v| out.push((xb + k, v)));
            }
        }
        s0 = s1;
    }
    found
}

/// ZNCC of windows `st in [xb, xb + m)`, both directions, from the
/// accumulated raw correlations: one fused, branch-free pass.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn scores(
    h: &History,
    stats: &QueryStats,
    len: usize,
    xb: usize,
    m: usize,
    (fa, ra): (&[f64], &[f64]),
    (fs, rs): (&mut [f64], &mut [f64]),
    flat_value: f64,
) {
    let (p1, p2, a) = (h.prefix, h.prefix_sq, h.values);
    let inv_l = 1.0 / len as f64;
    let len_norm2 = len as f64 * stats.norm2;
    let (mean, last) = (stats.mean, stats.last);
    // Equal lengths, stated, so the loop runs without bounds checks.
    let (ph, pl) = (&p1[xb + len..xb + len + m], &p1[xb..xb + m]);
    let (qh, ql) = (&p2[xb + len..xb + len + m], &p2[xb..xb + m]);
    let (fr, rr) = (&a[xb + len - 1..xb + len - 1 + m], &a[xb..xb + m]);
    let (fa, ra, fs, rs) = (&fa[..m], &ra[..m], &mut fs[..m], &mut rs[..m]);
    for st in 0..m {
        let sum = ph[st] - pl[st];
        let var = (qh[st] - ql[st]) * inv_l - (sum * inv_l) * (sum * inv_l);
        let inv = 1.0 / (var * len_norm2).sqrt();
        let fnum = fa[st] + last * fr[st] as f64 - mean * sum;
        let rnum = ra[st] - last * rr[st] as f64 + mean * sum;
        let live = var > h.flat;
        fs[st] = if live {
            (fnum * inv).clamp(-1.0, 1.0)
        } else {
            flat_value
        };
        rs[st] = if live {
            (rnum * inv).clamp(-1.0, 1.0)
        } else {
            flat_value
        };
    }
}

/// The best `count` of `found` at least `spacing` apart (the batch peak
/// selection).
pub fn best_spaced(
    mut found: Vec<(usize, f64)>,
    count: usize,
    spacing: usize,
) -> Vec<(usize, f64)> {
    found.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut kept: Vec<(usize, f64)> = Vec::with_capacity(count);
    for (x, v) in found {
        if kept.iter().all(|&(k, _)| k.abs_diff(x) >= spacing) {
            kept.push((x, v));
            if kept.len() == count {
                break;
            }
        }
    }
    kept
}
