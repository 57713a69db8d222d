//! Which paths may overlap, before any pair is matched: an index of turn
//! triples shared by many paths.
//!
//! Each path is reduced to its turns ([`super::turns`]) and every three
//! nearby turns to what a similarity, the direction of travel and the side
//! of the plane leave of them: the three signed angles and the third apex
//! seen from the first two,
//!
//! ```text
//! z = (a2 - a1) / (a1 - a0)   (apexes as complex numbers)
//! key = (θ0, θ1, θ2, ln|z|, arg z)
//! ```
//!
//! Travelled the other way a triple reads `(-θ2, -θ1, -θ0)` with `1/z`;
//! seen from the other side of its plane `(-θ0, -θ1, -θ2)` with `conj z`.
//! Each key is quantised, entered under its neighbouring cells as well (so
//! that two readings of one triple meet across a cell boundary), and two
//! paths vote for each other with every triple of one found under the
//! other's cells. Matching every pair of `n` paths costs `n²/2` matches;
//! the index costs a hash lookup per triple, and only the pairs it ranks
//! high are matched.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use super::turns::Turn;

/// Width of a cell of turn angle and of `arg z` (radians): 30°. The
/// turn-pair proposals take two turns for one within 20° or 30 %
/// ([`super::turns::TurnConfig`]); with the neighbouring cell entered too,
/// readings within half a cell (15°) always meet and up to a cell and a
/// half (45°) may, so that one turn smoothed a little wider or narrower in
/// one path still finds itself.
pub const ANGLE_CELL: f64 = PI / 6.0;

/// Width of a cell of `ln|z|`: ln 1.5, one apex spacing read 50 % longer in
/// one path than in the other, the same tolerance in ratio as the angles'
/// in radians.
pub const RATIO_CELL: f64 = 0.405_465_108_108_164_4;

/// Triples whose apex spacings differ by more than this ratio are not
/// keys: the small spacing is then a wiggle of one turn (an S-bend split in
/// two), whose apexes move with the smoothing.
pub const MAX_SPACING_RATIO: f64 = 8.0;

/// Turns skipped at most between the members of a triple: one, so that a
/// turn near [`super::turns::TurnConfig::min_angle`] found in one path and
/// not in the other still leaves triples common to both.
const SKIP: usize = 1;

/// A quantised triple.
type Key = [i32; 5];

/// A quantised pair of consecutive turns' angles.
type PairKey = [i32; 2];

/// The invariant reading of turns `i < j < k` of `turns`, if a key.
fn reading(turns: &[Turn], [i, j, k]: [usize; 3]) -> Option<[f64; 5]> {
    let (a0, a1, a2) = (turns[i].apex, turns[j].apex, turns[k].apex);
    let (u, v) = (a1 - a0, a2 - a1);
    let (nu, nv) = (u.norm(), v.norm());
    if !(nu > 0.0 && nv > 0.0) || (nu / nv).ln().abs() > MAX_SPACING_RATIO.ln() {
        return None;
    }
    // z = v / u as complex numbers.
    let arg = (u.x * v.y - u.y * v.x).atan2(u.dot(&v));
    Some([
        turns[i].angle,
        turns[j].angle,
        turns[k].angle,
        (nv / nu).ln(),
        arg,
    ])
}

/// The same triple travelled the other way.
fn reversed(r: [f64; 5]) -> [f64; 5] {
    [-r[2], -r[1], -r[0], -r[3], -r[4]]
}

/// The same triple seen from the other side of its plane.
fn mirrored(r: [f64; 5]) -> [f64; 5] {
    [-r[0], -r[1], -r[2], r[3], -r[4]]
}

/// Cell coordinates of a reading and, per axis, the neighbouring cell on
/// the reading's side.
fn cells(r: [f64; 5]) -> (Key, Key) {
    let mut cell = [0i32; 5];
    let mut near = [0i32; 5];
    for (d, &x) in r.iter().enumerate() {
        let w = if d == 3 { RATIO_CELL } else { ANGLE_CELL };
        let f = x / w;
        cell[d] = f.floor() as i32;
        near[d] = if f - f.floor() < 0.5 {
            cell[d] - 1
        } else {
            cell[d] + 1
        };
    }
    // arg z wraps around the circle.
    let turn = (2.0 * PI / ANGLE_CELL).round() as i32;
    cell[4] = cell[4].rem_euclid(turn);
    near[4] = near[4].rem_euclid(turn);
    (cell, near)
}

/// Every triple of nearby turns of one path, as readings.
fn readings(turns: &[Turn]) -> Vec<[f64; 5]> {
    let mut out = Vec::new();
    for i in 0..turns.len() {
        for j in i + 1..=(i + 1 + SKIP).min(turns.len().saturating_sub(1)) {
            for k in j + 1..=(j + 1 + SKIP).min(turns.len().saturating_sub(1)) {
                if k - i > 2 + SKIP {
                    continue;
                }
                out.extend(reading(turns, [i, j, k]));
            }
        }
    }
    out
}

/// The cell of each angle of a pair and the neighbouring cell on its side.
fn pair_cells(a: f64, b: f64) -> [[i32; 2]; 2] {
    let cell = |x: f64| {
        let f = x / ANGLE_CELL;
        let c = f.floor() as i32;
        [c, if f - f.floor() < 0.5 { c - 1 } else { c + 1 }]
    };
    [cell(a), cell(b)]
}

/// Enters `p` under `key` once.
fn enter<K: std::hash::Hash + Eq>(table: &mut HashMap<K, Vec<u32>>, key: K, p: usize) {
    let ids = table.entry(key).or_default();
    if ids.last() != Some(&(p as u32)) {
        ids.push(p as u32);
    }
}

/// The turn triples of many paths.
#[derive(Debug, Default)]
pub struct TurnIndex {
    /// Per cell, the paths with a triple entered there (each once).
    table: HashMap<Key, Vec<u32>>,
    /// Per cell of two consecutive turns' angles, the paths with such a
    /// pair: what a path of fewer than three turns can be ranked by.
    pairs: HashMap<PairKey, Vec<u32>>,
    /// Per path, its triples' readings.
    readings: Vec<Vec<[f64; 5]>>,
    /// Per path, the angles of its consecutive turns.
    angles: Vec<Vec<[f64; 2]>>,
}

impl TurnIndex {
    /// The index of `paths`, each given by its turns in travel order.
    pub fn new(paths: &[Vec<Turn>]) -> Self {
        let mut index = TurnIndex::default();
        for (p, turns) in paths.iter().enumerate() {
            let rs = readings(turns);
            for r in &rs {
                let (cell, near) = cells(*r);
                // The cell and every mix of it with the neighbouring cells.
                for mask in 0u32..32 {
                    let mut key = cell;
                    for (d, k) in key.iter_mut().enumerate() {
                        if mask & (1 << d) != 0 {
                            *k = near[d];
                        }
                    }
                    enter(&mut index.table, key, p);
                }
            }
            let angles: Vec<[f64; 2]> =
                turns.windows(2).map(|w| [w[0].angle, w[1].angle]).collect();
            for &[a, b] in &angles {
                let [ca, cb] = pair_cells(a, b);
                for x in ca {
                    for y in cb {
                        enter(&mut index.pairs, [x, y], p);
                    }
                }
            }
            index.readings.push(rs);
            index.angles.push(angles);
        }
        index
    }

    /// Number of triples of path `p`.
    pub fn triples(&self, p: usize) -> usize {
        self.readings.get(p).map_or(0, Vec::len)
    }

    /// Per other path, the number of `p`'s triples found among its cells,
    /// in any direction of travel and from either side.
    pub fn votes(&self, p: usize) -> Vec<usize> {
        let keys =
            |r: [f64; 5]| [r, reversed(r), mirrored(r), mirrored(reversed(r))].map(|v| cells(v).0);
        count(
            &self.table,
            self.readings[p].iter().map(|&r| keys(r)),
            p,
            self.readings.len(),
        )
    }

    /// Per other path, the number of `p`'s pairs of consecutive turns
    /// found among its pairs: a weaker vote, for paths of few turns.
    pub fn pair_votes(&self, p: usize) -> Vec<usize> {
        let keys = |[a, b]: [f64; 2]| {
            let key = |x: f64, y: f64| [x, y].map(|v| (v / ANGLE_CELL).floor() as i32);
            // Travelled the other way: order reversed and signs flipped;
            // from the other side: signs flipped.
            [key(a, b), key(-b, -a), key(-a, -b), key(b, a)]
        };
        count(
            &self.pairs,
            self.angles[p].iter().map(|&r| keys(r)),
            p,
            self.angles.len(),
        )
    }
}

/// Per path, the number of query items (each given by its keys) with a
/// key under which that path is entered; `p` itself is not counted.
fn count<K: std::hash::Hash + Eq, const N: usize>(
    table: &HashMap<K, Vec<u32>>,
    items: impl Iterator<Item = [K; N]>,
    p: usize,
    n: usize,
) -> Vec<usize> {
    let mut votes = vec![0; n];
    let mut seen = HashSet::new();
    for keys in items {
        seen.clear();
        for key in &keys {
            if let Some(ids) = table.get(key) {
                seen.extend(ids.iter().copied().filter(|&q| q as usize != p));
            }
        }
        for &q in &seen {
            votes[q as usize] += 1;
        }
    }
    votes
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    fn turn(angle: f64, x: f64, y: f64) -> Turn {
        Turn {
            angle,
            apex: Vector2::new(x, y),
            grid: 0.0,
            span: [0.0, 0.0],
        }
    }

    fn city() -> Vec<Turn> {
        vec![
            turn(1.5, 0.0, 0.0),
            turn(-1.2, 3.0, 1.0),
            turn(0.8, 4.0, 5.0),
            turn(1.9, 9.0, 4.0),
            turn(-0.6, 10.0, 12.0),
        ]
    }

    /// The same turns under a similarity, reversed, or seen from below.
    fn moved(turns: &[Turn], scale: f64, angle: f64, reverse: bool, mirror: bool) -> Vec<Turn> {
        let (c, s) = (angle.cos(), angle.sin());
        let m = if mirror { -1.0 } else { 1.0 };
        let mut out: Vec<Turn> = turns
            .iter()
            .map(|t| {
                let (x, y) = (t.apex.x, m * t.apex.y);
                turn(
                    if reverse { -m * t.angle } else { m * t.angle },
                    scale * (c * x - s * y) + 7.0,
                    scale * (s * x + c * y) - 3.0,
                )
            })
            .collect();
        if reverse {
            out.reverse();
        }
        out
    }

    #[test]
    fn a_path_under_any_similarity_direction_and_side_finds_itself() {
        let a = city();
        for (reverse, mirror) in [(false, false), (true, false), (false, true), (true, true)] {
            let b = moved(&a, 37.0, 2.1, reverse, mirror);
            let stranger = vec![
                turn(0.6, 0.0, 0.0),
                turn(0.6, 1.0, 0.0),
                turn(0.6, 1.0, 1.0),
                turn(0.6, 0.0, 1.0),
            ];
            let index = TurnIndex::new(&[a.clone(), b, stranger]);
            let votes = index.votes(0);
            assert_eq!(votes[1], index.triples(0), "{reverse} {mirror}");
            assert_eq!(votes[2], 0);
        }
    }
}
