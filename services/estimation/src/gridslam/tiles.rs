//! A particle's occupancy grid in copy-on-write tiles.
//!
//! The map frame is cut into square tiles of [`TILE`] × [`TILE`] cells. A grid holds a
//! dense index of shared tiles over the rectangle it has reached; cloning a grid (a
//! resampled copy of a particle) clones only the index, and a tile is copied the first time
//! one of the copies changes it (`Arc::make_mut`). Tiles nobody touched since two particles
//! parted stay shared, so N particles cost one map plus what each changed since they parted.
//!
//! As plain data (a filter's checkpoint), the tiles of many grids go into one table, each
//! shared tile once ([`TileTable`]), and each grid keeps its index as places in that
//! table ([`GridIndexState`]); restoring shares the tiles again as they were shared.

use crate::grid::{GridConfig, KeptBeam, OccupancyGrid, cell_of, trace_scan};
use crate::pose::Pose2;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::sync::Arc;

/// Cells along a tile's side.
pub const TILE: usize = 32;
const CELLS: usize = TILE * TILE;

/// One row of a tile's occupied cells: bit `i` for cell `i` of the row.
type Row = u32;
const _: () = assert!(TILE == Row::BITS as usize);

/// One tile: log-odds per cell, and per cell the number (mod 2¹⁶, from 1) of the last
/// scan that changed it, 0 for never; and per row which cells are occupied (log-odds
/// > 0), the part the scan likelihood reads, 128 bytes a tile instead of 4 KiB.
#[derive(Debug, Clone, PartialEq)]
struct Tile {
    occupied: [Row; TILE],
    log_odds: [f32; CELLS],
    stamp: [u16; CELLS],
}

impl Tile {
    fn unknown() -> Self {
        Self {
            occupied: [0; TILE],
            log_odds: [0.0; CELLS],
            stamp: [0; CELLS],
        }
    }

    /// Sets cell `local`'s log-odds and its occupied bit.
    fn set(&mut self, local: usize, log_odds: f32) {
        self.log_odds[local] = log_odds;
        let (row, bit) = (&mut self.occupied[local / TILE], 1 << (local % TILE));
        if log_odds > 0.0 {
            *row |= bit;
        } else {
            *row &= !bit;
        }
    }
}

/// Bytes of one tile.
pub const TILE_BYTES: usize = std::mem::size_of::<Tile>();

/// A log-odds occupancy grid of copy-on-write tiles; cell `(i, j)` covers
/// `[i·r, (i+1)·r) × [j·r, (j+1)·r)` of the map frame (`r` the resolution).
#[derive(Debug, Clone)]
pub struct TiledGrid {
    resolution: f64,
    /// Tile coordinates of the index's first entry.
    corner: (i64, i64),
    /// Tiles along x and y the index spans.
    span: (usize, usize),
    tiles: Vec<Option<Arc<Tile>>>,
    /// Scans integrated so far (mod 2¹⁶, skipping 0).
    scans: u16,
}

impl TiledGrid {
    /// An unknown grid of cells of side `resolution` (m).
    pub fn new(resolution: f64) -> Self {
        Self {
            resolution,
            corner: (0, 0),
            span: (0, 0),
            tiles: Vec::new(),
            scans: 0,
        }
    }

    /// Side of a cell (m).
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// The cell holding map point `(x, y)`.
    pub fn cell(&self, x: f64, y: f64) -> (i64, i64) {
        cell_of([0.0, 0.0], self.resolution, x, y)
    }

    fn slot(&self, ti: i64, tj: i64) -> Option<usize> {
        let (di, dj) = (ti - self.corner.0, tj - self.corner.1);
        let inside = (0..self.span.0 as i64).contains(&di) && (0..self.span.1 as i64).contains(&dj);
        inside.then(|| dj as usize * self.span.0 + di as usize)
    }

    fn split(i: i64, j: i64) -> ((i64, i64), usize) {
        let t = TILE as i64;
        let local = j.rem_euclid(t) as usize * TILE + i.rem_euclid(t) as usize;
        ((i.div_euclid(t), j.div_euclid(t)), local)
    }

    /// Log-odds of cell `(i, j)`; 0 (p = ½) where nothing was seen.
    pub fn log_odds(&self, i: i64, j: i64) -> f32 {
        let ((ti, tj), local) = Self::split(i, j);
        match self.slot(ti, tj).and_then(|s| self.tiles[s].as_ref()) {
            Some(tile) => tile.log_odds[local],
            None => 0.0,
        }
    }

    /// Whether cell `(i, j)` is occupied (log-odds > 0).
    fn occupied(&self, i: i64, j: i64) -> bool {
        let ((ti, tj), local) = Self::split(i, j);
        self.slot(ti, tj)
            .and_then(|s| self.tiles[s].as_ref())
            .is_some_and(|tile| tile.occupied[local / TILE] >> (local % TILE) & 1 == 1)
    }

    /// Calls `visit(i', j')` for every occupied cell (log-odds > 0) with
    /// `|i' − i| ≤ w` and `|j' − j| ≤ w`, row by row, `i'` rising within a row; one tile
    /// lookup and one word per row when the block lies in one tile.
    #[inline]
    pub fn occupied_near(&self, i: i64, j: i64, w: i64, mut visit: impl FnMut(i64, i64)) {
        let ((t0, local), (t1, _)) = (Self::split(i - w, j - w), Self::split(i + w, j + w));
        if t0 != t1 {
            for dj in -w..=w {
                for di in -w..=w {
                    if self.occupied(i + di, j + dj) {
                        visit(i + di, j + dj);
                    }
                }
            }
            return;
        }
        let Some(tile) = self.slot(t0.0, t0.1).and_then(|s| self.tiles[s].as_ref()) else {
            return;
        };
        let side = 2 * w as usize + 1;
        let mask: Row = (1 << side) - 1;
        let (first, row) = (local % TILE, local / TILE);
        for (dj, &bits) in tile.occupied[row..row + side].iter().enumerate() {
            let mut bits = bits >> first & mask;
            while bits != 0 {
                visit(i - w + i64::from(bits.trailing_zeros()), j - w + dj as i64);
                bits &= bits - 1;
            }
        }
    }

    /// Grows the index to hold cells `lo..=hi` (inclusive corners).
    fn cover(&mut self, lo: (i64, i64), hi: (i64, i64)) {
        let ((a0, b0), _) = Self::split(lo.0, lo.1);
        let ((a1, b1), _) = Self::split(hi.0, hi.1);
        let (c0, c1) = (
            self.corner,
            (
                self.corner.0 + self.span.0 as i64 - 1,
                self.corner.1 + self.span.1 as i64 - 1,
            ),
        );
        let empty = self.tiles.is_empty();
        if !empty && a0 >= c0.0 && b0 >= c0.1 && a1 <= c1.0 && b1 <= c1.1 {
            return;
        }
        let (n0, n1) = if empty {
            ((a0, b0), (a1, b1))
        } else {
            ((a0.min(c0.0), b0.min(c0.1)), (a1.max(c1.0), b1.max(c1.1)))
        };
        let span = ((n1.0 - n0.0 + 1) as usize, (n1.1 - n0.1 + 1) as usize);
        let mut tiles = vec![None; span.0 * span.1];
        for dj in 0..self.span.1 {
            for di in 0..self.span.0 {
                let (ti, tj) = (self.corner.0 + di as i64, self.corner.1 + dj as i64);
                let to = (tj - n0.1) as usize * span.0 + (ti - n0.0) as usize;
                tiles[to] = self.tiles[dj * self.span.0 + di].take();
            }
        }
        self.corner = n0;
        self.span = span;
        self.tiles = tiles;
    }

    /// Applies `delta` to cell `(i, j)` unless this scan already changed it; log-odds stay
    /// within `[l_min, l_max]`. The cell must be covered.
    fn update(&mut self, i: i64, j: i64, delta: f64, config: &GridConfig) {
        let ((ti, tj), local) = Self::split(i, j);
        let Some(slot) = self.slot(ti, tj) else {
            return;
        };
        let tile = Arc::make_mut(self.tiles[slot].get_or_insert_with(|| Arc::new(Tile::unknown())));
        if tile.stamp[local] != self.scans {
            tile.stamp[local] = self.scans;
            let l = f64::from(tile.log_odds[local]) + delta;
            tile.set(local, l.clamp(config.l_min, config.l_max) as f32);
        }
    }

    /// Integrates one scan's `beams` seen from `pose` with the inverse sensor model
    /// (`crate::grid`'s, each cell changed at most once per scan).
    pub fn integrate(&mut self, pose: &Pose2, beams: &[KeptBeam], config: &GridConfig) {
        self.scans = self.scans.checked_add(1).unwrap_or(1);
        let reach = beams
            .iter()
            .map(|b| f64::from(b.length))
            .fold(0.0, f64::max);
        let lo = self.cell(pose.x - reach, pose.y - reach);
        let hi = self.cell(pose.x + reach, pose.y + reach);
        self.cover(lo, hi);
        let resolution = self.resolution;
        let cell = |x: f64, y: f64| cell_of([0.0, 0.0], resolution, x, y);
        trace_scan(pose, beams, config, cell, |i, j, delta| {
            self.update(i, j, delta, config);
        });
    }

    /// Tiles this grid holds, each once, as addresses: equal addresses in two grids are
    /// one shared tile (for counting memory).
    pub fn tile_addresses(&self) -> impl Iterator<Item = usize> + '_ {
        self.tiles.iter().flatten().map(|t| Arc::as_ptr(t) as usize)
    }

    /// Bytes of the tile index (the part a copy does not share).
    pub fn index_bytes(&self) -> usize {
        self.tiles.capacity() * std::mem::size_of::<Option<Arc<Tile>>>()
    }

    /// The grid as occupancy percentages over the rectangle of its tiles (−1 unknown, else
    /// round(100 · p)); `None` before anything was integrated.
    pub fn occupancy(&self) -> Option<OccupancyGrid> {
        if self.tiles.iter().all(Option::is_none) {
            return None;
        }
        let (width, height) = (self.span.0 * TILE, self.span.1 * TILE);
        let (i0, j0) = (self.corner.0 * TILE as i64, self.corner.1 * TILE as i64);
        let mut cells = vec![-1i8; width * height];
        for (slot, tile) in self.tiles.iter().enumerate() {
            let Some(tile) = tile else { continue };
            let (di, dj) = (slot % self.span.0 * TILE, slot / self.span.0 * TILE);
            for local in 0..CELLS {
                if tile.stamp[local] != 0 {
                    let p = 1.0 - 1.0 / (1.0 + f64::from(tile.log_odds[local]).exp());
                    let k = (dj + local / TILE) * width + di + local % TILE;
                    cells[k] = (100.0 * p).round() as i8;
                }
            }
        }
        Some(OccupancyGrid {
            resolution: self.resolution,
            origin: [i0 as f64 * self.resolution, j0 as f64 * self.resolution],
            width,
            height,
            cells,
        })
    }
}

/// One tile as plain data: [`TILE`]² log-odds and scan numbers, row by row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TileState {
    /// Log-odds per cell.
    pub log_odds: Vec<f32>,
    /// Per cell, the number of the last scan that changed it (0 for never).
    pub stamp: Vec<u16>,
}

/// A grid's index as plain data: its tiles as places in a [`TileTable`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridIndexState {
    /// Side of a cell (m).
    pub resolution: f64,
    /// Tile coordinates of the index's first entry.
    pub corner: (i64, i64),
    /// Tiles along x and y the index spans.
    pub span: (u32, u32),
    /// Scans integrated so far (mod 2¹⁶, skipping 0).
    pub scans: u16,
    /// Per entry, row by row: 0 for a tile never written, else its place in the table + 1.
    pub tiles: Vec<u32>,
}

/// The tiles of many grids, each shared tile once (found by pointer identity).
#[derive(Debug, Default)]
pub struct TileTable {
    places: HashMap<usize, u32>,
    tiles: Vec<TileState>,
}

impl TileTable {
    /// `grid`'s index, its tiles added to the table unless they are in it already.
    pub fn add(&mut self, grid: &TiledGrid) -> GridIndexState {
        let tiles = (grid.tiles.iter())
            .map(|tile| {
                tile.as_ref().map_or(0, |tile| {
                    let next = self.tiles.len() as u32;
                    let place = *self
                        .places
                        .entry(Arc::as_ptr(tile) as usize)
                        .or_insert(next);
                    if place == next {
                        self.tiles.push(TileState {
                            log_odds: tile.log_odds.to_vec(),
                            stamp: tile.stamp.to_vec(),
                        });
                    }
                    place + 1
                })
            })
            .collect();
        GridIndexState {
            resolution: grid.resolution,
            corner: grid.corner,
            span: (grid.span.0 as u32, grid.span.1 as u32),
            scans: grid.scans,
            tiles,
        }
    }

    /// The distinct tiles, in the order the indices refer to them.
    pub fn into_tiles(self) -> Vec<TileState> {
        self.tiles
    }
}

/// The tiles of a [`TileTable`] in memory again, ready to be shared by the grids restored
/// from it.
#[derive(Debug)]
pub struct SharedTiles(Vec<Arc<Tile>>);

fn invalid(reason: String) -> Error {
    Error::InvalidInput {
        what: "grid state",
        reason,
    }
}

impl SharedTiles {
    /// The tiles of `table`.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a tile of another size or a log-odds that is not finite.
    pub fn restore(table: &[TileState]) -> Result<Self> {
        let tiles = (table.iter().enumerate())
            .map(|(k, t)| {
                let log_odds: [f32; CELLS] = (t.log_odds.as_slice().try_into())
                    .map_err(|_| invalid(format!("tile {k}: {} cells", t.log_odds.len())))?;
                let stamp: [u16; CELLS] = (t.stamp.as_slice().try_into())
                    .map_err(|_| invalid(format!("tile {k}: {} scan numbers", t.stamp.len())))?;
                if !log_odds.iter().all(|l| l.is_finite()) {
                    return Err(invalid(format!("tile {k}: a log-odds is not finite")));
                }
                let mut tile = Tile {
                    occupied: [0; TILE],
                    log_odds,
                    stamp,
                };
                for (local, &l) in log_odds.iter().enumerate() {
                    tile.set(local, l);
                }
                Ok(Arc::new(tile))
            })
            .collect::<Result<_>>()?;
        Ok(Self(tiles))
    }
}

impl TiledGrid {
    /// The grid `state` describes, sharing `tiles` (restored from the table its index
    /// refers to).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the index does not fit its span, refers to a tile the
    /// table does not hold, or the resolution is not positive.
    pub fn restore(state: &GridIndexState, tiles: &SharedTiles) -> Result<Self> {
        let span = (state.span.0 as usize, state.span.1 as usize);
        if span.0.checked_mul(span.1) != Some(state.tiles.len()) {
            return Err(invalid(format!(
                "an index of {} tiles spans {} × {}",
                state.tiles.len(),
                span.0,
                span.1
            )));
        }
        if !(state.resolution.is_finite() && state.resolution > 0.0) {
            return Err(invalid(format!("resolution {}", state.resolution)));
        }
        // Sized exactly, as the index it restores.
        let mut index = Vec::with_capacity(state.tiles.len());
        for &place in &state.tiles {
            index.push(match place.checked_sub(1) {
                None => None,
                Some(k) => Some(
                    (tiles.0.get(k as usize).cloned())
                        .ok_or_else(|| invalid(format!("tile {k} of {}", tiles.0.len())))?,
                ),
            });
        }
        Ok(Self {
            resolution: state.resolution,
            corner: state.corner,
            span,
            tiles: index,
            scans: state.scans,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::LogOddsGrid;

    fn beams() -> Vec<KeptBeam> {
        (0..90)
            .map(|k| KeptBeam {
                angle: (k as f32 * 4.0).to_radians(),
                length: 2.0 + (k % 7) as f32 * 0.9,
                hit: k % 5 != 0,
            })
            .collect()
    }

    #[test]
    fn occupied_near_visits_what_a_cell_by_cell_search_finds() {
        let config = GridConfig::default();
        let mut grid = TiledGrid::new(config.resolution);
        grid.integrate(&Pose2::new(1.0, -0.7, 0.3), &beams(), &config);
        let before = grid.clone();
        // Seen again from elsewhere: free beams clear some of the first scan's hits.
        for _ in 0..4 {
            grid.integrate(&Pose2::new(1.4, -0.2, 1.1), &beams(), &config);
        }
        let cleared = (-140..140)
            .flat_map(|j| (-140..140).map(move |i| (i, j)))
            .filter(|&(i, j)| before.log_odds(i, j) > 0.0 && grid.log_odds(i, j) <= 0.0)
            .count();
        assert!(cleared > 0, "no occupied cell was cleared");
        let (mut blocks, mut found) = (0, 0);
        // Every window around cells of a stretch that crosses tile borders both ways.
        for j in -140..140 {
            for i in -140..140 {
                for w in [1, 2] {
                    let mut visited = Vec::new();
                    grid.occupied_near(i, j, w, |a, b| visited.push((a, b)));
                    visited.sort_unstable();
                    let mut expected = Vec::new();
                    for b in j - w..=j + w {
                        for a in i - w..=i + w {
                            if grid.log_odds(a, b) > 0.0 {
                                expected.push((a, b));
                            }
                        }
                    }
                    expected.sort_unstable();
                    assert_eq!(visited, expected, "window {w} around ({i}, {j})");
                    blocks += 1;
                    found += usize::from(!expected.is_empty());
                }
            }
        }
        assert!(
            found > blocks / 100,
            "{found} of {blocks} windows hold a wall"
        );
    }

    #[test]
    fn matches_the_dense_grid_cell_for_cell() {
        let config = GridConfig::default();
        // Both lattices put cell (0, 0) at the origin, so cells round alike.
        let poses = [Pose2::new(10.3, 9.8, 0.1), Pose2::new(6.0, 13.0, 2.0)];
        let mut tiled = TiledGrid::new(config.resolution);
        let mut dense = LogOddsGrid::new(config.resolution, [0.0, 0.0], 400, 400);
        for pose in &poses {
            tiled.integrate(pose, &beams(), &config);
            dense.integrate(pose, &beams(), &config);
        }
        let (a, b) = (tiled.occupancy().unwrap(), dense.occupancy());
        let mut compared = 0;
        for j in 0..b.height {
            for i in 0..b.width {
                let x = b.origin[0] + (i as f64 + 0.5) * b.resolution;
                let y = b.origin[1] + (j as f64 + 0.5) * b.resolution;
                let ti = ((x - a.origin[0]) / a.resolution).floor() as usize;
                let tj = ((y - a.origin[1]) / a.resolution).floor() as usize;
                let tiled_cell = if ti < a.width && tj < a.height {
                    a.cells[tj * a.width + ti]
                } else {
                    -1
                };
                assert_eq!(tiled_cell, b.cells[j * b.width + i], "cell ({i}, {j})");
                compared += usize::from(tiled_cell != -1);
            }
        }
        assert!(compared > 1000, "{compared} known cells");
    }

    #[test]
    fn grids_restored_from_a_tile_table_share_what_they_shared() {
        let config = GridConfig::default();
        let mut first = TiledGrid::new(config.resolution);
        first.integrate(&Pose2::default(), &beams(), &config);
        let mut second = first.clone();
        second.integrate(&Pose2::new(3.0, 1.0, 0.5), &beams(), &config);
        let mut table = TileTable::default();
        let states = [table.add(&first), table.add(&second)];
        let distinct: std::collections::HashSet<usize> = first
            .tile_addresses()
            .chain(second.tile_addresses())
            .collect();
        let tiles = table.into_tiles();
        assert_eq!(tiles.len(), distinct.len(), "each shared tile once");
        assert!(tiles.len() < first.tile_addresses().count() + second.tile_addresses().count());
        let shared = SharedTiles::restore(&tiles).unwrap();
        let restored: Vec<TiledGrid> = (states.iter())
            .map(|s| TiledGrid::restore(s, &shared).unwrap())
            .collect();
        for (r, o) in restored.iter().zip([&first, &second]) {
            assert_eq!(r.occupancy(), o.occupancy());
            assert_eq!((r.corner, r.span, r.scans), (o.corner, o.span, o.scans));
            assert!(r.tiles == o.tiles, "the same cells, occupied bits included");
        }
        let again: std::collections::HashSet<usize> = (restored.iter())
            .flat_map(TiledGrid::tile_addresses)
            .collect();
        assert_eq!(again.len(), distinct.len(), "shared again as before");
        let mut broken = states[0].clone();
        broken.tiles[0] = tiles.len() as u32 + 1;
        assert!(TiledGrid::restore(&broken, &shared).is_err());
    }

    #[test]
    fn copies_share_tiles_until_one_changes_them() {
        let config = GridConfig::default();
        let mut first = TiledGrid::new(config.resolution);
        first.integrate(&Pose2::default(), &beams(), &config);
        let mut second = first.clone();
        let shared = |a: &TiledGrid, b: &TiledGrid| {
            let theirs: Vec<usize> = b.tile_addresses().collect();
            a.tile_addresses().filter(|t| theirs.contains(t)).count()
        };
        let all = first.tile_addresses().count();
        assert_eq!(shared(&first, &second), all);
        let far = [KeptBeam {
            angle: 0.0,
            length: 1.0,
            hit: true,
        }];
        second.integrate(&Pose2::new(5.0, 5.0, 0.0), &far, &config);
        let after = shared(&first, &second);
        assert!(
            after < all && after > all - 4,
            "{after} of {all} still shared"
        );
    }
}
