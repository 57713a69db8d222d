//! What real odometry sends, and what the detector does with it:
//!
//! - a non-finite position or timestamp: the pose is dropped (counted); so
//!   is a coordinate beyond [`MAX_COORDINATE`], whose distances the method
//!   cannot square;
//! - a timestamp older than the last accepted one: dropped (out of order),
//!   unless it is newer than the one before that: then the last one's stamp
//!   alone was ahead, the pose is taken and that stamp forgotten (counted);
//! - a timestamp equal to the last accepted one: dropped (duplicate);
//! - a single pose far away from both its neighbours (a GPS glitch: the step
//!   in and the step out both longer than `jump_factor` typical steps, the
//!   typical step following the path's speed upwards): the
//!   pose is dropped (counted as an outlier); this holds one pose back;
//! - a lasting jump (VO failure, re-initialisation: the path continues from
//!   the new place): the detector's frame is re-anchored so that the path
//!   continues one typical step along its last direction; later positions
//!   are shifted by the same offset (counted as a jump), so the jump adds
//!   neither length nor a curvature spike;
//! - standing still (steps below a quarter of the typical step): the pose
//!   costs O(1) and adds nothing to the history (chord parameter).

use nalgebra::Vector2;

/// Largest magnitude of a coordinate the detector takes.
///
/// The worker's history keeps positions as `f32` relative to the warm-up
/// centroid, which overflow to infinity past 3.4e38 (and then its spatial
/// index computed cell keys out of range); the method also squares
/// distances and path lengths in `f64`, which overflow from steps of about
/// 1e154 on (the chord parameter became infinite and the grid emitted
/// samples for ever). 1e30 leaves the path eight orders of magnitude to
/// travel within `f32`; no map in any unit comes near it.
pub const MAX_COORDINATE: f64 = 1e30;

/// Why a pose was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rejection {
    /// NaN or infinite position or timestamp, or a coordinate beyond
    /// [`MAX_COORDINATE`] (not finite in the method's arithmetic).
    NonFinite,
    /// Timestamp older than the last accepted pose's, and not newer than
    /// the one before it (see [`TimeGuard::check`]).
    OutOfOrder,
    /// Timestamp equal to the last accepted pose's.
    Duplicate,
}

/// Counts of what the guards did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct GuardCounts {
    /// Non-finite poses dropped (coordinates beyond [`MAX_COORDINATE`]
    /// included).
    pub non_finite: u64,
    /// Out-of-order poses dropped.
    pub out_of_order: u64,
    /// Duplicate timestamps dropped.
    pub duplicate: u64,
    /// Isolated far poses dropped (glitches).
    pub outliers: u64,
    /// Lasting jumps removed by re-anchoring.
    pub jumps: u64,
    /// Poses taken although older than the last, whose stamp alone was
    /// ahead of both neighbours (see [`TimeGuard::check`]).
    pub stamps_ahead: u64,
}

/// Timestamp and finiteness checks.
#[derive(Debug, Clone, Default)]
pub struct TimeGuard {
    last_t: Option<f64>,
    /// The accepted stamp before `last_t`.
    before_t: Option<f64>,
}

impl TimeGuard {
    /// Checks one pose; on success it becomes the last accepted one.
    ///
    /// A stamp older than the last accepted one but newer than the one
    /// before it says that the last one's stamp alone was ahead, not that
    /// this pose came late: CARMEN's Intel lab log stamps 305 odometry lines
    /// ahead of the next one (median 0.27 s), and their positions follow in
    /// line order (211 of the 212 such lines that move lie between their
    /// neighbours); dropped until the clock catches up, 3 007 of its 26 915
    /// poses would be lost. The pose is taken (`stamps_ahead`) and the stamp
    /// ahead forgotten.
    pub fn check(
        &mut self,
        t: Option<f64>,
        p: &[f64; 3],
        counts: &mut GuardCounts,
    ) -> Result<(), Rejection> {
        // `abs() <= MAX` is false for NaN too.
        if !p.iter().all(|v| v.abs() <= MAX_COORDINATE) || t.is_some_and(|t| !t.is_finite()) {
            return Err(Rejection::NonFinite);
        }
        if let (Some(t), Some(last)) = (t, self.last_t) {
            if t == last {
                return Err(Rejection::Duplicate);
            }
            if t < last {
                if !self.before_t.is_some_and(|b| t > b) {
                    return Err(Rejection::OutOfOrder);
                }
                counts.stamps_ahead += 1;
                self.last_t = Some(t);
                return Ok(());
            }
        }
        if t.is_some() {
            self.before_t = self.last_t;
            self.last_t = t;
        }
        Ok(())
    }
}

/// What the jump filter lets through for one input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Passed {
    /// Nothing yet (a suspect is held back, or a glitch was dropped).
    None,
    /// One pose (index, position in the detector's frame).
    One((usize, Vector2<f64>)),
    /// The held suspect and the new pose, both re-anchored.
    Two([(usize, Vector2<f64>); 2]),
}

/// One-pose-lookahead jump filter on 2D positions.
#[derive(Debug, Clone)]
pub struct JumpFilter {
    factor: f64,
    typical: f64,
    offset: Vector2<f64>,
    last: Option<Vector2<f64>>,
    direction: Vector2<f64>,
    suspect: Option<(usize, Vector2<f64>)>,
}

impl JumpFilter {
    /// Jumps are steps longer than `factor * typical`.
    pub fn new(typical: f64, factor: f64) -> Self {
        JumpFilter {
            factor,
            typical,
            offset: Vector2::zeros(),
            last: None,
            direction: Vector2::new(1.0, 0.0),
            suspect: None,
        }
    }

    /// Takes `typical` as the typical step from now on (the path changed
    /// speed).
    pub fn retune(&mut self, typical: f64) {
        self.typical = typical;
    }

    /// Steps longer than this are jumps.
    fn limit(&self) -> f64 {
        self.factor * self.typical
    }

    /// Feeds pose `index` at raw position `p`.
    pub fn push(&mut self, index: usize, p: Vector2<f64>, counts: &mut GuardCounts) -> Passed {
        let p = p + self.offset;
        let Some(last) = self.last else {
            self.accept(p);
            return Passed::One((index, p));
        };
        if let Some((si, sp)) = self.suspect.take() {
            if (p - last).norm() <= self.limit() {
                // The path came back: the suspect was a glitch.
                counts.outliers += 1;
                self.accept(p);
                return Passed::One((index, p));
            }
            // The path stays away: re-anchor at the suspect.
            counts.jumps += 1;
            let shift = last + self.typical * self.direction - sp;
            self.offset += shift;
            let (sp, p) = (sp + shift, p + shift);
            self.accept(sp);
            if (p - sp).norm() > self.limit() {
                // The new pose jumps again from the suspect: it is held in
                // turn. Taken as a step, a jump of a million typical steps
                // made the track grid emit a million samples.
                self.suspect = Some((index, p));
                return Passed::One((si, sp));
            }
            self.accept(p);
            return Passed::Two([(si, sp), (index, p)]);
        }
        if (p - last).norm() > self.limit() {
            self.suspect = Some((index, p));
            return Passed::None;
        }
        self.accept(p);
        Passed::One((index, p))
    }

    /// Releases a held suspect at the end of the stream (as a lasting jump).
    pub fn flush(&mut self, counts: &mut GuardCounts) -> Option<(usize, Vector2<f64>)> {
        let (si, sp) = self.suspect.take()?;
        let last = self.last?;
        counts.jumps += 1;
        let shift = last + self.typical * self.direction - sp;
        self.offset += shift;
        Some((si, sp + shift))
    }

    fn accept(&mut self, p: Vector2<f64>) {
        if let Some(last) = self.last {
            let d = p - last;
            let n = d.norm();
            if n > 0.25 * self.typical {
                self.direction = d / n;
            }
        }
        self.last = Some(p);
    }
}
