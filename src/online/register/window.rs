//! The window a registration places ([`super::register`]): its points,
//! weighed by turning, and the share of them a placement lays on the map,
//! with the map's open start (nothing is known before its first pose)
//! counted half.

use nalgebra::Vector2;

use super::map::{Block, Map};
use super::{heading, POINTS, RIVAL_BANDS};
use crate::geometry::Similarity2;
use crate::online::history::HistoryView;

/// The map's first road, in window lengths from the first pose: where a
/// return to the start may lie ([`OpenStart`]), and what the registration
/// checks and searches beyond its reach for it ([`super::register`]).
/// KITTI 00's last revisit under strong drift lay 114-169 m from its
/// window in seeds 2, 3 and 7, beyond the capped reach of about 111 m
/// (`Bounds::of_drift`). (1.5 found the same events with 18 more
/// candidates over seeds 1-40; 3, two events fewer.)
const FIRST_ROAD: f64 = 1.0;

/// Share of a window point's weight counted for a placement that lays it
/// beyond the map's open start ([`OpenStart`]): the map does not know
/// whether a road lies there.
pub(super) const OPEN_CREDIT: f64 = 0.5;

/// The window: points, turning weights, centroid.
pub(super) struct Window {
    pub(super) points: Vec<(Vector2<f64>, f64)>,
    pub(super) weights: Vec<f64>,
    pub(super) total: f64,
    /// The map's open end at the path's first sample.
    pub(super) start: OpenStart,
}

/// The map begins where the path began: beyond its first sample nothing is
/// known, so a window point laid there is neither on nor off the map. A
/// revisit of the first road (the commonest loop: back where it started)
/// enters it from roads the map has never seen, and without this its
/// entry counted against the true place and for any other junction
/// (KITTI 00's last revisit under strong drift).
pub(super) struct OpenStart {
    /// The path's first sample.
    origin: Vector2<f64>,
    /// Its direction of travel along the first road (unit).
    ahead: Vector2<f64>,
    /// The last track sample of the first road: [`FIRST_ROAD`] window
    /// lengths from the first.
    pub(super) road: u32,
    /// The last track sample next to the open end, whose points on the
    /// map a run beyond it must adjoin (a quarter of the window's length
    /// from the first).
    zone: u32,
    /// A point lies beyond the end when less than this far ahead of it
    /// (a band).
    band: f64,
}

impl OpenStart {
    /// The open end of the map `h` for a window of `length` whose
    /// tolerance is `band`.
    fn of(h: &HistoryView, length: f64, band: f64) -> Self {
        let last_within = |l: f64| h.s.partition_point(|&s| s <= h.s[0] + l).saturating_sub(1);
        let road = last_within(FIRST_ROAD * length);
        let zone = last_within(RIVAL_BANDS as f64 * band);
        let origin = h.point(0);
        let d = h.point(zone.max(1).min(h.xy.len() - 1)) - origin;
        let ahead = match d.norm() > 0.0 {
            true => d / d.norm(),
            false => Vector2::zeros(),
        };
        OpenStart {
            origin,
            ahead,
            road: road as u32,
            zone: zone as u32,
            band,
        }
    }

    /// Whether a point laid at `q` lies beyond the map's first sample.
    pub(super) fn beyond(&self, q: &Vector2<f64>) -> bool {
        (q - self.origin).dot(&self.ahead) < self.band
    }
}

/// The window points a placement lays on the map.
#[derive(Default)]
pub(super) struct OnMap {
    /// Their share of the window's weight.
    pub(super) support: f64,
    /// `(map sample, window point)`.
    pub(super) pairs: Vec<(Vector2<f64>, Vector2<f64>)>,
    /// Their weights.
    pub(super) weights: Vec<f64>,
}

impl Window {
    /// [`POINTS`] points of track samples `[g0, g1]` of `h`, weighted by
    /// turning (the turns are what pin a window along its roads), and
    /// their centroid; `band` is the placement's tolerance.
    pub(super) fn new(h: &HistoryView, g0: usize, g1: usize, band: f64) -> (Self, Vector2<f64>) {
        let length = h.s[g1] - h.s[g0];
        let samples: Vec<usize> = (0..POINTS)
            .map(|k| g0 + k * (g1 - g0) / (POINTS - 1))
            .collect();
        let points: Vec<(Vector2<f64>, f64)> = samples
            .iter()
            .map(|&g| (h.point(g), heading(h, g)))
            .collect();
        let kappa: Vec<f64> = samples
            .iter()
            .map(|&g| (h.curvature[g] as f64).abs())
            .collect();
        // Relative to the window's mean curvature, but at least a radian of
        // turning over the window: the noise of a straight weighs nothing.
        let mean_k = (kappa.iter().sum::<f64>() / POINTS as f64).max(1.0 / length);
        let weights: Vec<f64> = kappa.iter().map(|k| 1.0 + k / mean_k).collect();
        let centroid = points.iter().map(|p| p.0).sum::<Vector2<f64>>() / POINTS as f64;
        let window = Window {
            total: weights.iter().sum(),
            points,
            weights,
            start: OpenStart::of(h, length, band),
        };
        (window, centroid)
    }

    /// The turning-weighted share of points within the map's cell of a
    /// sample under `sim`, and the pairs `(map, window)` that are.
    ///
    /// Points of the window's first or last run off the map that carry on
    /// beyond the map's open start ([`OpenStart`]) count [`OPEN_CREDIT`]
    /// of their weight: unknown ground, neither for the place nor against.
    pub(super) fn support(&self, map: &Map, sim: &Similarity2) -> OnMap {
        let mut on = OnMap::default();
        let to_map = sim.applier();
        let mut block = Block::default();
        // The track sample under each window point on the map.
        let mut under = [None; POINTS];
        for (k, ((p, _), wi)) in self.points.iter().zip(&self.weights).enumerate() {
            if let Some(j) = map.nearest(&to_map(p), &mut block) {
                on.support += wi;
                on.pairs.push((map.samples[j].0, *p));
                on.weights.push(*wi);
                under[k] = Some(map.samples[j].2);
            }
        }
        // Only a map that holds the first road has an open start in reach.
        let open = match map.first <= self.start.zone {
            true => self.open_weight(&under, &to_map),
            false => 0.0,
        };
        on.support = (on.support + OPEN_CREDIT * open) / self.total;
        on
    }

    /// The weight of the window points off the map that carry on from its
    /// open start: a leading or trailing run of points off the map next to
    /// a point on the start's road, each laid beyond the first sample.
    fn open_weight(
        &self,
        under: &[Option<u32>; POINTS],
        to_map: &impl Fn(&Vector2<f64>) -> Vector2<f64>,
    ) -> f64 {
        let (Some(first), Some(last)) = (
            under.iter().position(Option::is_some),
            under.iter().rposition(Option::is_some),
        ) else {
            return 0.0;
        };
        let at_start = |k: usize| under[k].is_some_and(|t| t <= self.start.zone);
        let run = |ks: std::ops::Range<usize>| -> f64 {
            ks.filter(|&k| self.start.beyond(&to_map(&self.points[k].0)))
                .map(|k| self.weights[k])
                .sum()
        };
        let mut open = 0.0;
        if at_start(first) {
            open += run(0..first);
        }
        if at_start(last) {
            open += run(last + 1..POINTS);
        }
        open
    }

    /// `rounds` rigid refits of `sim`, which lays `on` on the map (a free
    /// scale would shrink the window onto any dense part of the map): the
    /// refined similarity and what it lays on the map, which the next
    /// refinement starts from instead of looking it up again.
    pub(super) fn refine(
        &self,
        map: &Map,
        mut sim: Similarity2,
        mut on: OnMap,
        rounds: usize,
    ) -> (Similarity2, OnMap) {
        for _ in 0..rounds {
            let (pairs, w) = (&on.pairs, &on.weights);
            let Some(fit) = Similarity2::fit(pairs, Some(w)).filter(|_| pairs.len() >= 3) else {
                break;
            };
            let rotate = Similarity2 {
                scale: 1.0,
                angle: fit.angle,
                translation: Vector2::zeros(),
            };
            let (mut cm, mut cq, mut ws) = (Vector2::zeros(), Vector2::zeros(), 0.0);
            for ((m, q), wi) in pairs.iter().zip(w) {
                cm += m * *wi;
                cq += q * *wi;
                ws += wi;
            }
            sim = Similarity2 {
                translation: cm / ws - rotate.apply(&(cq / ws)),
                ..rotate
            };
            on = self.support(map, &sim);
        }
        (sim, on)
    }
}
