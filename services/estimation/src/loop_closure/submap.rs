//! A submap: a few consecutive keyframes' scans in a local occupancy grid, in the frame of
//! its first keyframe.
//!
//! While active it is a log-odds grid (the inverse sensor model of `crate::grid`, with the
//! back-end's own log-odds) that grows in chunks of 64 cells to cover what its scans
//! reach. After `keyframes_per_submap` keyframes it is finished: the grid becomes bytes of
//! probability cropped to the cells seen ([`ProbabilityGrid`]) with its max-pooled levels
//! ([`MatchGrid`]), and the log-odds are dropped — a finished submap keeps nothing else.

use super::config::LoopClosureConfig;
use super::probability::ProbabilityGrid;
use super::pyramid::MatchGrid;
use crate::grid::{GridConfig, KeptBeam, LogOddsGrid};
use crate::pose::Pose2;

/// Grid sides grow by this many cells at a time, so the grid is re-allocated rarely.
const CHUNK: f64 = 64.0;

/// A finished submap keeps the rectangle around its cells of at least this occupancy
/// (percent): the cells some beam ended in. Free space beyond them, swept by long beams
/// without a return, would score a scan point little and cost memory.
const KEEP_FROM_PERCENT: i8 = 50;

/// A submap; see the module documentation.
#[derive(Debug, Clone)]
pub struct Submap {
    anchor: usize,
    keyframes: usize,
    state: State,
}

#[derive(Debug, Clone)]
enum State {
    /// Still taking keyframes: the grid and the rectangle it covers (min x, min y, max x,
    /// max y; m).
    Active(Option<(LogOddsGrid, [f64; 4])>),
    /// Finished: only its matching grids.
    Finished(MatchGrid),
}

impl Submap {
    /// An empty submap whose frame is keyframe `anchor`'s pose.
    pub(crate) fn new(anchor: usize) -> Self {
        Self {
            anchor,
            keyframes: 0,
            state: State::Active(None),
        }
    }

    /// The keyframe whose pose is the submap's frame (its first).
    pub fn anchor(&self) -> usize {
        self.anchor
    }

    /// Keyframes inserted.
    pub fn keyframes(&self) -> usize {
        self.keyframes
    }

    /// The matching grids once finished.
    pub fn grid(&self) -> Option<&MatchGrid> {
        match &self.state {
            State::Finished(grid) => Some(grid),
            State::Active(_) => None,
        }
    }

    /// Bytes the submap's grids take.
    pub fn bytes(&self) -> usize {
        match &self.state {
            State::Finished(grid) => grid.bytes(),
            // An `f32` log-odds and a `u32` stamp per cell.
            State::Active(grid) => grid.as_ref().map_or(0, |(_, b)| {
                let cells = ((b[2] - b[0]) * (b[3] - b[1])).max(0.0);
                8 * cells as usize
            }),
        }
    }

    /// Inserts a keyframe's `beams` (sensor frame) taken from the base pose `local` (in
    /// the submap's frame) with the sensor at `sensor` (base frame). Beams are cut at
    /// `max_range` (a hit beyond it becomes a free beam of that length). Does nothing once
    /// finished.
    pub(crate) fn insert(
        &mut self,
        local: &Pose2,
        sensor: &Pose2,
        beams: &[KeptBeam],
        config: &LoopClosureConfig,
    ) {
        let State::Active(slot) = &mut self.state else {
            return;
        };
        let at = local.compose(sensor);
        let reach = config.max_range as f32;
        let beams: Vec<KeptBeam> = beams
            .iter()
            .map(|b| {
                if b.length > reach {
                    KeptBeam {
                        length: reach,
                        hit: false,
                        ..*b
                    }
                } else {
                    *b
                }
            })
            .collect();
        let mut b = [at.x, at.y, at.x, at.y];
        for beam in &beams {
            let a = at.theta + f64::from(beam.angle);
            let l = f64::from(beam.length);
            let (x, y) = (at.x + l * a.cos(), at.y + l * a.sin());
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
        let r = config.resolution;
        let step = CHUNK * r;
        let cover = |b: [f64; 4]| {
            let lo = [(b[0] / step).floor() * step, (b[1] / step).floor() * step];
            let cells = |lo: f64, hi: f64| (((hi - lo) / step).floor() + 1.0) as usize;
            let (w, h) = (cells(lo[0], b[2]), cells(lo[1], b[3]));
            (lo, w * CHUNK as usize, h * CHUNK as usize)
        };
        match slot {
            Some((grid, bounds)) => {
                *bounds = [
                    bounds[0].min(b[0]),
                    bounds[1].min(b[1]),
                    bounds[2].max(b[2]),
                    bounds[3].max(b[3]),
                ];
                let (lo, w, h) = cover(*bounds);
                grid.cover(lo, w, h);
            }
            None => {
                let (lo, w, h) = cover(b);
                *slot = Some((LogOddsGrid::new(r, lo, w, h), b));
            }
        }
        let (grid, _) = slot.as_mut().expect("just made");
        grid.integrate(&at, &beams, &insertion(config));
        self.keyframes += 1;
    }

    /// Finishes the submap: its probabilities with `depth` max-pooled levels replace the
    /// log-odds. Does nothing when already finished.
    pub(crate) fn finish(&mut self, depth: usize, resolution: f64) {
        if let State::Active(slot) = &self.state {
            let probabilities = match slot {
                Some((grid, _)) => {
                    ProbabilityGrid::from_occupancy(&grid.occupancy(), KEEP_FROM_PERCENT)
                }
                None => ProbabilityGrid::from_occupancy(
                    &crate::grid::OccupancyGrid {
                        resolution,
                        origin: [0.0, 0.0],
                        width: 0,
                        height: 0,
                        cells: Vec::new(),
                    },
                    0,
                ),
            };
            self.state = State::Finished(MatchGrid::new(probabilities, depth));
        }
    }
}

/// The inverse sensor model of a submap as the grid module takes it.
fn insertion(config: &LoopClosureConfig) -> GridConfig {
    GridConfig {
        resolution: config.resolution,
        l_occupied: config.l_occupied,
        l_free: config.l_free,
        l_min: -config.l_clamp,
        l_max: config.l_clamp,
        max_range: config.max_range,
        ..GridConfig::default()
    }
}
