//! How well a scan fits a particle's grid: a likelihood field evaluated on the fly
//! (docs/ALGORITHMS.md §9).
//!
//! Every `stride`-th beam with a return ends at a point `e` of the map frame. Around the
//! cell of `e` the grid is searched `window` cells each way for occupied cells (positive
//! log-odds); `d` is the distance from `e` to the nearest one's centre. The beam's
//! likelihood is `z_hit · exp(−d² / 2σ²) + z_rand`, the second term standing for
//! everything the field does not explain (a spurious return, a wall not yet mapped, a
//! person walking by); with no occupied cell in the window only `z_rand` remains.
//! GMapping evaluates its grid the same way (a small search kernel instead of a
//! precomputed distance map), which keeps a particle's map cheap to change.
//!
//! A beam's term depends on `d²` alone, and the window bounds `d²`: [`ScanLikelihood`]
//! tabulates the term over that range once and reads it by linear interpolation (an
//! error below 10⁻⁸ per beam), instead of an `exp` and a `ln` per beam and evaluation.

use super::tiles::TiledGrid;
use crate::Result;
use crate::check::{positive, require};
use crate::moves::LocalTarget;
use crate::pose::{Pose2, wrap_angle};
use crate::scan::{Beam, RangeScan};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use serde::{Deserialize, Serialize};

/// Scan-to-map likelihood settings (`[map.matching]` of the service).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScanMatchConfig {
    /// Standard deviation of a beam's end point about the nearest occupied cell (m).
    /// Default 0.05: the range noise of an indoor lidar (1–3 cm) plus half a 5 cm cell.
    pub sigma: f64,
    /// Weight of the field term (dimensionless, in (0, 1)); `1 − z_hit` is `z_rand`.
    /// Default 0.9.
    pub z_hit: f64,
    /// Cells searched each way around a beam's end (count, ≥ 1). Default 1, GMapping's
    /// kernel.
    pub window: usize,
    /// Use every `stride`-th beam (count, ≥ 1). Default 4 (180 of 720 beams): neighbouring
    /// beams' errors are correlated through the grid, and fewer beams keep weights from
    /// collapsing on the first mismatch.
    pub stride: usize,
    /// Step of the finite differences for the information at the optimum: position (m).
    pub hessian_step_m: f64,
    /// … and heading (rad).
    pub hessian_step_rad: f64,
}

impl Default for ScanMatchConfig {
    fn default() -> Self {
        Self {
            sigma: 0.05,
            z_hit: 0.9,
            window: 1,
            stride: 4,
            hessian_step_m: 0.05,
            hessian_step_rad: 0.01,
        }
    }
}

/// Largest search window ([`ScanMatchConfig::window`]) accepted: the cost grows with its
/// square.
pub const MAX_WINDOW: usize = 8;

impl ScanMatchConfig {
    /// Checks the ranges.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        positive("map.matching.sigma", self.sigma)?;
        require(
            self.z_hit > 0.0 && self.z_hit < 1.0,
            "map.matching.z_hit",
            || format!("must lie in (0, 1), got {}", self.z_hit),
        )?;
        require(
            (1..=MAX_WINDOW).contains(&self.window),
            "map.matching.window",
            || format!("must lie in 1..={MAX_WINDOW}, got {}", self.window),
        )?;
        require(self.stride >= 1, "map.matching.stride", || {
            "must be >= 1".into()
        })?;
        positive("map.matching.hessian_step_m", self.hessian_step_m)?;
        positive("map.matching.hessian_step_rad", self.hessian_step_rad)
    }

    /// The end points of `scan`'s returns in the sensor frame (m): every `stride`-th
    /// beam that hit something.
    pub fn end_points(&self, scan: &RangeScan<'_>) -> Vec<[f64; 2]> {
        (0..scan.len())
            .step_by(self.stride)
            .filter_map(|i| match scan.beam(i) {
                Beam::Hit(r) => {
                    let a = scan.angle(i);
                    Some([r * a.cos(), r * a.sin()])
                }
                Beam::NoReturn | Beam::Invalid => None,
            })
            .collect()
    }

    /// A beam's log-likelihood `ln(z_hit · e^(−u) + z_rand)` at `u = d² / 2σ²`.
    fn beam(&self, u: f64) -> f64 {
        (self.z_hit * (-u).exp() + 1.0 - self.z_hit).ln()
    }
}

/// Table points per unit of `u = d² / 2σ²`: with `|∂²/∂u²| ≤ 1/4`, linear interpolation
/// errs by at most `1 / (32 · 1024²)`, 3·10⁻⁸ per beam.
const TABLE_PER_UNIT: f64 = 1024.0;

/// A [`ScanMatchConfig`]'s likelihood on grids of one resolution, its beam term
/// tabulated over the `u = d² / 2σ²` its window can give; see the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanLikelihood {
    config: ScanMatchConfig,
    resolution: f64,
    /// `ln(z_hit · e^(−u) + z_rand)` at `u = k / TABLE_PER_UNIT`.
    table: Vec<f64>,
}

impl ScanLikelihood {
    /// `config`'s likelihood on grids of cells of side `resolution` (m), whose window
    /// keeps every occupied cell's centre within `(window + 1) · resolution` of a beam's
    /// end on each axis.
    pub fn new(config: ScanMatchConfig, resolution: f64) -> Self {
        let reach = (config.window + 1) as f64 * resolution;
        let widest = 2.0 * reach * reach / (2.0 * config.sigma * config.sigma);
        let points = (widest * TABLE_PER_UNIT).ceil() as usize + 2;
        let table = (0..points)
            .map(|k| config.beam(k as f64 / TABLE_PER_UNIT))
            .collect();
        Self {
            config,
            resolution,
            table,
        }
    }

    /// The settings.
    pub fn config(&self) -> &ScanMatchConfig {
        &self.config
    }

    /// A beam's log-likelihood at `u = d² / 2σ²` from the table (exactly beyond it).
    #[inline]
    fn beam(&self, u: f64) -> f64 {
        let x = u * TABLE_PER_UNIT;
        if x < (self.table.len() - 1) as f64 {
            let k = x as usize;
            let (a, b) = (self.table[k], self.table[k + 1]);
            a + (x - k as f64) * (b - a)
        } else {
            self.config.beam(u)
        }
    }

    /// `log p(z | pose, grid)` of the scan's `points` (sensor frame) on `grid`, whose
    /// cells must have this likelihood's resolution.
    ///
    /// # Performance
    /// `points · (2 window + 1)²` cell reads.
    pub fn log_likelihood(&self, grid: &TiledGrid, pose: &Pose2, points: &[[f64; 2]]) -> f64 {
        debug_assert_eq!(grid.resolution(), self.resolution);
        let (s, c) = pose.theta.sin_cos();
        let w = self.config.window as i64;
        let r = grid.resolution();
        let inv = 0.5 / (self.config.sigma * self.config.sigma);
        // A point with no occupied cell in its window: `ln(z_hit · e^(−∞) + z_rand)`.
        let miss = (1.0 - self.config.z_hit).ln();
        points
            .iter()
            .map(|p| {
                let (ex, ey) = (pose.x + c * p[0] - s * p[1], pose.y + s * p[0] + c * p[1]);
                let (i, j) = grid.cell(ex, ey);
                let mut best = f64::INFINITY;
                grid.occupied_near(i, j, w, |ci, cj| {
                    let cx = (ci as f64 + 0.5) * r - ex;
                    let cy = (cj as f64 + 0.5) * r - ey;
                    best = best.min(cx * cx + cy * cy);
                });
                if best.is_finite() {
                    self.beam(best * inv)
                } else {
                    miss
                }
            })
            .sum()
    }
}

/// One particle's scan-matching target around its prediction `x̂`, for
/// [`crate::moves::Mover::laplace`]: offsets `o = x − x̂`, heading wrapped.
pub struct ScanTarget<'a> {
    /// The particle's map.
    pub grid: &'a TiledGrid,
    /// Its predicted pose `x̂`.
    pub predicted: Pose2,
    /// The scan's end points (sensor frame).
    pub points: &'a [[f64; 2]],
    /// The likelihood.
    pub likelihood: &'a ScanLikelihood,
}

impl ScanTarget<'_> {
    /// The pose at offset `o` from the prediction.
    pub fn pose(&self, o: &Vector3<f64>) -> Pose2 {
        Pose2::new(
            self.predicted.x + o[0],
            self.predicted.y + o[1],
            wrap_angle(self.predicted.theta + o[2]),
        )
    }
}

impl LocalTarget<3> for ScanTarget<'_> {
    fn log_likelihood(&self, offset: &Vector3<f64>) -> f64 {
        (self.likelihood).log_likelihood(self.grid, &self.pose(offset), self.points)
    }

    /// The negative Hessian of the log-likelihood by central differences (steps
    /// `hessian_step_m`, `hessian_step_rad`), its negative eigenvalues set to zero: the
    /// field is flat along a corridor and bumpy at the cell scale, and a direction the
    /// scan does not constrain must be left to the motion prior, not made up.
    fn information(&self, offset: &Vector3<f64>) -> Matrix3<f64> {
        let config = self.likelihood.config();
        let h = Vector3::new(
            config.hessian_step_m,
            config.hessian_step_m,
            config.hessian_step_rad,
        );
        let f = |d: Vector3<f64>| self.log_likelihood(&(offset + d));
        let unit = |k: usize| Vector3::from_fn(|r, _| if r == k { h[k] } else { 0.0 });
        let centre = f(Vector3::zeros());
        let mut hessian = Matrix3::zeros();
        for a in 0..3 {
            let (ea, ha) = (unit(a), h[a]);
            hessian[(a, a)] = (f(ea) - 2.0 * centre + f(-ea)) / (ha * ha);
            for b in a + 1..3 {
                let eb = unit(b);
                let mixed =
                    (f(ea + eb) - f(ea - eb) - f(eb - ea) + f(-ea - eb)) / (4.0 * ha * h[b]);
                hessian[(a, b)] = mixed;
                hessian[(b, a)] = mixed;
            }
        }
        let mut eigen = SymmetricEigen::new(-hessian);
        eigen
            .eigenvalues
            .iter_mut()
            .for_each(|l| *l = if l.is_finite() { l.max(0.0) } else { 0.0 });
        eigen.recompose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{GridConfig, KeptBeam};

    /// A grid that saw the walls of a 6 m × 4 m room with a notch from the origin.
    fn room() -> (TiledGrid, Vec<[f64; 2]>) {
        let config = GridConfig {
            resolution: 0.05,
            ..GridConfig::default()
        };
        let walls = room_points();
        let beams: Vec<KeptBeam> = walls
            .iter()
            .map(|p| KeptBeam {
                angle: p[1].atan2(p[0]) as f32,
                length: p[0].hypot(p[1]) as f32,
                hit: true,
            })
            .collect();
        let mut grid = TiledGrid::new(config.resolution);
        for _ in 0..3 {
            grid.integrate(&Pose2::default(), &beams, &config);
        }
        (grid, walls)
    }

    /// Points every 2.5 cm along the walls (a lidar's spacing at a few metres), off the
    /// cell boundaries.
    fn room_points() -> Vec<[f64; 2]> {
        let shift = 0.013;
        let mut points = Vec::new();
        for k in 0..=240 {
            let x = -3.0 + 0.025 * f64::from(k);
            points.push([x + shift, -2.0 + shift]);
            points.push([x + shift, if x > 1.0 { 1.5 } else { 2.0 } + shift]);
        }
        for k in 0..=160 {
            let y = -2.0 + 0.025 * f64::from(k);
            points.push([-3.0 + shift, y + shift]);
            points.push([3.0 + shift, y.min(1.5) + shift]);
        }
        points
    }

    fn likelihood() -> ScanLikelihood {
        ScanLikelihood::new(ScanMatchConfig::default(), 0.05)
    }

    #[test]
    fn the_table_reads_the_beam_term_within_its_bound() {
        for (window, sigma) in [(1, 0.05), (3, 0.02), (2, 0.2)] {
            let config = ScanMatchConfig {
                window,
                sigma,
                ..ScanMatchConfig::default()
            };
            let likelihood = ScanLikelihood::new(config.clone(), 0.05);
            let widest = 2.0 * ((window + 1) as f64 * 0.05).powi(2) / (2.0 * sigma * sigma);
            let mut worst: f64 = 0.0;
            for k in 0..=20_000 {
                // Past the table's end too, where the term is computed.
                let u = 1.2 * widest * f64::from(k) / 20_000.0 + 1e-7 * f64::from(k % 3);
                worst = worst.max((likelihood.beam(u) - config.beam(u)).abs());
            }
            assert!(worst < 3.1e-8, "window {window}, sigma {sigma}: {worst:e}");
            assert_eq!(likelihood.beam(0.0), config.beam(0.0));
        }
    }

    #[test]
    fn the_true_pose_scores_best_and_a_shift_scores_worse() {
        let (grid, points) = room();
        let likelihood = likelihood();
        let config = likelihood.config();
        let at = |x, y, t| likelihood.log_likelihood(&grid, &Pose2::new(x, y, t), &points);
        let truth = at(0.0, 0.0, 0.0);
        assert!(truth > at(0.1, 0.0, 0.0) + 10.0);
        assert!(truth > at(0.0, -0.1, 0.0) + 10.0);
        assert!(truth > at(0.0, 0.0, 0.03) + 10.0);
        let floor = points.len() as f64 * (1.0 - config.z_hit).ln();
        assert!(
            (at(50.0, 50.0, 0.0) - floor).abs() < 1e-9,
            "nothing mapped there"
        );
    }

    #[test]
    fn information_is_positive_semidefinite_and_largest_where_the_scan_constrains() {
        let (grid, points) = room();
        let likelihood = likelihood();
        let target = ScanTarget {
            grid: &grid,
            predicted: Pose2::default(),
            points: &points,
            likelihood: &likelihood,
        };
        let info = target.information(&Vector3::zeros());
        let eigen = SymmetricEigen::new(info);
        assert!(eigen.eigenvalues.iter().all(|&l| l >= 0.0), "{info}");
        assert!(info[(0, 0)] > 100.0 && info[(1, 1)] > 100.0, "{info}");
        // A scan of one straight wall says nothing about sliding along it.
        let wall: Vec<[f64; 2]> = (points.iter().copied())
            .filter(|p| p[1] < -1.9 && p[0].abs() < 2.5)
            .collect();
        let along = ScanTarget {
            points: &wall,
            ..target
        }
        .information(&Vector3::zeros());
        assert!(along[(0, 0)] < 0.05 * along[(1, 1)], "{along}");
    }
}
