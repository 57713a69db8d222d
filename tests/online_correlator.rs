//! The history correlator (block spectra, cached per-segment pieces) gives
//! the batch ZNCC: the raw piece correlations equal direct sums, and the
//! online search's peaks are peaks of `zncc_direct` with the same value.

use turnprint::io::{read_trajectory, Format};
use turnprint::matching::zncc::zncc_direct;
use turnprint::online::correlator::BlockCorrelator;
use turnprint::online::scan::{self, Query, QueryStats};
use turnprint::pipeline::{Config, PreparedPath};

mod common;

/// The signature and segment boundaries of KITTI ground truth `name`, or
/// `None` after a line saying it is skipped.
fn signature(name: &str) -> Option<(Vec<f32>, Vec<usize>)> {
    let path = common::shared(&format!("kitti_gt/{name}.txt"))?;
    let t = read_trajectory(&path, Format::Kitti).unwrap();
    let p = PreparedPath::new(&t, &Config::default()).unwrap();
    Some((
        p.signature.value.iter().map(|&v| v as f32).collect(),
        p.bounds,
    ))
}

#[test]
fn piece_correlations_equal_direct_sums_across_blocks() {
    let Some((a, bounds)) = signature("00") else {
        return;
    };
    // Small blocks: many block boundaries, a partial tail block, and a
    // piece longer than a block (the direct path).
    for block in [64, 100, 2048] {
        let mut c = BlockCorrelator::new(block);
        c.update(&a);
        for w in bounds.windows(2).step_by(7) {
            let (start, len) = (w[0], w[1] - w[0]);
            let piece = c.piece(&a, start, len);
            let p = &a[start..start + len];
            let scale: f32 =
                p.iter().map(|v| v.abs()).sum::<f32>() * a.iter().fold(0f32, |m, v| m.max(v.abs()));
            for e in (0..a.len()).step_by(13) {
                let f: f32 = (0..len)
                    .filter(|j| e + j < a.len())
                    .map(|j| p[j] * a[e + j])
                    .sum();
                let r: f32 = -(0..len)
                    .filter(|&j| e >= j)
                    .map(|j| p[j] * a[e - j])
                    .sum::<f32>();
                assert!(
                    (piece.forward[e] - f).abs() <= 1e-4 * scale,
                    "block {block} e {e}: {} vs {f}",
                    piece.forward[e]
                );
                assert!(
                    (piece.reversed[e] - r).abs() <= 1e-4 * scale,
                    "block {block} e {e}: {} vs {r}",
                    piece.reversed[e]
                );
            }
        }
    }
}

#[test]
fn zncc_from_pieces_matches_the_batch_correlator() {
    let Some((a, bounds)) = signature("00") else {
        return;
    };
    let a64: Vec<f64> = a.iter().map(|&v| v as f64).collect();
    let mut c = BlockCorrelator::new(256);
    c.update(&a);
    // A query of the 4 segments ending at boundary k, rebuilt from pieces.
    let k = bounds.len() - 5;
    let (q0, q1) = (bounds[k - 4], bounds[k]);
    let pieces: Vec<_> = (k - 3..=k)
        .map(|i| c.piece(&a, bounds[i - 1], bounds[i] - bounds[i - 1]))
        .collect();
    let q = &a64[q0..=q1];
    let direct = zncc_direct(&a64, q);
    let len = q.len();
    let mean = q.iter().sum::<f64>() / len as f64;
    let qn = q.iter().map(|v| (v - mean).powi(2)).sum::<f64>().sqrt();
    let mut checked = 0;
    for d in 0..=a.len() - len {
        // Forward: target of q0 is d; piece i starts at target d + (b - q0).
        let raw: f64 = pieces
            .iter()
            .map(|p| p.forward[d + p.start - q0] as f64)
            .sum::<f64>()
            + a64[q1] * a64[d + len - 1];
        let (s, sq) = c.window(d, len);
        let var = sq / len as f64 - (s / len as f64).powi(2);
        if var <= 1e-3 {
            continue;
        }
        let z = (raw - mean * s) / ((var * len as f64).sqrt() * qn);
        assert!(
            (z - direct.forward[d]).abs() < 1e-3,
            "forward {d}: {z} vs {}",
            direct.forward[d]
        );
        // Reversed: target of q1 is d, of query sample b is d + q1 - b.
        let raw: f64 = pieces
            .iter()
            .map(|p| p.reversed[d + q1 - p.start] as f64)
            .sum::<f64>()
            - a64[q1] * a64[d];
        let z = (raw + mean * s) / ((var * len as f64).sqrt() * qn);
        assert!(
            (z - direct.reversed[d]).abs() < 1e-3,
            "reversed {d}: {z} vs {}",
            direct.reversed[d]
        );
        checked += 1;
    }
    assert!(checked > a.len() / 2);
}

/// The tiled scan (2048 window starts per tile) finds the local maxima of
/// the direct ZNCC, across tile borders, on a history longer than two tiles.
#[test]
fn tiled_scan_finds_the_peaks_of_the_direct_zncc() {
    let mut a = Vec::new();
    let mut bounds = Vec::new();
    for name in ["00", "02", "05", "06", "08"] {
        let Some((s, b)) = signature(name) else {
            return;
        };
        bounds.extend(b.iter().map(|x| x + a.len()));
        a.extend(s);
    }
    assert!(a.len() > 2 * 2048, "{} samples", a.len());
    let a64: Vec<f64> = a.iter().map(|&v| v as f64).collect();
    let mut c = BlockCorrelator::new(512);
    c.update(&a);
    let k = bounds.len() - 1;
    let q1 = bounds[k];
    let pieces: Vec<_> = (0..5)
        .map(|i| c.piece(&a, bounds[k - i - 1], bounds[k - i] - bounds[k - i - 1]))
        .collect();
    let min = 0.5;
    let queries: Vec<Query> = pieces
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let len = q1 - p.start + 1;
            let q = &a64[p.start..=q1];
            let mean = q.iter().sum::<f64>() / len as f64;
            Query {
                len,
                // Windows end before the query starts.
                count: p.start - len + 1,
                stats: (i >= 1).then(|| QueryStats {
                    mean,
                    norm2: q.iter().map(|v| (v - mean).powi(2)).sum(),
                    last: a64[q1],
                }),
            }
        })
        .collect();
    let history = scan::History {
        values: &a,
        prefix: &c.prefix,
        prefix_sq: &c.prefix_sq,
        flat: 0.0,
    };
    let refs: Vec<_> = pieces.iter().collect();
    let found = scan::scan(&refs, &queries, &history, min);
    let mut checked = 0;
    for (query, found) in queries.iter().zip(&found).skip(1) {
        let q = &a64[q1 + 1 - query.len..=q1];
        let direct = zncc_direct(&a64[..query.count + query.len - 1], q);
        for (scores, peaks) in [(&direct.forward, &found[0]), (&direct.reversed, &found[1])] {
            let is_peak = |st: usize, margin: f64| {
                let v = scores[st];
                v >= min
                    && (st == 0 || scores[st - 1] < v - margin)
                    && (st + 1 == scores.len() || scores[st + 1] < v - margin)
            };
            for &(st, v) in peaks {
                assert!((v - scores[st]).abs() < 1e-3, "{st}: {v} vs {}", scores[st]);
                assert!(is_peak(st, -1e-3), "{st} is not a peak of the direct ZNCC");
            }
            for st in (0..scores.len()).filter(|&st| is_peak(st, 1e-3)) {
                assert!(peaks.iter().any(|p| p.0 == st), "direct peak {st} missed");
                checked += 1;
            }
        }
    }
    assert!(checked > 20, "{checked} peaks checked");
}

/// A segment's piece is computed by the first matching that needs it, which
/// may run after later hand-overs finished more blocks of the history: it
/// must equal, bit for bit, the piece computed when its boundary came (the
/// candidates are then the same with any number of matching threads).
#[test]
fn a_piece_computed_after_more_blocks_finished_equals_the_piece_at_its_boundary() {
    let Some((a, bounds)) = signature("00") else {
        return;
    };
    for block in [64, 100, 256] {
        let mut c = BlockCorrelator::new(block);
        // The history when boundary k came, with an open tail block.
        let k = bounds.len() / 2;
        let at_boundary = bounds[k] + block / 2;
        c.update(&a[..at_boundary]);
        let (start, len) = (bounds[k - 1], bounds[k] - bounds[k - 1]);
        let then = c.piece(&a[..at_boundary], start, len);
        // Later hand-overs: the open block finished, and more after it.
        c.update(&a);
        let later = c.piece(&a[..at_boundary], start, len);
        assert_eq!(then.forward.len(), at_boundary);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&then.forward), bits(&later.forward), "block {block}");
        assert_eq!(bits(&then.reversed), bits(&later.reversed), "block {block}");
    }
}
