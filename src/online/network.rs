//! When to place the newest stretch on the whole road network
//! ([`register`]) and what becomes of the placement: the detector's trigger
//! of the registration (a drifting map's revisit entered and left by other
//! roads), its gates, and the candidate grown from it.

use super::events::Source;
use super::gate::emitted;
use super::history::HistoryView;
use super::probe::Probed;
use super::register;
use super::search::{grow_seeded, Found, Frame, Searcher};
use super::OnlineConfig;

/// Probe periods of track samples the network registration places: about
/// 100 poses, 80 m, on KITTI, a junction's turn with the straights on both
/// sides of it (3 periods: one strong-drift event fewer of 44; 6: the same
/// events, more false candidates).
const REGISTER_PERIODS: usize = 4;
/// Least [`register::Registration::margin`] of a placement over its best
/// rival to be emitted alone. Below it the window fits two places about as
/// well, most often a straight slid along its road by a quarter of the
/// window or more ([`register::RIVAL_BANDS`]): the drift prior cannot tell
/// such places apart, so both are grown and emitted, and the verifier's
/// keyframes tell which one is right. 1.1: at 1.2 and 1.3 fewer
/// strong-drift events are found (320 and 290 of 440 against 338 at 1.1,
/// seeds 1-40), and with no margin at all the best place alone was wrong
/// in most strong-drift placements (279 of 320).
pub const REGISTER_MARGIN: f64 = 1.1;
/// Probe periods between two network registrations at least: a segment's
/// end and a periodic probe can come a few samples apart, and their windows
/// would be placed twice (the later one's candidates are dropped). (At
/// every probe: 22 strong-drift events of 44 instead of 21, the stream
/// within noise; every second period: 20.)
const REGISTER_EVERY: usize = 1;

/// Whether a registration of the window ending at track sample `g1` comes
/// too soon after the one at `last`, with probes every `probe_every`
/// samples (see `REGISTER_EVERY`). Decided when the matchings are settled
/// in stream order (`worker::Settle`), since with several workers the
/// previous matching may still be running elsewhere.
pub fn too_soon(last: Option<usize>, g1: usize, probe_every: usize) -> bool {
    last.is_some_and(|last| g1 < last + REGISTER_EVERY * probe_every)
}

/// The newest stretch registered onto the map's road network
/// ([`register`]), for a probe that found a road but no candidate (a
/// proximity candidate short of the cut aside; with the drifting map's
/// search on): verified from the registered place, and from its rival
/// when the margin is short of [`REGISTER_MARGIN`],
/// emitted as the drift probe's. `None` when no registration is due;
/// otherwise the window's newest sample (for [`too_soon`]) and what it
/// found.
pub fn register_newest(
    h: &HistoryView,
    searcher: &Searcher,
    frame: &Frame,
    probed: &Probed,
    config: &OnlineConfig,
) -> Option<(usize, Vec<Found>)> {
    let (Some(prior), Some(spatial)) = (&config.pipeline.drift_prior, &searcher.spatial) else {
        return None;
    };
    let g1 = probed.query()[1];
    let g0 = g1.checked_sub(REGISTER_PERIODS * config.probe_every)?;
    let length = h.s[g1] - h.s[g0];
    if config.drift_radius() <= 0.0 || length <= 0.0 {
        return None;
    }
    // Every window is placed, straight or turning: a straight slides along
    // its road, and its rival places along the road hold its margin near 1
    // (`register::RIVAL_BANDS`). A gate on the window's turning would save
    // registrations (KITTI 00's ground truth: 13 calls instead of 22, 8 %
    // of the worker's instructions) but loses strong-drift events (296
    // instead of 320 of 440, seeds 1-40).
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
    let Some(placed) = register::register(h, spatial, g0, g1, &bounds, prior) else {
        return Some((g1, Vec::new()));
    };
    let rival = placed.rival.filter(|_| placed.margin < REGISTER_MARGIN);
    let room = g1 - g0;
    let found = std::iter::once(placed.place)
        .chain(rival)
        .filter_map(|place| {
            let t_range = [place.target.saturating_sub(room), place.target + room];
            grow_seeded(
                h,
                frame,
                config,
                [g0, g1],
                [g0, g1],
                t_range,
                [place.sim],
                Source::Network,
            )
        })
        .filter(|f| emitted(f, config, frame.step))
        .collect();
    Some((g1, found))
}
