//! A finished submap's occupancy as bytes: the grid scan matching reads.
//!
//! Cell values are `round(255 p)` for a cell of occupancy probability `p`, and 0 for a
//! cell nothing was seen in: a scan point over unknown space earns nothing. Scores summed
//! as integers are exact, so branch and bound and an exhaustive search agree to the bit.

use crate::grid::OccupancyGrid;

/// Occupancy probabilities in bytes over a rectangle of a submap's frame; cell `(i, j)`
/// covers `[ox + i r, ox + (i+1) r) × [oy + j r, oy + (j+1) r)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbabilityGrid {
    resolution: f64,
    origin: [f64; 2],
    width: usize,
    height: usize,
    cells: Vec<u8>,
}

/// The largest cell value: probability 1.
pub const FULL: u32 = 255;

/// Cells to sum (a scan cast to cells at one heading), with their bounding box.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Cast {
    cells: Vec<(i32, i32)>,
    /// Smallest `i` and `j`, then largest (empty: `i32::MAX`, then `i32::MIN`).
    bounds: [i32; 4],
}

impl Cast {
    /// `cells` and their bounding box.
    pub(crate) fn new(cells: Vec<(i32, i32)>) -> Self {
        let bounds = cells.iter().fold(
            [i32::MAX, i32::MAX, i32::MIN, i32::MIN],
            |[a, b, c, d], &(i, j)| [a.min(i), b.min(j), c.max(i), d.max(j)],
        );
        Self { cells, bounds }
    }
}

/// `Σ v(c + offset + (pad, pad))` over the cells `c` of `cast`, `v` the row-major
/// `values` of a `width × height` lattice and 0 outside it. When the shifted bounding box
/// lies inside, the cells are read without testing each.
#[inline]
pub(crate) fn sum_over(
    values: &[u8],
    width: usize,
    height: usize,
    pad: i64,
    cast: &Cast,
    offset: (i32, i32),
) -> u32 {
    let (di, dj) = (i64::from(offset.0) + pad, i64::from(offset.1) + pad);
    let [i0, j0, i1, j1] = cast.bounds.map(i64::from);
    let inside = |i: i64, j: i64| (0..width as i64).contains(&i) && (0..height as i64).contains(&j);
    if inside(i0 + di, j0 + dj) && inside(i1 + di, j1 + dj) {
        (cast.cells.iter())
            .map(|&(i, j)| {
                let (a, b) = ((i64::from(i) + di) as usize, (i64::from(j) + dj) as usize);
                u32::from(values[b * width + a])
            })
            .sum()
    } else {
        (cast.cells.iter())
            .map(|&(i, j)| {
                let (a, b) = (i64::from(i) + di, i64::from(j) + dj);
                if inside(a, b) {
                    u32::from(values[b as usize * width + a as usize])
                } else {
                    0
                }
            })
            .sum()
    }
}

impl ProbabilityGrid {
    /// The cells of `grid` (percent, −1 unknown), cropped to the smallest rectangle that
    /// holds every cell of at least `keep_from` percent (0: every known cell; empty when
    /// there is none). Cells cropped away read as 0 like unknown ones.
    pub fn from_occupancy(grid: &OccupancyGrid, keep_from: i8) -> Self {
        let keep_from = keep_from.max(0);
        let known = |i: usize, j: usize| grid.cells[j * grid.width + i] >= keep_from;
        let rows: Vec<usize> = (0..grid.height)
            .filter(|&j| (0..grid.width).any(|i| known(i, j)))
            .collect();
        let columns: Vec<usize> = (0..grid.width)
            .filter(|&i| rows.iter().any(|&j| known(i, j)))
            .collect();
        let (Some(&j0), Some(&j1), Some(&i0), Some(&i1)) =
            (rows.first(), rows.last(), columns.first(), columns.last())
        else {
            return Self {
                resolution: grid.resolution,
                origin: grid.origin,
                width: 0,
                height: 0,
                cells: Vec::new(),
            };
        };
        let (width, height) = (i1 - i0 + 1, j1 - j0 + 1);
        let mut cells = Vec::with_capacity(width * height);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let percent = grid.cells[j * grid.width + i];
                cells.push(if percent < 0 {
                    0
                } else {
                    (f64::from(percent.min(100)) * 2.55).round() as u8
                });
            }
        }
        Self {
            resolution: grid.resolution,
            origin: [
                grid.origin[0] + i0 as f64 * grid.resolution,
                grid.origin[1] + j0 as f64 * grid.resolution,
            ],
            width,
            height,
            cells,
        }
    }

    /// The grid over `width × height` cells of side `resolution` from `origin` with the
    /// values `cells` (row-major from the lower left; `width · height` of them).
    pub(crate) fn from_cells(
        resolution: f64,
        origin: [f64; 2],
        width: usize,
        height: usize,
        cells: Vec<u8>,
    ) -> Self {
        debug_assert_eq!(cells.len(), width * height);
        Self {
            resolution,
            origin,
            width,
            height,
            cells,
        }
    }

    /// Side of a cell (m).
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Lower-left corner of cell (0, 0) (m).
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// Cells along x.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Cells along y.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Bytes the cells take.
    pub fn bytes(&self) -> usize {
        self.cells.len()
    }

    /// The cell holding point `(x, y)` (m).
    pub fn cell(&self, x: f64, y: f64) -> (i64, i64) {
        crate::grid::cell_of(self.origin, self.resolution, x, y)
    }

    /// `Σ get(c + offset)` over the cells `c` of `cast`.
    #[inline]
    pub(crate) fn sum(&self, cast: &Cast, offset: (i32, i32)) -> u32 {
        sum_over(&self.cells, self.width, self.height, 0, cast, offset)
    }

    /// Cell `(i, j)`'s value (0 outside the grid).
    #[inline]
    pub fn get(&self, i: i64, j: i64) -> u8 {
        if (0..self.width as i64).contains(&i) && (0..self.height as i64).contains(&j) {
            self.cells[j as usize * self.width + i as usize]
        } else {
            0
        }
    }

    /// The probability at cell `(i, j)` smoothed by the binomial kernel `[1 2 1]/4` each
    /// way (in [0, 1]).
    fn smoothed(&self, i: i64, j: i64) -> f64 {
        const W: [u32; 3] = [1, 2, 1];
        let mut sum = 0;
        for (b, wb) in W.iter().enumerate() {
            for (a, wa) in W.iter().enumerate() {
                sum += wa * wb * u32::from(self.get(i + a as i64 - 1, j + b as i64 - 1));
            }
        }
        f64::from(sum) / f64::from(16 * FULL)
    }

    /// The smoothed probability at point `(x, y)`, bilinear between cell centres, and its
    /// gradient (per m).
    pub(crate) fn interpolate(&self, x: f64, y: f64) -> (f64, [f64; 2]) {
        let u = (x - self.origin[0]) / self.resolution - 0.5;
        let v = (y - self.origin[1]) / self.resolution - 0.5;
        let (i, j) = (u.floor(), v.floor());
        let (fx, fy) = (u - i, v - j);
        let (i, j) = (i as i64, j as i64);
        let s00 = self.smoothed(i, j);
        let s10 = self.smoothed(i + 1, j);
        let s01 = self.smoothed(i, j + 1);
        let s11 = self.smoothed(i + 1, j + 1);
        let value = (1.0 - fy) * ((1.0 - fx) * s00 + fx * s10) + fy * ((1.0 - fx) * s01 + fx * s11);
        let dx = ((1.0 - fy) * (s10 - s00) + fy * (s11 - s01)) / self.resolution;
        let dy = ((1.0 - fx) * (s01 - s00) + fx * (s11 - s10)) / self.resolution;
        (value, [dx, dy])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cropping_keeps_the_known_cells_where_they_were() {
        let mut cells = vec![-1i8; 6 * 5];
        cells[2 * 6 + 1] = 100;
        cells[3 * 6 + 4] = 20;
        let grid = OccupancyGrid {
            resolution: 0.5,
            origin: [-1.0, 2.0],
            width: 6,
            height: 5,
            cells,
        };
        let only_hits = ProbabilityGrid::from_occupancy(&grid, 50);
        assert_eq!((only_hits.width(), only_hits.height()), (1, 1));
        let p = ProbabilityGrid::from_occupancy(&grid, 0);
        assert_eq!((p.width(), p.height()), (4, 2));
        assert_eq!(p.origin(), [-0.5, 3.0]);
        let (i, j) = p.cell(-0.25, 3.25);
        assert_eq!(p.get(i, j), 255);
        let (i, j) = p.cell(1.25, 3.75);
        assert_eq!(p.get(i, j), 51);
        assert_eq!(p.get(1, 0), 0, "unknown reads as zero");
        assert_eq!(p.get(-1, 0), 0, "outside reads as zero");
    }

    #[test]
    fn the_interpolated_gradient_matches_finite_differences() {
        let cells: Vec<i8> = (0..100).map(|k| ((k * 37) % 101) as i8).collect();
        let grid = OccupancyGrid {
            resolution: 0.1,
            origin: [0.0, 0.0],
            width: 10,
            height: 10,
            cells,
        };
        let p = ProbabilityGrid::from_occupancy(&grid, 0);
        let (x, y, h) = (0.437, 0.512, 1e-6);
        let (_, g) = p.interpolate(x, y);
        let gx = (p.interpolate(x + h, y).0 - p.interpolate(x - h, y).0) / (2.0 * h);
        let gy = (p.interpolate(x, y + h).0 - p.interpolate(x, y - h).0) / (2.0 * h);
        assert!((g[0] - gx).abs() < 1e-6 && (g[1] - gy).abs() < 1e-6);
    }
}
