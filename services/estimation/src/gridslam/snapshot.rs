//! Grid FastSLAM's state as plain data, to write a checkpoint and to continue from one.
//!
//! A [`GridFilterState`] holds what the next keyframe depends on: the keyframe counter
//! (every random draw comes from a stream labelled by it, so seed + keyframes *is* the
//! random state), the odometry travelled since the last keyframe, each particle's
//! prediction, motion prior, spread and grid, and the weights as they were (bit for bit).
//! The grids' copy-on-write tiles go into one table, each shared tile once, so a state
//! costs the distinct tiles, not N grids; restoring shares them again.

use super::tiles::{GridIndexState, SharedTiles, TileState, TileTable, TiledGrid};
use super::{GridFastSlam, GridParticle};
use crate::moves::MoveStats;
use crate::pose::Pose2;
use crate::weights::Weights;
use crate::{Error, Result};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// Everything a [`GridFastSlam`] needs to continue exactly where it was (but its config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridFilterState {
    /// Keyframes used so far: labels the random streams of the next one.
    pub keyframes: u64,
    /// Odometry distance (m) and absolute turn (rad) since the last keyframe.
    pub travelled: (f64, f64),
    /// The scan matcher's counts so far: steps, proposed, accepted, evaluations.
    pub stats: [u64; 4],
    /// The normalised log-weights, in particle order.
    pub log_weights: Vec<f64>,
    /// The weights' log-normaliser.
    pub log_normaliser: f64,
    /// The distinct tiles of every particle's grid.
    pub tiles: Vec<TileState>,
    /// The particles, in filter order.
    pub particles: Vec<GridParticleState>,
}

/// One particle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridParticleState {
    /// The prediction `x̂`.
    pub predicted: Pose2,
    /// The motion prior's covariance `P`, row-major.
    pub covariance: [f64; 9],
    /// The pose's spread at the last keyframe, row-major.
    pub spread: [f64; 9],
    /// Its grid, as places in [`GridFilterState::tiles`].
    pub grid: GridIndexState,
}

fn row_major(m: &Matrix3<f64>) -> [f64; 9] {
    std::array::from_fn(|k| m[(k / 3, k % 3)])
}

fn invalid(reason: String) -> Error {
    Error::InvalidInput {
        what: "grid filter state",
        reason,
    }
}

impl GridFastSlam {
    /// The filter's state (see the module documentation for what it holds).
    ///
    /// # Performance
    /// O(N · index entries) and one copy of every distinct tile.
    pub fn state(&self) -> GridFilterState {
        let mut table = TileTable::default();
        let particles = (self.particles.iter())
            .map(|p| GridParticleState {
                predicted: p.predicted,
                covariance: row_major(&p.covariance),
                spread: row_major(&p.spread),
                grid: table.add(&p.grid),
            })
            .collect();
        let s = self.stats;
        GridFilterState {
            keyframes: self.keyframes,
            travelled: self.travelled,
            stats: [s.steps, s.proposed, s.accepted, s.evaluations],
            log_weights: self.weights.log_weights().to_vec(),
            log_normaliser: self.weights.log_normaliser(),
            tiles: table.into_tiles(),
            particles,
        }
    }

    /// Puts this filter (as [`GridFastSlam::new`] built it, with the same config) where
    /// `state` left one.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the state does not fit the filter (another particle
    /// count or resolution, a pose or matrix that is not finite, a broken tile index);
    /// [`Error::DegenerateWeights`] for unusable weights. The filter is then unchanged.
    pub fn restore(&mut self, state: &GridFilterState) -> Result<()> {
        let n = self.particles.len();
        if state.particles.len() != n || state.log_weights.len() != n {
            return Err(invalid(format!(
                "{} particles and {} weights, the config asks for {n}",
                state.particles.len(),
                state.log_weights.len()
            )));
        }
        let weights = Weights::restore(&state.log_weights, state.log_normaliser)?;
        let tiles = SharedTiles::restore(&state.tiles)?;
        let particles = (state.particles.iter().enumerate())
            .map(|(i, p)| {
                let matrices = p.covariance.iter().chain(&p.spread);
                if !(p.predicted.is_finite() && matrices.clone().all(|v| v.is_finite())) {
                    return Err(invalid(format!("particle {i}: not finite")));
                }
                if p.grid.resolution != self.grid.resolution {
                    return Err(invalid(format!(
                        "particle {i}: cells of {} m, the config's are {} m",
                        p.grid.resolution, self.grid.resolution
                    )));
                }
                Ok(GridParticle {
                    predicted: p.predicted,
                    covariance: Matrix3::from_row_slice(&p.covariance),
                    spread: Matrix3::from_row_slice(&p.spread),
                    grid: TiledGrid::restore(&p.grid, &tiles)?,
                })
            })
            .collect::<Result<_>>()?;
        let [steps, proposed, accepted, evaluations] = state.stats;
        self.particles = particles;
        self.weights = weights;
        self.keyframes = state.keyframes;
        self.travelled = state.travelled;
        self.stats = MoveStats {
            steps,
            proposed,
            accepted,
            evaluations,
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fastslam::FastSlamConfig;
    use crate::grid::GridConfig;
    use crate::gridslam::ScanMatchConfig;
    use crate::motion::Control;
    use crate::moves::MoveConfig;
    use crate::optimise::{OptimiserConfig, OptimiserKind};
    use crate::scan::RangeScan;

    fn filter() -> GridFastSlam {
        let config = FastSlamConfig {
            particles: 6,
            ..FastSlamConfig::default()
        };
        let optimiser = OptimiserConfig {
            kind: OptimiserKind::Hill,
            ..OptimiserConfig::default()
        };
        let grid = GridConfig {
            keyframe_distance: 0.2,
            ..GridConfig::default()
        };
        let (matcher, moves) = (ScanMatchConfig::default(), MoveConfig::default());
        GridFastSlam::new(config, grid, matcher, &optimiser, moves).unwrap()
    }

    /// A square room of side 8 m seen from `(x, 0)`, 180 beams.
    fn ranges(x: f64) -> Vec<f32> {
        (0..180)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 180.0;
                let (c, s) = (a.cos(), a.sin());
                let tx = if c.abs() > 1e-9 {
                    (4.0 * c.signum() - x) / c
                } else {
                    f64::MAX
                };
                let ty = if s.abs() > 1e-9 {
                    4.0 * s.signum() / s
                } else {
                    f64::MAX
                };
                tx.min(ty) as f32
            })
            .collect()
    }

    fn drive(slam: &mut GridFastSlam, steps: std::ops::Range<u32>) -> Vec<Pose2> {
        let control = Control {
            v: 0.5,
            ..Control::ZERO
        };
        steps
            .map(|k| {
                slam.predict(&control, 0.1).unwrap();
                let r = ranges(0.05 * f64::from(k));
                let scan = RangeScan {
                    angle_min: 0.0,
                    angle_increment: std::f64::consts::TAU / 180.0,
                    range_min: 0.1,
                    range_max: 20.0,
                    ranges: &r,
                };
                slam.observe(&scan).unwrap();
                slam.estimate().mean
            })
            .collect()
    }

    #[test]
    fn a_restored_filter_continues_bit_for_bit() {
        let mut whole = filter();
        let expected = drive(&mut whole, 0..40);
        // Cut where particles share tiles (after a resampling), halfway at the earliest.
        let mut first = filter();
        drive(&mut first, 0..20);
        let mut split = 20;
        let per_particle = |state: &GridFilterState| -> usize {
            (state.particles.iter())
                .map(|p| p.grid.tiles.iter().filter(|&&t| t > 0).count())
                .sum()
        };
        let mut state = first.state();
        while state.tiles.len() == per_particle(&state) && split < 39 {
            drive(&mut first, split..split + 1);
            split += 1;
            state = first.state();
        }
        assert!(state.keyframes > 3, "{} keyframes", state.keyframes);
        assert!(
            state.tiles.len() < per_particle(&state),
            "{} distinct tiles of {}",
            state.tiles.len(),
            per_particle(&state)
        );
        let mut resumed = filter();
        resumed.restore(&state).unwrap();
        assert_eq!(resumed.state(), state);
        assert_eq!(
            resumed.grid_bytes(),
            first.grid_bytes(),
            "tiles shared again"
        );
        assert_eq!(drive(&mut resumed, split..40), expected[split as usize..]);
        assert_eq!(resumed.state(), whole.state());
    }

    #[test]
    fn a_state_of_another_filter_is_refused() {
        let mut slam = filter();
        drive(&mut slam, 0..3);
        let mut state = slam.state();
        state.particles.pop();
        let err = filter().restore(&state).unwrap_err();
        assert!(err.to_string().contains("particles"), "{err}");
        let mut state = slam.state();
        state.particles[0].predicted.x = f64::NAN;
        assert!(filter().restore(&state).is_err());
    }
}
