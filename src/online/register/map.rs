//! The map samples a registration window may be placed on
//! ([`super::register`]), gridded for nearest-sample lookups: a window
//! point is on the map where a sample lies within the grid's radius.

use std::collections::HashMap;

use nalgebra::Vector2;

use super::floor_i32;
use crate::online::history::CellHash;

/// The map samples in reach of the window, with a grid for nearest lookups.
///
/// A window point is on the map within `radius` of a sample. The grid's
/// cells are twice that, so the samples within `radius` of a point lie in
/// the two-by-two block of cells about the corner nearest it: four probes of
/// the cell map, not nine. Each cell is a run of one array (no allocation
/// per cell).
pub(super) struct Map {
    /// Position, road direction, track sample.
    pub(super) samples: Vec<(Vector2<f64>, f64, u32)>,
    /// Each cell's run of `items`.
    grid: HashMap<(i32, i32), (u32, u32), CellHash>,
    /// Sample indices, cell by cell, in sample order within a cell.
    items: Vec<u32>,
    radius: f64,
    /// The earliest track sample held.
    pub(super) first: u32,
}

impl Map {
    /// The grid of `samples` for lookups within `radius`.
    pub(super) fn new(samples: Vec<(Vector2<f64>, f64, u32)>, radius: f64) -> Self {
        let mut map = Map {
            first: samples.iter().map(|s| s.2).min().unwrap_or(u32::MAX),
            samples,
            grid: HashMap::default(),
            items: Vec::new(),
            radius,
        };
        let mut keyed: Vec<((i32, i32), u32)> = (0..map.samples.len())
            .map(|j| (map.cell_of(&map.samples[j].0).0, j as u32))
            .collect();
        keyed.sort_unstable();
        for (i, (k, _)) in keyed.iter().enumerate() {
            map.grid.entry(*k).or_insert((i as u32, i as u32)).1 += 1;
        }
        map.items = keyed.into_iter().map(|(_, j)| j).collect();
        map
    }

    /// The cell of `p` (cells of twice the radius), and whether `p` lies in
    /// its upper half along x and along y.
    fn cell_of(&self, p: &Vector2<f64>) -> ((i32, i32), (bool, bool)) {
        let (x, y) = (p.x / (2.0 * self.radius), p.y / (2.0 * self.radius));
        let (kx, ky) = (floor_i32(x), floor_i32(y));
        ((kx, ky), (x - kx as f64 >= 0.5, y - ky as f64 >= 0.5))
    }

    /// The nearest sample within `radius` of `p`, with `block` the block of
    /// cells the last lookup probed: consecutive window points mostly fall
    /// in the same block, and its runs are then not looked up again (about
    /// half the lookups of a placement).
    pub(super) fn nearest(&self, p: &Vector2<f64>, block: &mut Block) -> Option<usize> {
        let ((kx, ky), (up_x, up_y)) = self.cell_of(p);
        let corner = (kx - 1 + up_x as i32, ky - 1 + up_y as i32);
        if block.corner != Some(corner) {
            let run = |c: (i32, i32)| self.grid.get(&c).copied().unwrap_or((0, 0));
            let (x0, y0) = corner;
            block.corner = Some(corner);
            block.runs = [
                run((x0, y0)),
                run((x0, y0 + 1)),
                run((x0 + 1, y0)),
                run((x0 + 1, y0 + 1)),
            ];
        }
        let mut best: Option<(f64, usize)> = None;
        for &(a, b) in &block.runs {
            for &j in &self.items[a as usize..b as usize] {
                let d2 = (self.samples[j as usize].0 - p).norm_squared();
                if best.is_none_or(|b| d2 < b.0) {
                    best = Some((d2, j as usize));
                }
            }
        }
        best.filter(|b| b.0 <= self.radius * self.radius)
            .map(|b| b.1)
    }
}

/// The two-by-two block of cells a lookup probed: its corner cell and the
/// cells' runs of [`Map::items`].
#[derive(Default)]
pub(super) struct Block {
    corner: Option<(i32, i32)>,
    runs: [(u32, u32); 4],
}
