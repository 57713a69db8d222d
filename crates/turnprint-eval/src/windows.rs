//! Where the merge test cases are cut from a sequence: windows of ground-
//! truth frames chosen by road length, either overlapping in time (B shares
//! part of A's drive and runs on beyond it) or on a later pass over A's road.

use rand::Rng;

use super::revisits::Event;

/// An inclusive range of ground-truth frames.
pub type Window = [usize; 2];

/// First frame whose arc length reaches `s` (the last frame past the end).
pub fn frame_at_arc(arc: &[f64], s: f64) -> usize {
    arc.partition_point(|a| *a < s).min(arc.len() - 1)
}

/// Road length of a window.
pub fn window_length(arc: &[f64], w: Window) -> f64 {
    arc[w[1]] - arc[w[0]]
}

/// Road length shared by two windows of the same drive.
pub fn shared_length(arc: &[f64], a: Window, b: Window) -> f64 {
    let (lo, hi) = (a[0].max(b[0]), a[1].min(b[1]));
    if lo < hi {
        arc[hi] - arc[lo]
    } else {
        0.0
    }
}

/// Window by road length `[s0, s1]`, clipped to the drive.
fn window_at(arc: &[f64], s0: f64, s1: f64) -> Window {
    [frame_at_arc(arc, s0.max(0.0)), frame_at_arc(arc, s1)]
}

/// A random window of `min_len..max_len` of road (`None` if the drive is
/// shorter than `min_len`).
pub fn random_window(
    rng: &mut impl Rng,
    arc: &[f64],
    min_len: f64,
    max_len: f64,
) -> Option<Window> {
    let total = *arc.last()?;
    if total < min_len {
        return None;
    }
    let len = rng.random_range(min_len..=max_len.min(total));
    let s0 = rng.random_range(0.0..=total - len);
    Some(window_at(arc, s0, s0 + len))
}

/// Lengths (m) of the parts that the evaluation windows are built from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WindowSpec {
    /// Shortest and longest A window.
    pub a_len: (f64, f64),
    /// Shortest and longest common road.
    pub overlap: (f64, f64),
    /// Shortest and longest non-overlapping extension of B on each side.
    pub extra: (f64, f64),
}

impl Default for WindowSpec {
    fn default() -> Self {
        WindowSpec {
            a_len: (400.0, 1500.0),
            overlap: (200.0, 700.0),
            extra: (100.0, 600.0),
        }
    }
}

/// Which side(s) of the common road B extends beyond.
fn random_sides(rng: &mut impl Rng) -> (bool, bool) {
    match rng.random_range(0..3) {
        0 => (true, false),
        1 => (false, true),
        _ => (true, true),
    }
}

/// A window B of the same drive overlapping A by at least
/// `spec.overlap.0` of road and extending at least `spec.extra.0 / 2`
/// beyond A on one or both sides. `None` when the drive's ends leave no
/// room (the caller draws again).
pub fn overlapping_window(
    rng: &mut impl Rng,
    arc: &[f64],
    a: Window,
    spec: &WindowSpec,
) -> Option<Window> {
    let total = *arc.last()?;
    let (sa0, sa1) = (arc[a[0]], arc[a[1]]);
    let a_len = sa1 - sa0;
    if a_len < spec.overlap.0 {
        return None;
    }
    let (before, after) = random_sides(rng);
    let e0 = rng.random_range(spec.extra.0..=spec.extra.1);
    let e1 = rng.random_range(spec.extra.0..=spec.extra.1);
    let o = rng.random_range(spec.overlap.0..=spec.overlap.1.min(a_len).max(spec.overlap.0));
    let (s0, s1) = match (before, after) {
        (true, true) => (sa0 - e0, sa1 + e1),
        (true, false) => (sa0 - e0, sa0 + o),
        _ => (sa1 - o, sa1 + e1),
    };
    let b = window_at(arc, s0, s1.min(total));
    let beyond = (sa0 - arc[b[0]]).max(arc[b[1]] - sa1);
    (shared_length(arc, a, b) >= spec.overlap.0 && beyond >= spec.extra.0 / 2.0).then_some(b)
}

/// Windows for a revisit case: B is a later pass over at least
/// `spec.overlap.0` of the road of an event (`revisits[i]` is the earlier
/// frame that frame `i` revisits), extended on one or both sides; A is the
/// earlier pass with margins, `spec.a_len` long. `None` when the event is
/// too short, its earlier counterpart is not one stretch of road (or makes
/// A too long), or A and B would share frames.
pub fn revisit_windows(
    rng: &mut impl Rng,
    arc: &[f64],
    event: &Event,
    revisits: &[Option<usize>],
    spec: &WindowSpec,
) -> Option<(Window, Window)> {
    if event.length < spec.overlap.0 {
        return None;
    }
    let o = rng.random_range(spec.overlap.0..=spec.overlap.1.min(event.length));
    let s0 = rng.random_range(arc[event.first]..=arc[event.last] - o);
    let core = window_at(arc, s0, s0 + o);
    let earlier: Vec<usize> = (core[0]..=core[1]).filter_map(|i| revisits[i]).collect();
    let (m0, m1) = (*earlier.iter().min()?, *earlier.iter().max()?);
    if arc[m1] - arc[m0] > 1.5 * o + 100.0 {
        return None;
    }
    let (mut a0, mut a1) = (
        arc[m0] - rng.random_range(50.0..=400.0),
        arc[m1] + rng.random_range(50.0..=400.0),
    );
    if a1 - a0 < spec.a_len.0 {
        let pad = 0.5 * (spec.a_len.0 - (a1 - a0));
        a0 -= pad;
        a1 += pad;
    }
    let a = window_at(arc, a0, a1);
    if window_length(arc, a) > spec.a_len.1 {
        return None;
    }
    let (before, after) = random_sides(rng);
    let mut extra = |on: bool| {
        if on {
            rng.random_range(spec.extra.0..=spec.extra.1)
        } else {
            0.0
        }
    };
    let b = window_at(
        arc,
        arc[core[0]] - extra(before),
        arc[core[1]] + extra(after),
    );
    let disjoint = a[1] < b[0] || b[1] < a[0];
    disjoint.then_some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};

    /// 1 m per frame, 4000 frames.
    fn arc() -> Vec<f64> {
        (0..4000).map(|i| i as f64).collect()
    }

    #[test]
    fn random_windows_have_the_asked_length() {
        let arc = arc();
        let mut rng = StdRng::seed_from_u64(1);
        for _ in 0..200 {
            let w = random_window(&mut rng, &arc, 400.0, 1500.0).unwrap();
            let len = window_length(&arc, w);
            assert!((399.0..=1501.0).contains(&len), "{w:?}");
        }
        assert!(random_window(&mut rng, &arc[..100], 400.0, 1500.0).is_none());
    }

    #[test]
    fn overlapping_windows_share_road_and_stick_out() {
        let arc = arc();
        let spec = WindowSpec::default();
        let mut rng = StdRng::seed_from_u64(2);
        let mut made = 0;
        for _ in 0..300 {
            let a = random_window(&mut rng, &arc, 400.0, 1500.0).unwrap();
            let Some(b) = overlapping_window(&mut rng, &arc, a, &spec) else {
                continue;
            };
            made += 1;
            assert!(shared_length(&arc, a, b) >= 200.0);
            assert!(b[0] < a[0] || b[1] > a[1], "{a:?} {b:?}");
        }
        assert!(made > 200, "only {made} of 300 drawn");
    }

    #[test]
    fn revisit_windows_are_disjoint_passes() {
        // Frames 3000..3999 drive again over frames 500..1499.
        let arc = arc();
        let mut revisits = vec![None; 4000];
        for (i, r) in revisits.iter_mut().enumerate().skip(3000) {
            *r = Some(i - 2500);
        }
        let event = Event {
            first: 3000,
            last: 3999,
            length: 999.0,
            match_first: 500,
            match_last: 1499,
        };
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..100 {
            let (a, b) =
                revisit_windows(&mut rng, &arc, &event, &revisits, &WindowSpec::default()).unwrap();
            assert!(a[1] < b[0]);
            assert!((399.0..=1500.0).contains(&window_length(&arc, a)));
            // The common road: B's frames whose earlier frame lies in A.
            let common = (b[0]..=b[1])
                .filter(|i| revisits[*i].is_some_and(|j| (a[0]..=a[1]).contains(&j)))
                .count();
            assert!(common >= 199, "{a:?} {b:?} {common}");
        }
    }
}
