//! Proximity seeds for loops within one map: where the path comes back near
//! an earlier part of itself, in the map's own frame.
//!
//! On a map that is still consistent this finds most revisits, including
//! straight ones that carry no turn to match: the naive "nearest earlier
//! position" search a SLAM engineer would try first. turnprint must never do
//! worse than it, so its seeds go through the same verification as the
//! shape candidates (starting from the identity) and compete on score.

use super::PreparedPath;

/// A query grid range and the target grid index its middle is nearest to.
#[derive(Debug, Clone, Copy)]
pub struct ProximitySeed {
    /// Inclusive query grid range.
    pub query: [usize; 2],
    /// Nearest earlier-or-later grid index outside the neighbourhood.
    pub target: usize,
}

/// Probe points per window.
const PROBES: usize = 8;
/// A window revisits a place when its probes' median distance to the other
/// part is below this fraction of the window's length.
const NEAR_FRACTION: f64 = 0.25;

/// Seeds from windows of two consecutive segments.
pub fn proximity_seeds(path: &PreparedPath) -> Vec<ProximitySeed> {
    let track = &path.track;
    let sig = &path.signature;
    let stride = 2;
    let mut seeds = Vec::new();
    for w in path.bounds.windows(3) {
        let g0 = sig.grid[w[0]].floor() as usize;
        let g1 = (sig.grid[w[2]].ceil() as usize).min(track.len() - 1);
        if g1 <= g0 + PROBES {
            continue;
        }
        let length = track.s[g1] - track.s[g0];
        // Away from itself by at least its own length, along the path.
        let mut dists = Vec::with_capacity(PROBES);
        let mut targets = Vec::with_capacity(PROBES);
        for k in 0..PROBES {
            let g = g0 + (k * (g1 - g0)) / (PROBES - 1);
            let (p, s) = (track.xy[g], track.s[g]);
            let mut best = (f64::INFINITY, 0usize);
            let mut t = 0;
            while t < track.len() {
                if (track.s[t] - s).abs() > length {
                    let d = (track.xy[t] - p).norm_squared();
                    if d < best.0 {
                        best = (d, t);
                    }
                }
                t += stride;
            }
            dists.push(best.0.sqrt());
            targets.push(best.1);
        }
        let mut sorted = dists.clone();
        sorted.sort_by(f64::total_cmp);
        if sorted[PROBES / 2] < NEAR_FRACTION * length {
            targets.sort_unstable();
            seeds.push(ProximitySeed {
                query: [g0, g1],
                target: targets[PROBES / 2],
            });
        }
    }
    seeds
}
