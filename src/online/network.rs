//! When to place the newest stretch on the whole road network
//! ([`register`]) and what becomes of the placement: the detector's trigger
//! of the registration (a drifting map's revisit entered and left by other
//! roads), its gates, and the candidate grown from it.

use super::events::Source;
use super::history::History;
use super::probe::Probed;
use super::register;
use super::search::{emitted, grow_seeded, Found, Frame, Searcher};
use super::OnlineConfig;

/// Probe periods of track samples the network registration places: about
/// 100 poses, 80 m, on KITTI, a junction's turn with the straights on both
/// sides of it (3 periods: one strong-drift event fewer of 44; 6: the same
/// events, more false candidates).
const REGISTER_PERIODS: usize = 4;
/// Least [`register::Registration::margin`] of an emitted placement over its
/// best rival: a window that fits two places about as well is left to the
/// later windows. 1.1 since the fifteenth session, whose narrower reach
/// holds fewer rival places: strong drift, seeds 1-40, 320 -> 338 of 440
/// events against 1.2, seeds 41-60 (never run before) 154 -> 163 of 220, at
/// 18 % more candidates (ground truth 144 -> 151, share 0.78 -> 0.75). At
/// 1.3, 290 of 440; with no margin at all, 279 of 320 placements on the
/// strong-drift runs were wrong (thirteenth session).
pub const REGISTER_MARGIN: f64 = 1.1;
/// Probe periods between two network registrations at least: a segment's
/// end and a periodic probe can come a few samples apart, and their windows
/// would be placed twice. (At every probe: 22 strong-drift events of 44
/// instead of 21, the stream within noise; every second period: 20.)
const REGISTER_EVERY: usize = 1;

/// The newest stretch registered onto the map's road network
/// ([`register`]), for a probe that found a road but no candidate (a
/// proximity candidate short of the cut aside; with the drifting map's
/// search on): verified from the registered placement, emitted as the drift
/// probe's.
pub fn register_newest(
    h: &History,
    searcher: &mut Searcher,
    frame: &Frame,
    probed: &Probed,
    config: &OnlineConfig,
) -> Option<Found> {
    let prior = config.pipeline.drift_prior.as_ref()?;
    let spatial = searcher.spatial.as_ref()?;
    if config.drift_radius() <= 0.0 {
        return None;
    }
    let g1 = probed.query()[1];
    let g0 = g1.checked_sub(REGISTER_PERIODS * config.probe_every)?;
    let recent = searcher
        .last_registered
        .is_some_and(|last| g1 < last + REGISTER_EVERY * config.probe_every);
    let length = h.s[g1] - h.s[g0];
    if recent || length <= 0.0 {
        return None;
    }
    // Every window is placed, straight or turning: a straight slides along
    // its road, and its rival places along the road hold its margin near 1
    // (`register::RIVAL_BANDS`). A gate on the window's turning (half a
    // radian until the fifteenth session) saved registrations that the
    // narrower reach now pays for: KITTI 00's ground truth 13 -> 22 calls,
    // 172.7 M -> 187.1 M worker instructions (the fourteenth session's
    // 186.5 M); strong drift, seeds 1-40, 296 -> 320 of 440.
    searcher.last_registered = Some(g1);
    // The drift prior's reach at the probed roads' distance.
    let between = (h.s[g0] - h.s[probed.target()]).max(0.0);
    let bounds = register::Bounds::of_drift(
        prior,
        config.drift_radius(),
        length,
        between,
        spatial,
        frame.step,
    );
    let placed = register::register(h, spatial, g0, g1, &bounds, prior)?;
    if placed.margin < REGISTER_MARGIN {
        return None;
    }
    let room = g1 - g0;
    let t_range = [placed.target.saturating_sub(room), placed.target + room];
    grow_seeded(
        h,
        frame,
        config,
        [g0, g1],
        [g0, g1],
        t_range,
        [placed.sim],
        Source::Network,
    )
    .filter(|f| emitted(f, config, frame.step))
}
