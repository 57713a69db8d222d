//! The worker's compact history of finalised samples, the prefix of it a
//! matching reads ([`HistoryView`]), and local [`PreparedPath`] windows cut
//! from it for the batch verification.
//!
//! Storage per track grid sample: position `2 x f32`, arc length `f64`,
//! curvature `f32`, pose index `u32` (24 bytes; about two samples per moving
//! pose). Per signature sample: value `f32`, grid index `f64` (12 bytes).
//! Positions are relative to the warm-up plane's centroid, so `f32` keeps
//! well below a millimetre on paths of tens of kilometres.
//!
//! One history serves every matching thread: a matching reads the history
//! as it stood when the matching fell due ([`Upto`]), so the samples taken
//! in since (the worker takes a batch of hand-overs in before it runs their
//! matchings) are invisible to it, and it finds what it would have found
//! alone.

use std::sync::Arc;

use nalgebra::Vector2;

use crate::geometry::polyline::PathIndex;
use crate::geometry::{Plane, Polyline2};
use crate::pipeline::PreparedPath;
use crate::signature::Signature;
use crate::track::Track;

/// Finalised samples of the whole path so far.
#[derive(Default)]
pub struct History {
    /// Track positions.
    pub xy: Vec<[f32; 2]>,
    /// Track arc length.
    pub s: Vec<f64>,
    /// Track curvature.
    pub curvature: Vec<f32>,
    /// Nearest pose index of each track sample.
    pub pose: Vec<u32>,
    /// Signature values.
    pub sig_value: Vec<f32>,
    /// Fractional track index of each signature sample.
    pub sig_grid: Vec<f64>,
    /// Segment boundaries (signature indices).
    pub bounds: Vec<usize>,
    /// Keyframe ids by pose index, increasing.
    pub keyframes: Vec<(u32, u64)>,
    /// BVH of the track, shared by the windows' polylines (no window
    /// builds its own tree).
    pub index: Arc<PathIndex>,
}

/// How much of the history a matching sees: the lengths of its parts when
/// the matching fell due.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Upto {
    /// Track samples.
    pub grid: usize,
    /// Signature samples.
    pub sig: usize,
    /// Segment boundaries.
    pub bounds: usize,
    /// Keyframes.
    pub keyframes: usize,
}

/// A prefix of the [`History`]: what one matching reads.
#[derive(Clone, Copy)]
pub struct HistoryView<'a> {
    /// Track positions.
    pub xy: &'a [[f32; 2]],
    /// Track arc length.
    pub s: &'a [f64],
    /// Track curvature.
    pub curvature: &'a [f32],
    /// Nearest pose index of each track sample.
    pub pose: &'a [u32],
    /// Signature values.
    pub sig_value: &'a [f32],
    /// Fractional track index of each signature sample.
    pub sig_grid: &'a [f64],
    /// Segment boundaries (signature indices).
    pub bounds: &'a [usize],
    /// Keyframe ids by pose index, increasing.
    pub keyframes: &'a [(u32, u64)],
    /// BVH of the whole history's track: a window's queries stay inside
    /// the window, so leaves past the prefix are never reached.
    pub index: &'a Arc<PathIndex>,
}

/// A window of the history as a prepared path, with its offsets.
pub struct Window {
    /// The prepared path (local indices).
    pub path: PreparedPath,
    /// First track sample of the window.
    pub grid0: usize,
    /// First signature sample of the window.
    pub sig0: usize,
}

impl History {
    /// The lengths of every part now.
    pub fn upto(&self) -> Upto {
        Upto {
            grid: self.xy.len(),
            sig: self.sig_value.len(),
            bounds: self.bounds.len(),
            keyframes: self.keyframes.len(),
        }
    }

    /// The history as it stood at `upto`.
    pub fn view(&self, upto: Upto) -> HistoryView<'_> {
        HistoryView {
            xy: &self.xy[..upto.grid],
            s: &self.s[..upto.grid],
            curvature: &self.curvature[..upto.grid],
            pose: &self.pose[..upto.grid],
            sig_value: &self.sig_value[..upto.sig],
            sig_grid: &self.sig_grid[..upto.sig],
            bounds: &self.bounds[..upto.bounds],
            keyframes: &self.keyframes[..upto.keyframes],
            index: &self.index,
        }
    }

    /// The whole history.
    pub fn now(&self) -> HistoryView<'_> {
        self.view(self.upto())
    }

    /// Indexes the track samples appended since the last call.
    pub fn index_new_samples(&mut self) {
        let xy = &self.xy;
        // The windows holding the index are gone by now: no copy is made.
        Arc::make_mut(&mut self.index)
            .extend(xy.len(), |i| Vector2::new(xy[i][0] as f64, xy[i][1] as f64));
    }

    /// Bytes held per stored item (for the memory figures).
    pub fn bytes(&self) -> usize {
        self.xy.capacity() * 8
            + self.s.capacity() * 8
            + self.curvature.capacity() * 4
            + self.pose.capacity() * 4
            + self.sig_value.capacity() * 4
            + self.sig_grid.capacity() * 8
            + self.bounds.capacity() * 8
            + self.keyframes.capacity() * 16
            + self.index.bytes()
    }
}

impl HistoryView<'_> {
    /// Track position of sample `i`.
    pub fn point(&self, i: usize) -> Vector2<f64> {
        let p = self.xy[i];
        Vector2::new(p[0] as f64, p[1] as f64)
    }

    /// Track position at a fractional sample index (linear in between).
    pub fn point_at(&self, g: f64) -> Vector2<f64> {
        let last = self.xy.len().saturating_sub(1);
        // Truncation saturates below 0 (and NaN) to 0: the clamped floor
        // without a libm call.
        let i = (g as usize).min(last.saturating_sub(1));
        let f = (g - i as f64).clamp(0.0, 1.0);
        self.point(i) * (1.0 - f) + self.point((i + 1).min(last)) * f
    }

    /// Arc length at signature sample `j`.
    pub fn sig_s(&self, j: usize) -> f64 {
        Track::interp(self.s, self.sig_grid[j])
    }

    /// The keyframes of poses in `[p0, p1]`.
    fn keyframes_within(&self, range: [usize; 2]) -> &[(u32, u64)] {
        let lo = self
            .keyframes
            .partition_point(|k| (k.0 as usize) < range[0]);
        let hi = self
            .keyframes
            .partition_point(|k| (k.0 as usize) <= range[1]);
        &self.keyframes[lo..hi.max(lo)]
    }

    /// Keyframe ids of poses in `[p0, p1]`, at most `max` spread evenly.
    pub fn keyframes_in(&self, range: [usize; 2], max: usize) -> Vec<u64> {
        let within = self.keyframes_within(range);
        let n = within.len();
        if n <= max {
            return within.iter().map(|k| k.1).collect();
        }
        (0..max)
            .map(|i| within[i * (n - 1) / (max - 1).max(1)].1)
            .collect()
    }

    /// The keyframe nearest to `pose` within `range`: (id, pose index).
    pub fn keyframe_near(&self, pose: usize, range: [usize; 2]) -> Option<(u64, usize)> {
        self.keyframes_within(range)
            .iter()
            .min_by_key(|k| (k.0 as usize).abs_diff(pose))
            .map(|k| (k.1, k.0 as usize))
    }

    /// Track samples `[g0, g1]` (clamped) as a prepared path.
    #[allow(clippy::too_many_arguments)]
    pub fn window(
        &self,
        g0: usize,
        g1: usize,
        plane: &Plane,
        step: f64,
        bandwidth: f64,
        dk: f64,
        poses: usize,
    ) -> Option<Window> {
        let g1 = g1.min(self.xy.len().checked_sub(1)?);
        if g1 < g0 + 3 {
            return None;
        }
        // Over the slice rather than by index: the copy vectorises, without
        // a bounds check per sample (windows span tens of thousands).
        let xy: Vec<Vector2<f64>> = self.xy[g0..=g1]
            .iter()
            .map(|p| Vector2::new(p[0] as f64, p[1] as f64))
            .collect();
        let track = Track {
            s: self.s[g0..=g1].to_vec(),
            // Verification never reads the heading: leaving it out saves an
            // atan2 per sample, a tenth of the detector's time.
            heading: Vec::new(),
            curvature: self.curvature[g0..=g1].iter().map(|&c| c as f64).collect(),
            pose: self.pose[g0..=g1].iter().map(|&p| p as f64).collect(),
            step,
            pose_u: Vec::new(),
            bandwidth,
            xy,
        };
        let sig0 = self.sig_grid.partition_point(|&g| g < g0 as f64);
        let sig1 = self.sig_grid.partition_point(|&g| g <= g1 as f64);
        let n = sig1.saturating_sub(sig0);
        let mut signature = Signature {
            dk,
            value: Vec::with_capacity(n),
            s: Vec::with_capacity(n),
            grid: Vec::with_capacity(n),
        };
        for j in sig0..sig1 {
            let grid = self.sig_grid[j] - g0 as f64;
            signature.value.push(self.sig_value[j] as f64);
            signature.s.push(Track::interp(&track.s, grid));
            signature.grid.push(grid);
        }
        // Boundaries increase: the window's are one run, found by bisection
        // (a scan of every boundary grew with the history).
        let b0 = self.bounds.partition_point(|&b| b < sig0);
        let b1 = self.bounds.partition_point(|&b| b < sig1).max(b0);
        let bounds = self.bounds[b0..b1].iter().map(|&b| b - sig0).collect();
        let polyline = Polyline2::window(&track.xy, self.index.clone(), g0);
        Some(Window {
            path: PreparedPath {
                plane: *plane,
                track,
                signature,
                bounds,
                polyline,
                poses,
                // The online history keeps no input positions: its
                // windows are planar.
                positions: Vec::new(),
            },
            grid0: g0,
            sig0,
        })
    }
}

/// Uniform hash grid over decimated track samples: nearest earlier
/// positions without scanning the history. The cell is a multiple of the
/// typical step (scale-free).
#[derive(Debug, Default)]
pub struct SpatialIndex {
    cell: f64,
    every: usize,
    cells: std::collections::HashMap<(i32, i32), Vec<u32>, CellHash>,
    indexed: usize,
}

/// Hashing of cell keys: the probes look up hundreds of cells per call, and
/// the default SipHash (built against flooding, not needed for grid cells
/// of one's own path) took most of that time.
#[derive(Debug, Clone, Copy, Default)]
pub struct CellHash;

impl std::hash::BuildHasher for CellHash {
    type Hasher = CellHasher;
    fn build_hasher(&self) -> CellHasher {
        CellHasher(0)
    }
}

/// Multiply-rotate hashing of the two cell coordinates.
#[derive(Debug, Clone, Copy)]
pub struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(u64::from(*b));
        }
    }
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(29) ^ i).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

impl SpatialIndex {
    /// Cells of `cell` units, one sample in `every` indexed.
    pub fn new(cell: f64, every: usize) -> Self {
        SpatialIndex {
            cell,
            every: every.max(1),
            cells: Default::default(),
            indexed: 0,
        }
    }

    /// Side of a cell.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    fn key(&self, p: &Vector2<f64>) -> (i32, i32) {
        (
            (p.x / self.cell).floor() as i32,
            (p.y / self.cell).floor() as i32,
        )
    }

    /// Indexes the history's new samples.
    pub fn update(&mut self, h: &HistoryView) {
        while self.indexed < h.xy.len() {
            let i = self.indexed;
            if i.is_multiple_of(self.every) {
                let k = self.key(&h.point(i));
                self.cells.entry(k).or_default().push(i as u32);
            }
            self.indexed += 1;
        }
    }

    /// For each of `points`, the indexed sample minimising
    /// `distance / radius(k, t)` among those within `max_radius` of it that
    /// pass `allowed(k, t)`, with that ratio: the drifting map's probe, whose
    /// radius grows with the path between the two parts. One scan of the
    /// cells around all the points (at most `max_cells` cells beyond their
    /// box) serves every point.
    pub fn nearest_scaled<const N: usize>(
        &self,
        h: &HistoryView,
        points: &[Vector2<f64>; N],
        max_radius: f64,
        max_cells: i32,
        radius: impl Fn(usize, usize) -> f64,
        allowed: impl Fn(usize, usize) -> bool,
    ) -> [Option<(f64, usize)>; N] {
        let mut best = [None; N];
        if N == 0 {
            return best;
        }
        let r = ((max_radius / self.cell).ceil() as i32).clamp(0, max_cells);
        let keys = points.map(|p| self.key(&p));
        let (x0, x1) = (
            keys.iter().map(|k| k.0).min(),
            keys.iter().map(|k| k.0).max(),
        );
        let (y0, y1) = (
            keys.iter().map(|k| k.1).min(),
            keys.iter().map(|k| k.1).max(),
        );
        let (Some(x0), Some(x1), Some(y0), Some(y1)) = (x0, x1, y0, y1) else {
            return best;
        };
        // Keys saturate for points outside the cells' range, which then has
        // nothing near them (the guard keeps such positions out).
        let (Some(x0), Some(x1), Some(y0), Some(y1)) = (
            x0.checked_sub(r),
            x1.checked_add(r),
            y0.checked_sub(r),
            y1.checked_add(r),
        ) else {
            return best;
        };
        let max2 = max_radius * max_radius;
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                let Some(list) = self.cells.get(&(cx, cy)) else {
                    continue;
                };
                // A cell's samples increase: those past the matching's
                // prefix end it.
                for &i in list.iter().take_while(|&&i| (i as usize) < h.xy.len()) {
                    let i = i as usize;
                    let q = h.point(i);
                    for (k, p) in points.iter().enumerate() {
                        let d2 = (q - p).norm_squared();
                        if d2 > max2 || !allowed(k, i) {
                            continue;
                        }
                        let ratio = d2.sqrt() / radius(k, i);
                        if best[k].is_none_or(|b: (f64, usize)| ratio < b.0) {
                            best[k] = Some((ratio, i));
                        }
                    }
                }
            }
        }
        best
    }

    /// Calls `f` with every indexed sample of `h` in the cells within
    /// `radius` of `center` (a superset of the samples within `radius`).
    pub fn samples_near(
        &self,
        h: &HistoryView,
        center: &Vector2<f64>,
        radius: f64,
        mut f: impl FnMut(usize),
    ) {
        let (lo, hi) = (
            self.key(&(center - Vector2::new(radius, radius))),
            self.key(&(center + Vector2::new(radius, radius))),
        );
        for cx in lo.0..=hi.0 {
            for cy in lo.1..=hi.1 {
                let cell = self.cells.get(&(cx, cy)).into_iter().flatten();
                for &i in cell.take_while(|&&i| (i as usize) < h.xy.len()) {
                    f(i as usize);
                }
            }
        }
    }

    /// One sample in this many is indexed.
    pub fn every(&self) -> usize {
        self.every
    }

    /// Bytes held (approximate: entries plus per-cell overhead).
    pub fn bytes(&self) -> usize {
        self.cells.values().map(|v| v.capacity() * 4 + 48).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A matching reads the history as it stood when it fell due: the
    /// spatial grid, which indexes every sample taken in since, must not
    /// hand it a later one (its slices end there: indexing one panicked).
    #[test]
    fn a_view_sees_no_sample_taken_in_after_it() {
        let mut h = History::default();
        // Two passes over the same line: the later one lies on the
        // earlier.
        for i in 0..400 {
            let x = (i % 200) as f32;
            h.xy.push([x, 0.0]);
            h.s.push(i as f64);
            h.curvature.push(0.0);
            h.pose.push(i);
        }
        let mut grid = SpatialIndex::new(8.0, 1);
        grid.update(&h.now());
        let upto = Upto {
            grid: 200,
            ..h.upto()
        };
        let view = h.view(upto);
        let mut seen = Vec::new();
        grid.samples_near(&view, &Vector2::new(50.0, 0.0), 10.0, |i| seen.push(i));
        assert!(!seen.is_empty());
        assert!(seen.iter().all(|&i| i < 200), "{seen:?}");
        let [nearest] = grid.nearest_scaled(
            &view,
            &[Vector2::new(150.0, 0.0)],
            10.0,
            4,
            |_, _| 1.0,
            |_, _| true,
        );
        assert_eq!(nearest.map(|n| n.1), Some(150));
        // The whole history sees the second pass.
        let mut all = Vec::new();
        grid.samples_near(&h.now(), &Vector2::new(50.0, 0.0), 10.0, |i| all.push(i));
        assert!(all.iter().any(|&i| i >= 200));
    }
}
