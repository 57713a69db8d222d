//! Where a path comes back to where it has been: per-pose revisits (nearest
//! earlier pose far enough back in time) and revisit events (runs of them
//! spanning enough road). Used both for the ground truth of the loop
//! evaluation and, in the input's own frame, by the naive baseline.

use nalgebra::Vector3;

/// Cumulative arc length: `arc[0] = 0`, `arc[i] = arc[i-1] + |p_i - p_{i-1}|`.
pub fn arc_lengths(positions: &[Vector3<f64>]) -> Vec<f64> {
    let mut arc = Vec::with_capacity(positions.len());
    let mut s = 0.0;
    for (i, p) in positions.iter().enumerate() {
        if i > 0 {
            s += (p - positions[i - 1]).norm();
        }
        arc.push(s);
    }
    arc
}

/// For every pose `i`, the nearest pose `j <= i - min_gap` and its distance
/// (`None` when `i < min_gap`). Brute force: O(n^2), about 10^7 distance
/// evaluations for a KITTI sequence.
pub fn nearest_earlier(positions: &[Vector3<f64>], min_gap: usize) -> Vec<Option<(usize, f64)>> {
    nearest_before(positions, |i| (i + 1).checked_sub(min_gap))
}

/// For every pose `i`, the nearest pose `j` at least `gap` of road earlier
/// (`arc[j] <= arc[i] - gap`) and its distance: [`nearest_earlier`] with the
/// gap in length, for paths whose rate of poses per length varies (a drone
/// hovering, a walker standing at a crossing).
pub fn nearest_earlier_apart(positions: &[Vector3<f64>], gap: f64) -> Vec<Option<(usize, f64)>> {
    let arc = arc_lengths(positions);
    nearest_before(positions, |i| {
        Some(arc.partition_point(|s| *s <= arc[i] - gap))
    })
}

/// For every pose `i`, the nearest of the poses `0..end(i)` and its
/// distance (`None` when there is none).
fn nearest_before(
    positions: &[Vector3<f64>],
    end: impl Fn(usize) -> Option<usize>,
) -> Vec<Option<(usize, f64)>> {
    (0..positions.len())
        .map(|i| {
            let p = positions[i];
            (0..end(i)?)
                .map(|j| (j, (positions[j] - p).norm_squared()))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .map(|(j, d2)| (j, d2.sqrt()))
        })
        .collect()
}

/// For every pose, the nearest earlier pose (at least `min_gap` poses back)
/// when it lies within `radius`; `None` otherwise.
pub fn revisits(positions: &[Vector3<f64>], radius: f64, min_gap: usize) -> Vec<Option<usize>> {
    nearest_earlier(positions, min_gap)
        .into_iter()
        .map(|n| n.filter(|(_, d)| *d <= radius).map(|(j, _)| j))
        .collect()
}

/// A run of revisiting poses: the later pass `[first, last]` (inclusive pose
/// indices) over road already travelled at `[match_first, match_last]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// First revisiting pose.
    pub first: usize,
    /// Last revisiting pose.
    pub last: usize,
    /// Road length of the later pass, `arc[last] - arc[first]`.
    pub length: f64,
    /// Smallest matched earlier pose.
    pub match_first: usize,
    /// Largest matched earlier pose.
    pub match_last: usize,
}

/// Groups revisiting poses into events: consecutive revisiting poses with
/// gaps of at most `max_gap` non-revisiting poses join one run; a run is an
/// event when it spans at least `min_length` of road (same units as `arc`).
pub fn events(
    revisits: &[Option<usize>],
    arc: &[f64],
    max_gap: usize,
    min_length: f64,
) -> Vec<Event> {
    let mut out = Vec::new();
    let mut run: Option<Event> = None;
    let close = |run: Option<Event>, out: &mut Vec<Event>| {
        if let Some(e) = run {
            if e.length >= min_length {
                out.push(e);
            }
        }
    };
    for (i, r) in revisits.iter().enumerate() {
        let Some(j) = *r else { continue };
        match run.as_mut() {
            Some(e) if i - e.last <= max_gap + 1 => {
                e.last = i;
                e.length = arc[i] - arc[e.first];
                e.match_first = e.match_first.min(j);
                e.match_last = e.match_last.max(j);
            }
            _ => {
                close(run.take(), &mut out);
                run = Some(Event {
                    first: i,
                    last: i,
                    length: 0.0,
                    match_first: j,
                    match_last: j,
                });
            }
        }
    }
    close(run, &mut out);
    out
}

/// Median true distance from the poses of `query` (an inclusive index
/// range) to the nearest pose of `matched`: how far apart a loop's two
/// passes really are (0 for the same road in the same lane).
pub fn true_offset(query: [usize; 2], matched: [usize; 2], truth: &[Vector3<f64>]) -> f64 {
    let mut d: Vec<f64> = (query[0]..=query[1])
        .map(|i| {
            (matched[0]..=matched[1])
                .map(|j| (truth[i] - truth[j]).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(f64::INFINITY)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 100 m straight, a square loop of side 100 m back to the start,
    /// then the first 60 m of the straight again: 1 m steps.
    fn loop_path() -> Vec<Vector3<f64>> {
        crate::test_paths::square_loop(61, 0.0)
    }

    #[test]
    fn arc_lengths_accumulate_steps() {
        let arc = arc_lengths(&loop_path());
        assert_eq!(arc[0], 0.0);
        assert!((arc[460] - 460.0).abs() < 1e-9);
    }

    #[test]
    fn the_second_pass_is_one_event() {
        let path = loop_path();
        let arc = arc_lengths(&path);
        let r = revisits(&path, 8.0, 300);
        let ev = events(&r, &arc, 3, 40.0);
        assert_eq!(ev.len(), 1, "{ev:?}");
        let e = &ev[0];
        // Poses 392.. lie within 8 m of the start (the corner at 400 closes
        // the square); the run lasts to the end of the path.
        assert!((390..=395).contains(&e.first), "{e:?}");
        assert_eq!(e.last, 460);
        assert!(
            e.match_first <= 2 && (58..=61).contains(&e.match_last),
            "{e:?}"
        );
    }

    #[test]
    fn short_runs_and_gaps_are_handled() {
        let arc: Vec<f64> = (0..20).map(|i| i as f64 * 10.0).collect();
        let mut r = vec![None; 20];
        // 2..=5 with a 2-pose gap then 8..=9: one run of 70 m with max_gap 2.
        for i in [2, 3, 4, 5, 8, 9] {
            r[i] = Some(0);
        }
        // A lone revisit at 15: too short.
        r[15] = Some(1);
        let ev = events(&r, &arc, 2, 40.0);
        assert_eq!(ev.len(), 1);
        assert_eq!((ev[0].first, ev[0].last), (2, 9));
        assert!((ev[0].length - 70.0).abs() < 1e-9);
        // With no gap allowed the run splits into 30 m and 10 m pieces.
        assert!(events(&r, &arc, 0, 40.0).is_empty());
    }
}
