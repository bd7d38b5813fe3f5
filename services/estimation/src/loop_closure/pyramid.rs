//! The grids branch and bound reads: a submap's probabilities and their max-pooled
//! copies at `2^h` cells (Olson 2009; Hess et al. 2016).
//!
//! Level `h` holds at cell `c` the largest probability over the `2^h × 2^h` cells
//! `c + [0, 2^h)²` of level 0. A search node at level `h` stands for every translation
//! offset `d + [0, 2^h)²`; the sum of level `h` at the scan's cells shifted by `d` bounds
//! the score of each of them from above, since every point's term does. Level `h` is
//! padded by `2^h − 1` cells below and to the left so that blocks reaching into the grid
//! from outside keep their bound.

use super::probability::{Cast, ProbabilityGrid, sum_over};

/// One max-pooled level, padded by `pad` cells below and to the left.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MaxPooled {
    pad: i64,
    width: usize,
    height: usize,
    cells: Vec<u8>,
}

impl MaxPooled {
    /// Level 1 from the probabilities (level 0): each cell the largest of a 2 × 2 block.
    fn first(grid: &ProbabilityGrid) -> Self {
        Self::pooled(grid.width(), grid.height(), 1, |i, j| grid.get(i, j))
    }

    /// The next level from this one (`2^h` → `2^(h+1)` cells).
    fn coarser(&self) -> Self {
        Self::pooled(
            self.width - self.pad as usize,
            self.height - self.pad as usize,
            self.pad + 1,
            |i, j| self.get(i, j),
        )
    }

    /// The level whose cells are the largest of four of `finer`'s, `half` cells apart,
    /// over a `width × height` grid (level 0's size), padded by `2 half − 1`.
    fn pooled(width: usize, height: usize, half: i64, finer: impl Fn(i64, i64) -> u8) -> Self {
        let pad = 2 * half - 1;
        let width = width + pad as usize;
        let height = height + pad as usize;
        let mut cells = Vec::with_capacity(width * height);
        for j in -pad..height as i64 - pad {
            for i in -pad..width as i64 - pad {
                let m = finer(i, j)
                    .max(finer(i + half, j))
                    .max(finer(i, j + half))
                    .max(finer(i + half, j + half));
                cells.push(m);
            }
        }
        Self {
            pad,
            width,
            height,
            cells,
        }
    }

    /// The pooled value at cell `(i, j)` of the submap's lattice (0 outside).
    #[inline]
    pub(crate) fn get(&self, i: i64, j: i64) -> u8 {
        let (a, b) = (i + self.pad, j + self.pad);
        if a >= 0 && b >= 0 && (a as usize) < self.width && (b as usize) < self.height {
            self.cells[b as usize * self.width + a as usize]
        } else {
            0
        }
    }

    /// `Σ get(c + offset)` over the cells `c` of `cast`.
    #[inline]
    pub(crate) fn sum(&self, cast: &Cast, offset: (i32, i32)) -> u32 {
        sum_over(&self.cells, self.width, self.height, self.pad, cast, offset)
    }
}

/// A finished submap's grids for matching: its probabilities (level 0) and `depth − 1`
/// levels of max-pooled copies.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchGrid {
    probabilities: ProbabilityGrid,
    /// Levels 1, 2, ….
    levels: Vec<MaxPooled>,
}

impl MatchGrid {
    /// Precomputes the `depth` (≥ 1) levels of `probabilities`.
    ///
    /// # Performance
    /// Four reads per cell per level; memory about `depth` bytes per cell.
    pub fn new(probabilities: ProbabilityGrid, depth: usize) -> Self {
        let mut levels: Vec<MaxPooled> = Vec::with_capacity(depth.saturating_sub(1));
        for _ in 1..depth.max(1) {
            let next = match levels.last() {
                None => MaxPooled::first(&probabilities),
                Some(finer) => finer.coarser(),
            };
            levels.push(next);
        }
        Self {
            probabilities,
            levels,
        }
    }

    /// The probabilities.
    pub fn probabilities(&self) -> &ProbabilityGrid {
        &self.probabilities
    }

    /// Number of levels, level 0 included.
    pub fn depth(&self) -> usize {
        self.levels.len() + 1
    }

    /// `Σ level_h(c + offset)` over the cells `c` of `cast`.
    #[inline]
    pub(crate) fn sum(&self, h: usize, cast: &Cast, offset: (i32, i32)) -> u32 {
        match h.checked_sub(1) {
            None => self.probabilities.sum(cast, offset),
            Some(k) => self.levels[k].sum(cast, offset),
        }
    }

    /// Bytes the grids take.
    pub fn bytes(&self) -> usize {
        self.levels.iter().map(|l| l.cells.len()).sum::<usize>() + self.probabilities.bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::OccupancyGrid;

    #[test]
    fn each_level_is_the_maximum_over_its_block() {
        let (width, height) = (13, 9);
        let cells: Vec<i8> = (0..width * height)
            .map(|k| ((k * 53 + 7) % 101) as i8)
            .collect();
        let grid = ProbabilityGrid::from_occupancy(
            &OccupancyGrid {
                resolution: 0.05,
                origin: [0.0, 0.0],
                width,
                height,
                cells,
            },
            0,
        );
        let pyramid = MatchGrid::new(grid.clone(), 4);
        for h in 0..4 {
            let side = 1i64 << h;
            for j in -side - 2..height as i64 + 2 {
                for i in -side - 2..width as i64 + 2 {
                    let expected = (0..side)
                        .flat_map(|b| (0..side).map(move |a| (a, b)))
                        .map(|(a, b)| grid.get(i + a, j + b))
                        .max()
                        .unwrap();
                    let got = pyramid.sum(h, &Cast::new(vec![(i as i32, j as i32)]), (0, 0));
                    assert_eq!(got, u32::from(expected), "level {h} ({i}, {j})");
                    // The same cell among others, summed with the box inside or not.
                    let pair = Cast::new(vec![(i as i32, j as i32), (0, 0)]);
                    let both =
                        u32::from(expected) + pyramid.sum(h, &Cast::new(vec![(0, 0)]), (0, 0));
                    assert_eq!(pyramid.sum(h, &pair, (0, 0)), both, "level {h} ({i}, {j})");
                }
            }
        }
    }
}
