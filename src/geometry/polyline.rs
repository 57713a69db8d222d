//! A 2D polyline for nearest-point queries: how far a mapped point of one
//! path is from the other path, and where along it (as a fractional vertex
//! index; the arc length there is the track's, so there is one arc length).
//!
//! The index is a parry2d BVH over runs of `CHUNK` consecutive segments
//! rather than over single segments: a path is spatially coherent, so a run's
//! box is tight, and 8x fewer leaves make the tree cheap to build. A whole
//! path builds its tree on the first query (a path that is never a target
//! costs nothing); a growing path (the online history) keeps one
//! [`PathIndex`], extended as it grows, that every window cut from it shares,
//! so verification builds no tree at all (per-window trees were half of the
//! online detector's time).

use std::ops::Range;
use std::sync::{Arc, OnceLock};

use glam::DVec2;
use nalgebra::Vector2;
use parry2d_f64::bounding_volume::Aabb;
use parry2d_f64::partitioning::{Bvh, BvhBuildStrategy, BvhNode};

/// Consecutive segments per BVH leaf.
const CHUNK: usize = 8;
/// Consecutive segments per leaf of a [`PathIndex`]: longer runs than a
/// whole path's keep the online history's tree within its memory budget
/// (parry spends 100-250 bytes per leaf: runs of 16 cost about 25 bytes
/// per pose, of 8 about 50; runs of 32 made projections 10 % slower).
const PATH_CHUNK: usize = 16;
/// Up to this many leaves a flat scan of their boxes beats building and
/// walking a tree.
const FLAT_LEAVES: usize = 128;

/// A polyline and its BVH.
pub struct Polyline2 {
    vertices: Vec<Vector2<f64>>,
    index: Index,
}

/// Where a polyline's BVH comes from.
enum Index {
    /// Its own, built on the first query.
    Own {
        bvh: OnceLock<Bvh>,
        leaves: OnceLock<Vec<Aabb>>,
    },
    /// A window of a larger path: that path's index, and the global number
    /// of the window's first vertex.
    Shared { index: Arc<PathIndex>, first: usize },
}

/// Nearest point of a [`Polyline2`] to a query point.
#[derive(Debug, Clone, Copy)]
pub struct Projection {
    /// Distance from the query point.
    pub distance: f64,
    /// Fractional vertex index of the nearest point.
    pub vertex: f64,
}

/// The BVH of a growing path: one leaf per complete run of `PATH_CHUNK`
/// segments, inserted as the path grows.
#[derive(Clone, Default)]
pub struct PathIndex {
    bvh: Bvh,
    /// Leaves inserted (runs indexed).
    leaves: usize,
}

impl PathIndex {
    /// Indexes the complete runs among the first `n` vertices (`vertex(i)`
    /// gives vertex `i`) that are not indexed yet.
    pub fn extend(&mut self, n: usize, vertex: impl Fn(usize) -> Vector2<f64>) {
        while (self.leaves + 1) * PATH_CHUNK < n {
            let leaf = self.leaves;
            let aabb = run_box((leaf * PATH_CHUNK..=(leaf + 1) * PATH_CHUNK).map(&vertex));
            self.bvh.insert(aabb, leaf as u32);
            self.leaves += 1;
        }
    }

    /// Segments covered by leaves (the later ones are scanned directly).
    fn indexed_segments(&self) -> usize {
        self.leaves * PATH_CHUNK
    }

    /// Bytes held by the tree.
    pub fn bytes(&self) -> usize {
        self.bvh.total_memory_size()
    }
}

/// The box of a run of vertices.
fn run_box(mut vertices: impl Iterator<Item = Vector2<f64>>) -> Aabb {
    let first = vertices.next().unwrap_or_else(Vector2::zeros);
    let (lo, hi) = vertices.fold((first, first), |(lo, hi), v| (lo.inf(&v), hi.sup(&v)));
    Aabb::new(DVec2::new(lo.x, lo.y), DVec2::new(hi.x, hi.y))
}

/// Squared distance from `q` to a box (0 inside).
fn box_dist2(b: &Aabb, q: DVec2) -> f64 {
    (b.mins - q)
        .max(q - b.maxs)
        .max(DVec2::ZERO)
        .length_squared()
}

impl Polyline2 {
    /// A polyline through `points` (all finite), with its own index.
    pub fn new(points: &[Vector2<f64>]) -> Self {
        Self::with_index(
            points,
            Index::Own {
                bvh: OnceLock::new(),
                leaves: OnceLock::new(),
            },
        )
    }

    /// Vertices `first..first + points.len()` of the path that `index`
    /// indexes (`points` are those vertices).
    pub fn window(points: &[Vector2<f64>], index: Arc<PathIndex>, first: usize) -> Self {
        Self::with_index(points, Index::Shared { index, first })
    }

    fn with_index(points: &[Vector2<f64>], index: Index) -> Self {
        Polyline2 {
            vertices: points.to_vec(),
            index,
        }
    }

    /// Segments `[CHUNK·leaf, CHUNK·(leaf+1))` of a polyline with its own
    /// index (segment `i` joins vertices `i` and `i + 1`).
    fn own_leaf(&self, leaf: usize) -> Range<usize> {
        let n = self.vertices.len().saturating_sub(1);
        (leaf * CHUNK).min(n)..((leaf + 1) * CHUNK).min(n)
    }

    /// Nearest point to `p` (the whole polyline searched).
    pub fn project(&self, p: &Vector2<f64>) -> Option<Projection> {
        self.project_within(p, f64::INFINITY, |_| true)
    }

    /// Nearest point to `p` within `max_dist` among the segments whose
    /// nearest point passes `allowed(fractional vertex index)`: a path
    /// matched against itself must not find itself.
    pub fn project_within(
        &self,
        p: &Vector2<f64>,
        max_dist: f64,
        allowed: impl Fn(f64) -> bool,
    ) -> Option<Projection> {
        if self.vertices.len() < 2 {
            return None;
        }
        let q = DVec2::new(p.x, p.y);
        let max2 = max_dist * max_dist;
        // A leaf's best point when nearer than `best_cost` (squared); the
        // cost passed in as a sentinel point prunes the scan of the run.
        let in_run = |run: Range<usize>, best_cost: f64| {
            let sentinel = (best_cost < max2).then_some((best_cost, usize::MAX, 0.0));
            self.nearest_in(p, max_dist, run, &allowed, sentinel)
                .filter(|b| b.1 != usize::MAX)
                .map(|(d2, i, t)| (d2, (i, t)))
        };
        let box_cost = |node: &BvhNode, _: f64| box_dist2(&node.aabb(), q);
        let best = match &self.index {
            Index::Own { bvh, leaves } => {
                let leaves = self.own_leaves(leaves);
                if leaves.len() <= FLAT_LEAVES {
                    return self.project_flat(p, max_dist, leaves, &allowed);
                }
                // Best-first down the tree, nearest child first, pruning
                // every box farther than the best point so far: a wide
                // tolerance (the first grow round of a long overlap) meets
                // hundreds of runs, of which a few are ever searched.
                bvh.get_or_init(|| Bvh::from_leaves(BvhBuildStrategy::Binned, leaves))
                    .find_best(max2, box_cost, |leaf, cost| {
                        in_run(self.own_leaf(leaf as usize), cost)
                    })
                    .map(|(_, b)| b)
            }
            Index::Shared { index, first } => {
                // Global segments [first, last) are the window's; the
                // newest ones are in no complete run yet.
                let (first, last) = (*first, first + self.vertices.len() - 1);
                let local = |g: Range<usize>| {
                    g.start.max(first) - first..g.end.min(last).saturating_sub(first)
                };
                let tail = in_run(local(index.indexed_segments().max(first)..last), max2);
                let cost = tail.map_or(max2, |t| t.0);
                let tree = index
                    .bvh
                    .find_best(cost, box_cost, |leaf, cost| {
                        let run =
                            local(leaf as usize * PATH_CHUNK..(leaf as usize + 1) * PATH_CHUNK);
                        (!run.is_empty()).then(|| in_run(run, cost)).flatten()
                    })
                    .map(|(_, b)| b);
                tree.or(tail)
            }
        };
        best.map(|(d2, (i, t))| projection((d2, i, t)))
    }

    /// The boxes of a whole path's own runs, computed on the first query.
    fn own_leaves<'a>(&self, leaves: &'a OnceLock<Vec<Aabb>>) -> &'a Vec<Aabb> {
        leaves.get_or_init(|| {
            let n = self.vertices.len().saturating_sub(1);
            (0..n.div_ceil(CHUNK))
                .map(|leaf| {
                    let s = self.own_leaf(leaf);
                    run_box(self.vertices[s.start..=s.end].iter().copied())
                })
                .collect()
        })
    }

    /// [`Polyline2::project_within`] by a scan of a few leaf boxes: the
    /// nearest box first, for a first best point, then every box nearer
    /// than the best point so far (no buffer, no sort: this runs for every
    /// projected point).
    fn project_flat(
        &self,
        p: &Vector2<f64>,
        max_dist: f64,
        leaves: &[Aabb],
        allowed: &impl Fn(f64) -> bool,
    ) -> Option<Projection> {
        let q = DVec2::new(p.x, p.y);
        let max2 = max_dist * max_dist;
        let box2 = |leaf: usize| box_dist2(&leaves[leaf], q);
        let first = (0..leaves.len()).min_by(|&i, &j| box2(i).total_cmp(&box2(j)))?;
        let mut best = None;
        for leaf in std::iter::once(first).chain((0..leaves.len()).filter(|&l| l != first)) {
            let d2 = box2(leaf);
            if d2 > max2 || best.is_some_and(|b: (f64, usize, f64)| b.0 < d2) {
                continue;
            }
            best = self.nearest_in(p, max_dist, self.own_leaf(leaf), allowed, best);
        }
        best.map(projection)
    }

    /// [`Polyline2::project_within`] among segments `segments` only (segment
    /// `i` joins vertices `i` and `i + 1`), for a caller that knows where
    /// along the polyline the point must land: near path length `around`,
    /// where `arc[i]` is the path length at vertex `i`.
    ///
    /// A sum of chords is never shorter than the chord it spans, so a vertex
    /// `d` away from `p` has no point within `r` of `p` on the `d - r` of
    /// path on either side of it. The scan starts at `around` and runs both
    /// ways, jumping over such stretches once a near point bounds `r`: a
    /// growing overlap projects each point onto a window of hundreds of
    /// segments of which a few are ever near.
    pub fn project_along(
        &self,
        p: &Vector2<f64>,
        max_dist: f64,
        segments: Range<usize>,
        arc: &[f64],
        around: f64,
        allowed: impl Fn(f64) -> bool,
    ) -> Option<Projection> {
        let end = segments.end.min(self.vertices.len().saturating_sub(1));
        let start = segments.start;
        if start >= end || arc.len() != self.vertices.len() {
            return self
                .nearest_in(p, max_dist, start..end, &allowed, None)
                .map(projection);
        }
        let v = &self.vertices;
        let mut best: Option<(f64, usize, f64)> = None;
        // How much of the path beyond vertex `i` may be skipped: its
        // distance less the reach that still matters, less the vertices'
        // own rounding (the online history keeps them in f32: a relative
        // 1e-6 covers two f32 roundings of vertex and chord).
        let gap = |i: usize, best: &Option<(f64, usize, f64)>| {
            let d = (p - v[i]).norm();
            let reach = best.map_or(max_dist, |b| b.0.sqrt().min(max_dist));
            d - reach - 1e-6 * (v[i].norm() + d)
        };
        let centre = (start + arc[start..=end].partition_point(|&x| x <= around))
            .saturating_sub(1)
            .clamp(start, end - 1);
        let mut i = centre;
        while i < end {
            let g = gap(i, &best);
            if g > 0.0 {
                // The first vertex at least `g` of path beyond `i`: the
                // segment ending there is the first that may come near.
                let k = first_not_below(arc, i + 1..end + 1, arc[i] + g);
                if k - 1 > i {
                    i = k - 1;
                    continue;
                }
            }
            best = self.nearest_in(p, max_dist, i..i + 1, &allowed, best);
            i += 1;
        }
        // Backwards from the centre, each segment seen from its end vertex.
        let mut i = centre;
        while i > start {
            let g = gap(i, &best);
            if g > 0.0 {
                // The last vertex at least `g` of path before `i`.
                let Some(j) = last_not_above(arc, start..i, arc[i] - g) else {
                    break;
                };
                if j + 1 < i {
                    i = j + 1;
                    continue;
                }
            }
            best = self.nearest_in(p, max_dist, i - 1..i, &allowed, best);
            i -= 1;
        }
        best.map(projection)
    }

    /// The nearest allowed point of `segments` within `max_dist` of `p`, as
    /// (squared distance, segment, fraction), if nearer than `best`.
    fn nearest_in(
        &self,
        p: &Vector2<f64>,
        max_dist: f64,
        segments: Range<usize>,
        allowed: &impl Fn(f64) -> bool,
        mut best: Option<(f64, usize, f64)>,
    ) -> Option<(f64, usize, f64)> {
        let max2 = max_dist * max_dist;
        for i in segments {
            let (a, b) = (self.vertices[i], self.vertices[i + 1]);
            let ab = b - a;
            let len2 = ab.norm_squared();
            let t = if len2 > 0.0 {
                ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let d2 = (a + ab * t - p).norm_squared();
            if d2 > max2 || best.is_some_and(|b| b.0 <= d2) {
                continue;
            }
            if !allowed(i as f64 + t) {
                continue;
            }
            best = Some((d2, i, t));
        }
        best
    }
}

/// The first index of `range` where the ascending `arc` is at least `x`
/// (`range.end` if none), probed outwards from the start: the skips of
/// [`Polyline2::project_along`] are mostly short, and a binary search of
/// the whole window costs more than the segments it skips.
fn first_not_below(arc: &[f64], range: Range<usize>, x: f64) -> usize {
    let (mut lo, mut step) = (range.start, 1);
    // Everything before `lo` (within the range) is below `x`.
    while lo < range.end && arc[lo] < x {
        let hi = (lo + step).min(range.end);
        if hi == range.end || arc[hi] >= x {
            return lo + 1 + arc[lo + 1..hi].partition_point(|&a| a < x);
        }
        lo = hi;
        step *= 2;
    }
    lo
}

/// The last index of `range` where the ascending `arc` is at most `y`,
/// probed inwards from the end ([`first_not_below`] mirrored).
fn last_not_above(arc: &[f64], range: Range<usize>, y: f64) -> Option<usize> {
    let (mut hi, mut step) = (range.end, 1);
    // Everything from `hi` on (within the range) is above `y`.
    while hi > range.start {
        if arc[hi - 1] <= y {
            return Some(hi - 1);
        }
        let lo = hi.saturating_sub(1 + step).max(range.start);
        if lo == range.start || arc[lo] <= y {
            let k = arc[lo..hi - 1].partition_point(|&a| a <= y);
            return (k > 0).then(|| lo + k - 1);
        }
        hi = lo;
        step *= 2;
    }
    None
}

/// The projection at fraction `t` of segment `i`, `d2` away.
fn projection((d2, i, t): (f64, usize, f64)) -> Projection {
    Projection {
        distance: d2.sqrt(),
        vertex: i as f64 + t,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn zigzag(n: usize) -> Vec<Vector2<f64>> {
        (0..n)
            .map(|i| Vector2::new(i as f64, ((i * 7) % 5) as f64))
            .collect()
    }

    fn brute(pts: &[Vector2<f64>], p: &Vector2<f64>) -> f64 {
        (0..pts.len() - 1)
            .map(|i| {
                let (a, b) = (pts[i], pts[i + 1]);
                let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
                (a + (b - a) * t - p).norm()
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn nearest_point_on_a_zigzag_matches_brute_force() {
        // Short (flat scan) and long (tree) polylines.
        for n in [203, 2003] {
            let pts = zigzag(n);
            let line = Polyline2::new(&pts);
            for k in 0..50 {
                let p = Vector2::new(k as f64 * 0.041 * n as f64 - 3.0, (k % 9) as f64 - 2.0);
                let d = brute(&pts, &p);
                let got = line.project(&p).expect("a nearest point");
                assert!((got.distance - d).abs() < 1e-12, "{k}: {got:?} vs {d}");
                if d > 0.0 {
                    assert!(line.project_within(&p, d * 0.99, |_| true).is_none());
                }
            }
        }
    }

    #[test]
    fn projecting_along_some_segments_matches_brute_force_on_them() {
        // A zigzag (path much longer than its chords) and a spiral that
        // comes back near itself, with vertices rounded to f32 as the
        // online history keeps them and lengths summed before rounding.
        let spiral: Vec<_> = (0..600)
            .map(|i| {
                let a = i as f64 * 0.05;
                Vector2::new((1.0 + 0.01 * a) * a.cos(), (1.0 + 0.01 * a) * a.sin()) * 1e3
            })
            .collect();
        for exact in [zigzag(300), spiral] {
            let arc: Vec<f64> = std::iter::once(0.0)
                .chain(exact.windows(2).scan(0.0, |s, w| {
                    *s += (w[1] - w[0]).norm();
                    Some(*s)
                }))
                .collect();
            let pts: Vec<_> = exact.iter().map(|p| p.map(|x| x as f32 as f64)).collect();
            let line = Polyline2::new(&pts);
            let span = arc[arc.len() - 1];
            let mut found = 0;
            for k in 0..200 {
                let start = k * 7 % (pts.len() - 50);
                let segments = start..start + 5 + k % 45;
                let end = segments.end.min(pts.len() - 1);
                let p = pts[(start + k % 40).min(pts.len() - 1)]
                    + Vector2::new((k % 13) as f64 - 6.0, (k % 7) as f64 - 3.0) * span * 1e-3;
                let around = arc[start] + (k % 11) as f64 / 10.0 * (arc[end] - arc[start]);
                let max_dist = [f64::INFINITY, span * 0.01, span * 0.002][k % 3];
                let allowed = |v: f64| !((v * 10.0) as usize).is_multiple_of(4);
                let brute = line.nearest_in(&p, max_dist, start..end, &allowed, None);
                let got = line.project_along(&p, max_dist, segments.clone(), &arc, around, allowed);
                match (brute.map(projection), got) {
                    (None, None) => {}
                    (Some(b), Some(g)) => {
                        found += 1;
                        assert!(
                            (g.distance - b.distance).abs() <= 1e-9 * span,
                            "{k}: {g:?} vs {b:?}"
                        );
                        assert!(g.vertex >= start as f64 && g.vertex <= end as f64);
                    }
                    (b, g) => panic!("{k}: brute force {b:?}, along {g:?}"),
                }
            }
            assert!(found > 100, "{found} of 200 cases found a point");
        }
    }

    #[test]
    fn galloping_searches_agree_with_a_binary_search() {
        let arc: Vec<f64> = (0..40).map(|i| (i / 3) as f64).collect();
        for start in 0..40 {
            for end in start..=40 {
                for x in [-1.0, 0.0, 0.5, 3.0, 7.2, 13.0, 20.0] {
                    let first = start + arc[start..end].partition_point(|&a| a < x);
                    assert_eq!(first_not_below(&arc, start..end, x), first);
                    let k = arc[start..end].partition_point(|&a| a <= x);
                    let last = (k > 0).then(|| start + k - 1);
                    assert_eq!(last_not_above(&arc, start..end, x), last);
                }
            }
        }
    }

    #[test]
    fn a_window_of_a_shared_index_equals_its_own_polyline() {
        let pts = zigzag(1000);
        let mut index = PathIndex::default();
        // Indexed as it grows, with a tail not yet in a complete run.
        for n in [100, 517, 1000] {
            index.extend(n, |i| pts[i]);
        }
        let index = Arc::new(index);
        for (first, last) in [(0, 999), (37, 420), (990, 999), (500, 503)] {
            let w = &pts[first..=last];
            let (shared, own) = (
                Polyline2::window(w, index.clone(), first),
                Polyline2::new(w),
            );
            for k in 0..40 {
                let p = Vector2::new(first as f64 + k as f64 * 11.3 % 500.0, (k % 7) as f64);
                let (a, b) = (shared.project(&p), own.project(&p));
                assert_eq!(
                    a.map(|a| a.vertex),
                    b.map(|b| b.vertex),
                    "{first}..{last} {k}"
                );
            }
        }
    }
}
