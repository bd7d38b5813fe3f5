//! The log-odds grid itself: cells, ray tracing (Bresenham) and the inverse sensor model.

use super::{GridConfig, KeptBeam, OccupancyGrid};
use crate::pose::Pose2;

/// A log-odds occupancy grid over an axis-aligned rectangle of the map frame.
#[derive(Debug, Clone, PartialEq)]
pub struct LogOddsGrid {
    resolution: f64,
    origin: [f64; 2],
    width: usize,
    height: usize,
    log_odds: Vec<f32>,
    /// Per cell: 0 never updated, else the number (from 1) of the last scan that updated it.
    stamp: Vec<u32>,
    scans: u32,
}

impl LogOddsGrid {
    /// An unknown grid of `width × height` cells of side `resolution` (m) whose cell
    /// (0, 0) has its lower-left corner at `origin` (m).
    pub fn new(resolution: f64, origin: [f64; 2], width: usize, height: usize) -> Self {
        Self {
            resolution,
            origin,
            width,
            height,
            log_odds: vec![0.0; width * height],
            stamp: vec![0; width * height],
            scans: 0,
        }
    }

    /// Re-allocates to cover `origin` with `width × height` cells, keeping every cell
    /// (the new rectangle must contain the old one on the same lattice; otherwise the
    /// cells that fall outside are lost).
    pub fn cover(&mut self, origin: [f64; 2], width: usize, height: usize) {
        if (origin, width, height) == (self.origin, self.width, self.height) {
            return;
        }
        let mut bigger = Self::new(self.resolution, origin, width, height);
        bigger.scans = self.scans;
        let di = ((self.origin[0] - origin[0]) / self.resolution).round() as i64;
        let dj = ((self.origin[1] - origin[1]) / self.resolution).round() as i64;
        for j in 0..self.height {
            for i in 0..self.width {
                if let Some(k) = bigger.index(i as i64 + di, j as i64 + dj) {
                    bigger.log_odds[k] = self.log_odds[j * self.width + i];
                    bigger.stamp[k] = self.stamp[j * self.width + i];
                }
            }
        }
        *self = bigger;
    }

    fn index(&self, i: i64, j: i64) -> Option<usize> {
        let inside = (0..self.width as i64).contains(&i) && (0..self.height as i64).contains(&j);
        inside.then(|| j as usize * self.width + i as usize)
    }

    /// Applies `delta` to cell (i, j) unless this scan already changed it.
    fn update(&mut self, i: i64, j: i64, delta: f64, config: &GridConfig) {
        if let Some(k) = self.index(i, j)
            && self.stamp[k] != self.scans
        {
            self.stamp[k] = self.scans;
            let l = f64::from(self.log_odds[k]) + delta;
            self.log_odds[k] = l.clamp(config.l_min, config.l_max) as f32;
        }
    }

    /// Integrates one scan's `beams` seen from `pose` ([`trace_scan`]).
    pub fn integrate(&mut self, pose: &Pose2, beams: &[KeptBeam], config: &GridConfig) {
        self.scans += 1;
        let (origin, resolution) = (self.origin, self.resolution);
        let cell_of = |x: f64, y: f64| cell_of(origin, resolution, x, y);
        trace_scan(pose, beams, config, cell_of, |i, j, delta| {
            self.update(i, j, delta, config);
        });
    }

    /// The grid as occupancy percentages: −1 for cells never updated, else
    /// round(100 · p) with p = 1 − 1/(1 + e^l).
    pub fn occupancy(&self) -> OccupancyGrid {
        let cells = self
            .log_odds
            .iter()
            .zip(&self.stamp)
            .map(|(&l, &s)| {
                if s == 0 {
                    -1
                } else {
                    let p = 1.0 - 1.0 / (1.0 + f64::from(l).exp());
                    (100.0 * p).round() as i8
                }
            })
            .collect();
        OccupancyGrid {
            resolution: self.resolution,
            origin: self.origin,
            width: self.width,
            height: self.height,
            cells,
        }
    }
}

/// The cell `(i, j)` holding map point `(x, y)` on the lattice of side `resolution` (m)
/// whose cell (0, 0) has its lower-left corner at `origin`.
#[inline]
pub(crate) fn cell_of(origin: [f64; 2], resolution: f64, x: f64, y: f64) -> (i64, i64) {
    (
        floor_i64((x - origin[0]) / resolution),
        floor_i64((y - origin[1]) / resolution),
    )
}

/// `v.floor() as i64` for every `v` (saturating, NaN to 0) without a call into libm: the
/// cast truncates toward zero, and a negative value with a fraction is one lower.
#[inline]
fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    t.saturating_sub(i64::from(t as f64 > v))
}

/// The inverse sensor model of one scan: calls `update(i, j, delta)` for the cells of
/// `beams` seen from `pose` (`cell_of` maps a point to its cell) — obstacle cells first
/// with `l_occupied`, then the cells along every beam with `l_free`, the end cell of a
/// hit left out. A grid that lets each cell change at most once per scan thus counts a
/// cell both hit and crossed as occupied.
pub(crate) fn trace_scan(
    pose: &Pose2,
    beams: &[KeptBeam],
    config: &GridConfig,
    cell_of: impl Fn(f64, f64) -> (i64, i64),
    mut update: impl FnMut(i64, i64, f64),
) {
    let start = cell_of(pose.x, pose.y);
    let ends: Vec<((i64, i64), bool)> = beams
        .iter()
        .map(|b| {
            let a = pose.theta + f64::from(b.angle);
            let l = f64::from(b.length);
            (cell_of(pose.x + l * a.cos(), pose.y + l * a.sin()), b.hit)
        })
        .collect();
    for &((i, j), hit) in &ends {
        if hit {
            update(i, j, config.l_occupied);
        }
    }
    for &(stop, hit) in &ends {
        bresenham(start, stop, |i, j| {
            if (i, j) != stop || !hit {
                update(i, j, config.l_free);
            }
        });
    }
}

/// Calls `visit` for every cell of the digital line from `from` to `to`, both included.
fn bresenham(from: (i64, i64), to: (i64, i64), mut visit: impl FnMut(i64, i64)) {
    let (mut x, mut y) = from;
    let (dx, dy) = ((to.0 - x).abs(), -(to.1 - y).abs());
    let (sx, sy) = ((to.0 - x).signum(), (to.1 - y).signum());
    let mut err = dx + dy;
    loop {
        visit(x, y);
        if (x, y) == to {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_i64_is_floor_cast_for_every_kind_of_value() {
        let big = 2f64.powi(63);
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            f64::EPSILON,
            -f64::EPSILON,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            big,
            -big,
            big * 2.0,
            -big * 2.0,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for k in -2000..2000 {
            let x = f64::from(k) * 0.37 + 1e-3 * f64::from(k % 7);
            values.extend([x, x.floor(), x.floor().next_down(), x.floor().next_up()]);
        }
        for v in values {
            assert_eq!(floor_i64(v), v.floor() as i64, "{v:e}");
        }
    }

    #[test]
    fn bresenham_visits_a_connected_line_between_the_ends() {
        let mut cells = Vec::new();
        bresenham((0, 0), (5, -2), |i, j| cells.push((i, j)));
        assert_eq!(cells.first(), Some(&(0, 0)));
        assert_eq!(cells.last(), Some(&(5, -2)));
        assert_eq!(cells.len(), 6);
        assert!(
            cells
                .windows(2)
                .all(|w| (w[1].0 - w[0].0).abs() <= 1 && (w[1].1 - w[0].1).abs() <= 1)
        );
        let mut one = Vec::new();
        bresenham((3, 3), (3, 3), |i, j| one.push((i, j)));
        assert_eq!(one, [(3, 3)]);
    }

    #[test]
    fn log_odds_are_clamped_and_a_hit_cell_is_not_also_cleared() {
        let config = GridConfig::default();
        let mut grid = LogOddsGrid::new(1.0, [0.0, 0.0], 10, 1);
        let beams = [
            KeptBeam {
                angle: 0.0,
                length: 5.2,
                hit: true,
            },
            KeptBeam {
                angle: 0.0,
                length: 5.7,
                hit: true,
            },
            KeptBeam {
                angle: 0.0,
                length: 7.9,
                hit: false,
            },
        ];
        for _ in 0..50 {
            grid.integrate(&Pose2::new(0.5, 0.5, 0.0), &beams, &config);
        }
        let cells = grid.occupancy().cells;
        let p_max = (100.0 * (1.0 - 1.0 / (1.0 + config.l_max.exp()))).round() as i8;
        let p_min = (100.0 * (1.0 - 1.0 / (1.0 + config.l_min.exp()))).round() as i8;
        assert_eq!(
            cells[5], p_max,
            "hit by one beam, crossed by two: occupied, clamped"
        );
        assert_eq!(cells[2], p_min, "crossed 50 times: free, clamped at l_min");
        assert_eq!(cells[9], -1, "beyond every beam: unknown");
    }

    #[test]
    fn cover_keeps_cells_in_place() {
        let config = GridConfig::default();
        let mut grid = LogOddsGrid::new(0.5, [0.0, 0.0], 4, 4);
        let beam = [KeptBeam {
            angle: 0.0,
            length: 1.0,
            hit: true,
        }];
        grid.integrate(&Pose2::new(0.25, 0.25, 0.0), &beam, &config);
        let before = grid.occupancy();
        grid.cover([-1.0, -2.0], 10, 10);
        let after = grid.occupancy();
        for j in 0..4 {
            for i in 0..4 {
                assert_eq!(after.cells[(j + 4) * 10 + i + 2], before.cells[j * 4 + i]);
            }
        }
        assert_eq!(after.cells.iter().filter(|&&c| c >= 0).count(), 3);
    }
}
