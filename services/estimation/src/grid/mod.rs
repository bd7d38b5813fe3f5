//! Occupancy grid mapping from raw scans along the best particle's own trajectory.
//!
//! - [`LogOddsGrid`]: a log-odds grid with the inverse sensor model — every beam is ray
//!   traced from the sensor; cells it crosses get `l_free`, the cell where it ends gets
//!   `l_occupied` when it hit something; each cell changes at most once per scan
//!   (occupied wins over free), and log-odds stay within `[l_min, l_max]` (clamping keeps
//!   the map able to change its mind).
//! - [`GridMapper`]: keeps the scans taken at keyframes (the estimate moved
//!   `keyframe_distance` or turned `keyframe_angle` since the last one), and builds the
//!   grid of a particle from its [`Trail`] (its pose at each keyframe).
//!
//! Why a rebuild from a trail: the best particle changes from step to step, and each
//! particle has its own trajectory; a grid accumulated along "whatever was best at the
//! time" would mix trajectories and smear walls. The grid of one particle's history is
//! consistent with that particle's landmark map.
//!
//! # Performance
//! Integrating one keyframe costs O(B · L / resolution) for B beams of length L. A full
//! rebuild costs that times the K keyframes of the trail, plus O(cells). The mapper
//! caches the last grid with the trail it came from: when the new trail extends it (the
//! best particle descends from the previous one, the usual case), only the new keyframes
//! are integrated — the same result as a rebuild, since updates apply in keyframe order.
//! Memory: the kept beams (12 bytes each, K·B in all) and the grid (5 bytes a cell).

mod log_odds;

pub use log_odds::LogOddsGrid;
pub(crate) use log_odds::{cell_of, trace_scan};

use crate::Result;
use crate::check::{positive, require};
use crate::fastslam::Trail;
use crate::pose::Pose2;
use crate::scan::{Beam, RangeScan};
use serde::{Deserialize, Serialize};

/// Grid mapping settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridConfig {
    /// Side of a cell (m).
    pub resolution: f64,
    /// Log-odds added to the cell where a beam hit something (dimensionless; 0.85 ≈ p 0.7).
    pub l_occupied: f64,
    /// Log-odds added to a cell a beam crossed (dimensionless, < 0; −0.4 ≈ p 0.4).
    pub l_free: f64,
    /// Lower clamp of a cell's log-odds (dimensionless).
    pub l_min: f64,
    /// Upper clamp of a cell's log-odds (dimensionless).
    pub l_max: f64,
    /// A scan becomes a keyframe when the estimate moved this far since the last (m)…
    pub keyframe_distance: f64,
    /// …or turned this much (rad).
    pub keyframe_angle: f64,
    /// Beams are traced at most this far (m).
    pub max_range: f64,
    /// A beam without a return clears the cells along it up to the sensor's range (or
    /// `max_range`); off, such beams are ignored (safer for sensors that miss dark or
    /// glancing surfaces).
    pub clear_no_return: bool,
    /// Use every `beam_stride`-th beam (1 = all).
    pub beam_stride: usize,
    /// Room left around the keyframes' reach for the particles' spread (m).
    pub margin: f64,
}

impl Default for GridConfig {
    fn default() -> Self {
        Self {
            resolution: 0.1,
            l_occupied: 0.85,
            l_free: -0.4,
            l_min: -2.0,
            l_max: 3.5,
            keyframe_distance: 0.5,
            keyframe_angle: 15f64.to_radians(),
            max_range: 30.0,
            clear_no_return: true,
            beam_stride: 1,
            margin: 5.0,
        }
    }
}

impl GridConfig {
    /// The beams of `scan` a grid integrates: every `beam_stride`-th, cut at `max_range`
    /// (a hit beyond it becomes a free beam of that length), beams without a return kept
    /// as free beams only with `clear_no_return`, invalid ones left out.
    pub fn kept_beams(&self, scan: &RangeScan<'_>) -> Vec<KeptBeam> {
        let reach_limit = self.max_range.min(scan.range_max);
        (0..scan.len())
            .step_by(self.beam_stride)
            .filter_map(|i| {
                let (length, hit) = match scan.beam(i) {
                    Beam::Hit(r) if r <= reach_limit => (r, true),
                    Beam::Hit(_) => (reach_limit, false),
                    Beam::NoReturn if self.clear_no_return => (reach_limit, false),
                    Beam::NoReturn | Beam::Invalid => return None,
                };
                Some(KeptBeam {
                    angle: scan.angle(i) as f32,
                    length: length as f32,
                    hit,
                })
            })
            .collect()
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        positive("grid.resolution", self.resolution)?;
        positive("grid.l_occupied", self.l_occupied)?;
        positive("grid.l_max", self.l_max)?;
        require(
            self.l_free < 0.0 && self.l_free.is_finite(),
            "grid.l_free",
            || format!("must be finite and < 0, got {}", self.l_free),
        )?;
        require(
            self.l_min < 0.0 && self.l_min.is_finite(),
            "grid.l_min",
            || format!("must be finite and < 0, got {}", self.l_min),
        )?;
        positive("grid.keyframe_distance", self.keyframe_distance)?;
        positive("grid.keyframe_angle", self.keyframe_angle)?;
        positive("grid.max_range", self.max_range)?;
        require(self.beam_stride >= 1, "grid.beam_stride", || {
            "must be >= 1".into()
        })?;
        positive("grid.margin", self.margin)
    }
}

/// One beam kept for mapping: direction in the sensor frame (rad), length (m), and
/// whether it ended on an obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeptBeam {
    /// Direction (rad, sensor frame).
    pub angle: f32,
    /// Length to trace (m).
    pub length: f32,
    /// True when the beam ended on an obstacle.
    pub hit: bool,
}

/// An occupancy grid as published: cells −1 unknown, 0..100 occupancy in percent,
/// row-major from the cell whose lower-left corner is `origin`.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    /// Side of a cell (m).
    pub resolution: f64,
    /// Lower-left corner of cell (0, 0), map frame (m).
    pub origin: [f64; 2],
    /// Cells per row (along x).
    pub width: usize,
    /// Rows (along y).
    pub height: usize,
    /// `width · height` cells.
    pub cells: Vec<i8>,
}

/// Keyframe scans and the grid built from a particle's trail; see the module docs.
#[derive(Debug, Clone)]
pub struct GridMapper {
    config: GridConfig,
    keyframes: Vec<Vec<KeptBeam>>,
    last_keyframe: Option<Pose2>,
    /// min x, min y, max x, max y (m) the grid must cover.
    bounds: Option<[f64; 4]>,
    cache: Option<(Trail, LogOddsGrid)>,
}

/// Grid sides are multiples of this many cells, so the grid grows rarely.
const CHUNK_CELLS: f64 = 64.0;

impl GridMapper {
    /// A mapper with nothing kept yet.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] for a bad `config`.
    pub fn new(config: GridConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            keyframes: Vec::new(),
            last_keyframe: None,
            bounds: None,
            cache: None,
        })
    }

    /// The settings.
    pub fn config(&self) -> &GridConfig {
        &self.config
    }

    /// Number of keyframes kept.
    pub fn keyframes(&self) -> usize {
        self.keyframes.len()
    }

    /// Offers a scan taken when the filter's estimate was `estimate`. When it is a
    /// keyframe its beams are kept and its number returned: record every particle's
    /// pose under it ([`crate::fastslam::FastSlam::record_poses`]).
    pub fn offer(&mut self, scan: &RangeScan<'_>, estimate: Pose2) -> Option<u64> {
        if let Some(last) = self.last_keyframe {
            let moved = (estimate.x - last.x).hypot(estimate.y - last.y);
            let turned = crate::wrap_angle(estimate.theta - last.theta).abs();
            if moved < self.config.keyframe_distance && turned < self.config.keyframe_angle {
                return None;
            }
        }
        let beams = self.config.kept_beams(scan);
        let reach = beams
            .iter()
            .map(|b| f64::from(b.length))
            .fold(0.0, f64::max);
        let r = reach + self.config.margin;
        let b = [
            estimate.x - r,
            estimate.y - r,
            estimate.x + r,
            estimate.y + r,
        ];
        self.bounds = Some(match self.bounds {
            None => b,
            Some(o) => [
                o[0].min(b[0]),
                o[1].min(b[1]),
                o[2].max(b[2]),
                o[3].max(b[3]),
            ],
        });
        self.last_keyframe = Some(estimate);
        self.keyframes.push(beams);
        Some(self.keyframes.len() as u64 - 1)
    }

    /// The grid along `trail` (a particle's poses at keyframes): the cached grid extended
    /// by the new keyframes when `trail` extends the cached trail, otherwise a rebuild.
    /// `None` before the first keyframe. Poses at unknown keyframes are skipped.
    ///
    /// # Performance
    /// See the module documentation.
    pub fn grid(&mut self, trail: &Trail) -> Option<OccupancyGrid> {
        let bounds = self.bounds?;
        let step = CHUNK_CELLS * self.config.resolution;
        let lo = [
            (bounds[0] / step).floor() * step,
            (bounds[1] / step).floor() * step,
        ];
        let cells = |lo: f64, hi: f64| (((hi - lo) / step).ceil() * CHUNK_CELLS) as usize;
        let (width, height) = (cells(lo[0], bounds[2]), cells(lo[1], bounds[3]));
        let cached = self.cache.take();
        let (mut grid, todo) = match cached.and_then(|(t, g)| Some((g, trail.since(&t)?))) {
            Some((mut g, new)) => {
                g.cover(lo, width, height);
                (g, new)
            }
            None => {
                let mut all: Vec<(u64, Pose2)> = trail.iter().collect();
                all.reverse();
                let g = LogOddsGrid::new(self.config.resolution, lo, width, height);
                (g, all)
            }
        };
        for (keyframe, pose) in todo {
            if let Some(beams) = usize::try_from(keyframe)
                .ok()
                .and_then(|k| self.keyframes.get(k))
            {
                grid.integrate(&pose, beams, &self.config);
            }
        }
        let out = grid.occupancy();
        self.cache = Some((trail.clone(), grid));
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square room [−5, 5]² seen by a 360° scanner at `pose`.
    fn room_scan(pose: &Pose2) -> Vec<f32> {
        (0..720)
            .map(|i| {
                let a = pose.theta + i as f64 * std::f64::consts::TAU / 720.0;
                let (c, s) = (a.cos(), a.sin());
                let tx = if c > 0.0 {
                    (5.0 - pose.x) / c
                } else {
                    (-5.0 - pose.x) / c
                };
                let ty = if s > 0.0 {
                    (5.0 - pose.y) / s
                } else {
                    (-5.0 - pose.y) / s
                };
                tx.min(ty) as f32
            })
            .collect()
    }

    fn scan(ranges: &[f32]) -> RangeScan<'_> {
        RangeScan {
            angle_min: 0.0,
            angle_increment: std::f64::consts::TAU / 720.0,
            range_min: 0.1,
            range_max: 30.0,
            ranges,
        }
    }

    #[test]
    fn a_room_maps_to_occupied_walls_and_a_free_inside() {
        let mut mapper = GridMapper::new(GridConfig::default()).unwrap();
        let mut trail = Trail::default();
        for k in 0..6 {
            let pose = Pose2::new(-2.0 + 0.8 * k as f64, 0.3 * k as f64 - 1.0, 0.1 * k as f64);
            let ranges = room_scan(&pose);
            let key = mapper
                .offer(&scan(&ranges), pose)
                .expect("moved 0.8 m: a keyframe");
            trail.push(key, pose);
        }
        let grid = mapper.grid(&trail).unwrap();
        let at = |x: f64, y: f64| {
            let i = ((x - grid.origin[0]) / grid.resolution).floor() as usize;
            let j = ((y - grid.origin[1]) / grid.resolution).floor() as usize;
            grid.cells[j * grid.width + i]
        };
        assert!(at(0.0, 0.0) < 20, "inside is free: {}", at(0.0, 0.0));
        assert!(at(3.0, -2.0) < 20);
        for (x, y) in [(5.02, 0.0), (-4.98, 2.0), (1.0, 5.03), (-3.0, -4.97)] {
            assert!(at(x, y) > 65, "wall at ({x}, {y}): {}", at(x, y));
        }
        assert_eq!(at(7.0, 7.0), -1, "outside the room nothing was seen");
        assert!(grid.cells.iter().all(|&c| (-1..=100).contains(&c)));
    }

    #[test]
    fn extending_the_trail_gives_the_same_grid_as_a_rebuild() {
        let poses: Vec<Pose2> = (0..8)
            .map(|k| {
                Pose2::new(
                    -3.0 + 0.7 * k as f64,
                    0.5 * (k as f64).sin(),
                    0.2 * k as f64,
                )
            })
            .collect();
        let mut incremental = GridMapper::new(GridConfig::default()).unwrap();
        let mut trail = Trail::default();
        let mut last = None;
        for pose in &poses {
            let ranges = room_scan(pose);
            let key = incremental.offer(&scan(&ranges), *pose).unwrap();
            trail.push(key, *pose);
            last = incremental.grid(&trail);
        }
        let mut rebuilt = incremental.clone();
        rebuilt.cache = None;
        assert_eq!(rebuilt.grid(&trail), last);
        // A trail of other poses is not an extension: it is rebuilt, and differs.
        let mut other = Trail::default();
        for (k, pose) in poses.iter().enumerate() {
            other.push(k as u64, Pose2::new(pose.x + 0.5, pose.y, pose.theta));
        }
        assert_ne!(incremental.grid(&other), last);
    }

    #[test]
    fn small_moves_are_not_keyframes_and_bad_config_is_rejected() {
        let mut mapper = GridMapper::new(GridConfig::default()).unwrap();
        let ranges = room_scan(&Pose2::default());
        assert_eq!(mapper.offer(&scan(&ranges), Pose2::default()), Some(0));
        assert_eq!(
            mapper.offer(&scan(&ranges), Pose2::new(0.1, 0.0, 0.1)),
            None
        );
        assert_eq!(
            mapper.offer(&scan(&ranges), Pose2::new(0.6, 0.0, 0.0)),
            Some(1)
        );
        assert_eq!(mapper.keyframes(), 2);
        let bad = GridConfig {
            l_free: 0.4,
            ..GridConfig::default()
        };
        assert!(GridMapper::new(bad).is_err());
    }
}
