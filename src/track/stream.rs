//! The track one sample at a time: kernel smoothing on a uniform grid in the
//! chord parameter, then arc length, heading and curvature by central
//! differences. [`super::Track::from_smoother`] runs these same streams over
//! a whole path, so batch and online share one implementation.
//!
//! Lags: a grid sample at `u` is final once a kept pose beyond
//! `u + Smoother::reach()` (three bandwidths) has arrived; its heading and
//! curvature need two more grid samples (central differences).

use std::collections::VecDeque;

use nalgebra::Vector2;

use super::Smoother;

/// One final sample of the smoothed grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridPoint {
    /// Chord parameter of the sample.
    pub u: f64,
    /// Smoothed position.
    pub xy: Vector2<f64>,
    /// Fractional original pose index.
    pub pose: f64,
}

/// A kept (moving) pose as the smoother sees it.
#[derive(Debug, Clone, Copy)]
struct Kept {
    u: f64,
    xy: Vector2<f64>,
    /// Original pose index (fractional for a pose filled into a gap).
    index: f64,
}

/// Kernel smoother evaluated on the grid `u_i = i · step` as kept poses
/// arrive in increasing `u`.
#[derive(Debug, Clone)]
pub struct GridStream {
    smoother: Smoother,
    step: f64,
    window: VecDeque<Kept>,
    /// The last kept pose dropped from the window (pose interpolation).
    before: Option<Kept>,
    next: usize,
    /// Sample `base` lies at `origin`, the later ones `step` apart (both 0
    /// until [`GridStream::retune`]).
    base: usize,
    origin: f64,
}

impl GridStream {
    /// Grid step `step` (units of `u`), kernel `smoother`.
    pub fn new(smoother: Smoother, step: f64) -> Self {
        GridStream {
            smoother,
            step,
            window: VecDeque::new(),
            before: None,
            next: 0,
            base: 0,
            origin: 0.0,
        }
    }

    /// Samples from the next one on `step` apart, smoothed by `smoother`
    /// (the path changed speed; see the online `Streams`). The samples
    /// already emitted keep their spacing.
    pub fn retune(&mut self, smoother: Smoother, step: f64) {
        self.origin = self.u_of(self.next);
        self.base = self.next;
        self.smoother = smoother;
        self.step = step;
    }

    /// Chord parameter of grid sample `i` (`i >= base`).
    fn u_of(&self, i: usize) -> f64 {
        self.origin + (i - self.base) as f64 * self.step
    }

    /// Grid step.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// Number of grid samples emitted so far.
    pub fn emitted(&self) -> usize {
        self.next
    }

    /// Feeds a kept pose (chord parameter `u`, position, original index)
    /// and emits every grid sample that became final.
    ///
    /// A pose farther than the kernel's reach from the last one (the path
    /// sped up to steps of many bandwidths, or a sparse path) is preceded by
    /// poses on the chord between the two, a bandwidth apart. Without them
    /// the grid samples in the gap see one pose each: they pile up on it,
    /// their differences are rounding noise, and each noise direction
    /// counted as turning (KITTI 00 entered at a tenth of its speed: 120°
    /// of turning per pose once the car sped up).
    pub fn push(
        &mut self,
        u: f64,
        xy: Vector2<f64>,
        index: usize,
        out: &mut impl FnMut(GridPoint),
    ) {
        let index = index as f64;
        let h = self.smoother.bandwidth;
        if let Some(&last) = self.window.back() {
            let gap = u - last.u;
            if gap > self.smoother.reach() && gap.is_finite() && h > 0.0 {
                let n = (gap / h).ceil() as usize;
                for k in 1..n {
                    let f = k as f64 / n as f64;
                    self.push_kept(
                        Kept {
                            u: last.u + f * gap,
                            xy: last.xy + f * (xy - last.xy),
                            index: last.index + f * (index - last.index),
                        },
                        out,
                    );
                }
            }
        }
        self.push_kept(Kept { u, xy, index }, out);
    }

    fn push_kept(&mut self, kept: Kept, out: &mut impl FnMut(GridPoint)) {
        let u = kept.u;
        self.window.push_back(kept);
        let reach = self.smoother.reach();
        loop {
            let ui = self.u_of(self.next);
            // An infinite `u` would never be reached.
            if u <= ui + reach || !u.is_finite() {
                break;
            }
            out(self.eval(ui));
            self.next += 1;
        }
    }

    /// Emits the remaining samples up to grid index `count - 1` (the end of
    /// the path: no more poses will come).
    pub fn flush(&mut self, count: usize, out: &mut impl FnMut(GridPoint)) {
        if self.window.is_empty() {
            return;
        }
        while self.next < count {
            let ui = self.u_of(self.next);
            out(self.eval(ui));
            self.next += 1;
        }
    }

    /// Grid samples a path of total chord length `total` has (the last one
    /// at or just past the end), for [`GridStream::flush`] online.
    pub fn count_for(&self, total: f64) -> usize {
        if total < self.origin {
            return self.next;
        }
        self.base + ((total - self.origin) / self.step).floor() as usize + 1
    }

    fn eval(&mut self, ui: f64) -> GridPoint {
        let reach = self.smoother.reach();
        while self.window.len() > 1 && self.window[0].u < ui - reach {
            self.before = self.window.pop_front();
        }
        let xy = match self
            .smoother
            .kernel(self.window.iter().map(|k| (k.u, k.xy)), ui)
        {
            Some((p, _)) => p,
            None => {
                // Beyond the kernel reach of every pose: the first pose at or
                // after `ui` (else the last one).
                let k = self.window.iter().position(|k| k.u >= ui);
                self.window[k.unwrap_or(self.window.len() - 1)].xy
            }
        };
        GridPoint {
            u: ui,
            xy,
            pose: self.pose_at(ui),
        }
    }

    /// Fractional original pose index at `u` by linear interpolation
    /// between the kept poses around it.
    fn pose_at(&self, u: f64) -> f64 {
        let Some(k) = self.window.iter().position(|k| k.u > u) else {
            return self.window.back().map_or(0.0, |k| k.index);
        };
        let prev = if k == 0 {
            match self.before {
                Some(b) => b,
                None => return self.window[0].index,
            }
        } else {
            self.window[k - 1]
        };
        let next = self.window[k];
        let f = if next.u > prev.u {
            (u - prev.u) / (next.u - prev.u)
        } else {
            0.0
        };
        prev.index + f * (next.index - prev.index)
    }
}

/// One final sample of the track: position, arc length, unwrapped heading,
/// curvature and fractional pose index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPoint {
    /// Smoothed position.
    pub xy: Vector2<f64>,
    /// Arc length of the smoothed curve.
    pub s: f64,
    /// Unwrapped heading (radians).
    pub heading: f64,
    /// Signed curvature `d heading / ds`.
    pub curvature: f64,
    /// Fractional original pose index.
    pub pose: f64,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    xy: Vector2<f64>,
    s: f64,
    pose: f64,
    heading: f64,
}

/// Arc length, unwrapped heading and curvature by central differences,
/// `kappa_i = (theta_{i+1} - theta_{i-1}) / (s_{i+1} - s_{i-1})`, one grid
/// sample at a time (one-sided at both ends). Lag: two samples.
#[derive(Debug, Clone, Default)]
pub struct DiffStream {
    /// The last (up to) four samples; `base` is the index of the first.
    ring: VecDeque<Pending>,
    base: usize,
    n: usize,
}

impl DiffStream {
    /// An empty stream.
    pub fn new() -> Self {
        Self::default()
    }

    /// Samples received so far.
    pub fn received(&self) -> usize {
        self.n
    }

    fn at(&self, i: usize) -> &Pending {
        &self.ring[i - self.base]
    }

    fn at_mut(&mut self, i: usize) -> &mut Pending {
        &mut self.ring[i - self.base]
    }

    /// Feeds grid sample `n` and emits sample `n - 2` once it is final.
    pub fn push(&mut self, g: GridPoint, out: &mut impl FnMut(TrackPoint)) {
        let n = self.n;
        let s = if n == 0 {
            0.0
        } else {
            let prev = self.at(n - 1);
            prev.s + (g.xy - prev.xy).norm()
        };
        self.ring.push_back(Pending {
            xy: g.xy,
            s,
            pose: g.pose,
            heading: 0.0,
        });
        self.n += 1;
        if n >= 1 {
            self.set_heading(n - 1, n);
        }
        if n >= 2 {
            self.emit(n - 2, n - 1, out);
        }
        while self.ring.len() > 4 {
            self.ring.pop_front();
            self.base += 1;
        }
    }

    /// Emits the last two samples with one-sided differences at the end.
    pub fn flush(&mut self, out: &mut impl FnMut(TrackPoint)) {
        let m = self.n;
        if m == 0 {
            return;
        }
        self.set_heading(m - 1, m - 1);
        if m >= 2 {
            self.emit(m - 2, m - 1, out);
        }
        self.emit(m - 1, m - 1, out);
    }

    /// Heading of sample `i` from its neighbours up to `last`, unwrapped
    /// against sample `i - 1`.
    fn set_heading(&mut self, i: usize, last: usize) {
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(last));
        let d = self.at(hi).xy - self.at(lo).xy;
        let mut h = d.y.atan2(d.x);
        if i > 0 {
            use std::f64::consts::{PI, TAU};
            let prev = self.at(i - 1).heading;
            let mut dh = h - prev;
            dh -= TAU * ((dh + PI) / TAU).floor();
            h = prev + dh;
        }
        self.at_mut(i).heading = h;
    }

    fn emit(&self, i: usize, last: usize, out: &mut impl FnMut(TrackPoint)) {
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(last));
        let (a, b) = (self.at(lo), self.at(hi));
        let ds = b.s - a.s;
        let curvature = if ds > 0.0 {
            (b.heading - a.heading) / ds
        } else {
            0.0
        };
        let p = self.at(i);
        out(TrackPoint {
            xy: p.xy,
            s: p.s,
            heading: p.heading,
            curvature,
            pose: p.pose,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After a retune the samples go on from where the old spacing would
    /// have put the next one, at the new spacing, and the count at the end
    /// of the path is the last sample at or past it.
    #[test]
    fn a_retuned_grid_goes_on_at_the_new_step() {
        let smoother = Smoother { bandwidth: 0.5 };
        let mut grid = GridStream::new(smoother, 0.25);
        let mut u = Vec::new();
        for i in 0..40 {
            let x = i as f64 * 0.25;
            grid.push(x, Vector2::new(x, 0.0), i, &mut |g| u.push(g.u));
        }
        let before = u.len();
        let next = before as f64 * 0.25;
        grid.retune(Smoother { bandwidth: 2.0 }, 1.0);
        for i in 40..200 {
            let x = 10.0 + (i - 40) as f64;
            grid.push(x, Vector2::new(x, 0.0), i, &mut |g| u.push(g.u));
        }
        let total = 169.0;
        let count = grid.count_for(total);
        grid.flush(count, &mut |g| u.push(g.u));
        assert_eq!(u[before], next);
        assert!(u[before..].windows(2).all(|w| w[1] - w[0] == 1.0));
        let last = *u.last().unwrap();
        assert!(last >= total - 1.0 && last <= total, "last sample {last}");
        assert_eq!(u.len(), count);
    }
}
