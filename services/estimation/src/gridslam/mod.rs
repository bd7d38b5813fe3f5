//! Grid FastSLAM (docs/ALGORITHMS.md §9): every particle carries a pose and its own
//! occupancy grid, and its proposal comes from matching the scan against that grid —
//! GMapping's filter (Grisetti, Stachniss & Burgard 2007), with the optimisers of
//! [`crate::optimise`] (or GMapping's hill climber, [`crate::optimise::HillClimb`]) as
//! the scan matcher.
//!
//! Per particle:
//! - **Prediction.** Odometry moves the particle's prediction `x̂` without noise and
//!   grows its motion prior `N(x̂, P)` by the controls' noise (`P ← F P Fᵀ + F_u Q F_uᵀ`).
//! - **Keyframes.** As in GMapping, a scan is used only when the odometry moved
//!   `keyframe_distance` or turned `keyframe_angle` since the last one used (`[grid]`);
//!   in between the estimate is the predicted cloud.
//! - **Proposal.** Without an optimiser (`none`) the pose is drawn from the motion prior
//!   and weighed by the scan's likelihood ([`likelihood`]). With one, the optimiser
//!   searches the particle's target `p(z | x, m) N(x; x̂, P)` and the pose is drawn from
//!   the defensive Laplace mixture around its optimum ([`crate::moves::local`]), weighed
//!   by `p(z | x, m) N(x; x̂, P) / q(x)`: an importance weight that is correct whatever the
//!   optimiser found.
//! - **Map.** The scan is integrated into the particle's grid at the drawn pose.
//! - **Resampling** when `N_eff < neff_ratio · N` (GMapping's adaptive rule with 0.5);
//!   copies share their grids' tiles ([`tiles`]).
//!
//! # Determinism
//! Particle `i` of keyframe `k` draws from its own stream `(seed, k, i, purpose)`, so the
//! particles run in parallel with the same numbers on any number of threads.

mod likelihood;
mod snapshot;
mod tiles;

pub use likelihood::{ScanLikelihood, ScanMatchConfig, ScanTarget};
pub use snapshot::{GridFilterState, GridParticleState};
pub use tiles::{GridIndexState, SharedTiles, TILE, TILE_BYTES, TileState, TileTable, TiledGrid};

use crate::fastslam::{FastSlamConfig, PoseEstimate};
use crate::grid::{GridConfig, OccupancyGrid};
use crate::motion::Control;
use crate::moves::{LocalTarget, MoveConfig, MoveStats, Mover};
use crate::optimise::OptimiserConfig;
use crate::pose::{Pose2, wrap_angle};
use crate::rng::{SimRng, Streams, seeded};
use crate::scan::RangeScan;
use crate::weights::Weights;
use crate::{Error, Result};
use nalgebra::{Matrix3, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use std::collections::HashSet;

/// Draws of the motion proposal.
const PURPOSE_MOTION: u64 = 0;
/// The optimiser's search and the draw from its proposal.
const PURPOSE_MATCH: u64 = 1;
/// Resampling.
const PURPOSE_RESAMPLE: u64 = 2;

/// One hypothesis: where the vehicle was at the last keyframe, where the odometry says it
/// is now, and the map it built.
#[derive(Debug, Clone)]
pub struct GridParticle {
    /// The prediction `x̂` (the pose at the last keyframe moved by the odometry since).
    pub predicted: Pose2,
    /// The motion prior's covariance `P` since the last keyframe.
    pub covariance: Matrix3<f64>,
    /// The covariance of the particle's pose given its past at the last keyframe: the
    /// Laplace covariance of its target there, `(I + P⁻¹)⁻¹` (zero before the first).
    /// The published estimate is the mixture of `N(x̂ᵢ, spreadᵢ + Pᵢ)`: the
    /// Rao-Blackwellised spread of the current pose, which does not collapse when
    /// resampling leaves copies of one particle.
    pub spread: Matrix3<f64>,
    /// The particle's map.
    pub grid: TiledGrid,
}

/// What one keyframe did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridStep {
    /// The scan was a keyframe (matched and mapped); otherwise only the estimate moved.
    pub keyframe: bool,
    /// `N_eff` after weighting (N when the scan was not a keyframe).
    pub ess: f64,
    /// The particles were resampled.
    pub resampled: bool,
    /// Distinct particles after the step (N when not resampled).
    pub distinct: usize,
}

/// Grid FastSLAM: particles with their own grids, scan matching as the proposal.
#[derive(Debug)]
pub struct GridFastSlam {
    filter: FastSlamConfig,
    grid: GridConfig,
    matcher: ScanLikelihood,
    mover: Option<Mover>,
    particles: Vec<GridParticle>,
    weights: Weights,
    keyframes: u64,
    /// Odometry distance (m) and absolute turn (rad) since the last keyframe.
    travelled: (f64, f64),
    stats: MoveStats,
    /// The laser's pose in the base frame; `None` when it sits at the origin.
    mount: Option<Pose2>,
}

impl GridFastSlam {
    /// `filter.particles` particles at the origin with empty grids; the motion model,
    /// seed, resampling rule and prior floor come from `filter`, the inverse sensor model
    /// and keyframe spacing from `grid`, the likelihood from `matcher`, and the scan
    /// matcher from `optimiser` (`none` = motion proposal only) with `moves`' candidate
    /// count, box, inflation and defensive weight.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for any invalid setting.
    pub fn new(
        filter: FastSlamConfig,
        grid: GridConfig,
        matcher: ScanMatchConfig,
        optimiser: &OptimiserConfig,
        moves: MoveConfig,
    ) -> Result<Self> {
        filter.validate()?;
        grid.validate()?;
        matcher.validate()?;
        let mover = Mover::new(optimiser, moves, &mut seeded(filter.seed))?;
        let particle = GridParticle {
            predicted: Pose2::default(),
            covariance: Matrix3::zeros(),
            spread: Matrix3::zeros(),
            grid: TiledGrid::new(grid.resolution),
        };
        let n = filter.particles;
        let resolution = grid.resolution;
        Ok(Self {
            particles: vec![particle; n],
            weights: Weights::from_log(&vec![0.0; n])?,
            filter,
            grid,
            matcher: ScanLikelihood::new(matcher, resolution),
            mover,
            keyframes: 0,
            travelled: (0.0, 0.0),
            stats: MoveStats::default(),
            mount: None,
        })
    }

    /// Places the laser at `mount` in the base frame (the particles' poses stay the
    /// base's): scan points are matched and rays traced from `pose ⊕ mount`.
    pub fn set_laser_mount(&mut self, mount: Pose2) {
        self.mount = (mount != Pose2::default()).then_some(mount);
    }

    /// The particles.
    pub fn particles(&self) -> &[GridParticle] {
        &self.particles
    }

    /// The particles' current normalised weights and `N_eff`.
    pub fn weights(&self) -> &Weights {
        &self.weights
    }

    /// Keyframes used so far.
    pub fn keyframes(&self) -> u64 {
        self.keyframes
    }

    /// What the scan matcher did so far (`None` without an optimiser).
    pub fn move_stats(&self) -> Option<MoveStats> {
        self.mover.as_ref().map(|_| self.stats)
    }

    /// Moves every particle's prediction by `control` over `dt` seconds and grows its
    /// motion prior.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a control that is not finite or `dt ≤ 0`.
    pub fn predict(&mut self, control: &Control, dt: f64) -> Result<()> {
        control.validate()?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::InvalidInput {
                what: "dt",
                reason: format!("must be finite and > 0, got {dt}"),
            });
        }
        let motion = &self.filter.motion;
        let before = self.particles[0].predicted;
        for p in &mut self.particles {
            let j = motion.jacobians(&p.predicted, control, dt);
            let noise = motion.pose_noise(&p.predicted, control, dt);
            p.covariance = j.wrt_pose * p.covariance * j.wrt_pose.transpose() + noise;
            p.predicted = motion.propagate(&p.predicted, control, dt);
        }
        let after = self.particles[0].predicted;
        self.travelled.0 += (after.x - before.x).hypot(after.y - before.y);
        self.travelled.1 += wrap_angle(after.theta - before.theta).abs();
        Ok(())
    }

    /// One scan: a keyframe when the odometry moved far enough since the last (always the
    /// first scan), then matched, weighed, mapped and perhaps resampled.
    ///
    /// # Errors
    /// [`Error::DegenerateWeights`] when no particle's weight is finite, and the
    /// optimiser's errors; the filter is then unchanged.
    pub fn observe(&mut self, scan: &RangeScan<'_>) -> Result<GridStep> {
        let due = self.keyframes == 0
            || self.travelled.0 >= self.grid.keyframe_distance
            || self.travelled.1 >= self.grid.keyframe_angle;
        if !due {
            return Ok(GridStep {
                keyframe: false,
                ess: self.filter.particles as f64,
                resampled: false,
                distinct: self.filter.particles,
            });
        }
        let beams = self.grid.kept_beams(scan);
        let mut points = self.matcher.config().end_points(scan);
        if let Some(m) = &self.mount {
            for p in &mut points {
                *p = m.transform_point(*p);
            }
        }
        let mount = self.mount;
        let streams = Streams::new(self.filter.seed, &[self.keyframes]);
        let floor = &self.filter.prior_floor;
        let floor = Matrix3::from_diagonal(&Vector3::new(
            floor.position.powi(2),
            floor.position.powi(2),
            floor.heading.powi(2),
        ));
        let first = self.keyframes == 0;
        let (matcher, mover) = (&self.matcher, self.mover.as_ref());
        let drawn: Vec<Result<Drawn>> = (self.particles.par_iter())
            .enumerate()
            .map(|(i, p)| {
                if first {
                    return Ok(Drawn {
                        pose: p.predicted,
                        log_weight: 0.0,
                        spread: Matrix3::zeros(),
                        stats: MoveStats::default(),
                    });
                }
                let covariance = p.covariance + floor;
                let target = ScanTarget {
                    grid: &p.grid,
                    predicted: p.predicted,
                    points: &points,
                    likelihood: matcher,
                };
                let Some(mover) = mover else {
                    let mut rng = streams.stream(&[i as u64, PURPOSE_MOTION]);
                    let o = draw_gaussian(&covariance, &mut rng)?;
                    let information = target.information(&o) + inverse(&covariance)?;
                    return Ok(Drawn {
                        pose: target.pose(&o),
                        log_weight: target.log_likelihood(&o),
                        spread: inverse(&information)?,
                        stats: MoveStats::default(),
                    });
                };
                let mut rng = streams.stream(&[i as u64, PURPOSE_MATCH]);
                let laplace = mover.laplace(&target, &covariance, &[], &mut rng)?;
                let (o, correction) = laplace.draw(&mut rng);
                Ok(Drawn {
                    pose: target.pose(&o),
                    log_weight: target.log_likelihood(&o) + correction,
                    spread: *laplace.covariance(),
                    stats: MoveStats {
                        steps: 0,
                        proposed: 1,
                        accepted: 1,
                        evaluations: laplace.evaluations + 1,
                    },
                })
            })
            .collect();
        let drawn: Vec<Drawn> = drawn.into_iter().collect::<Result<_>>()?;
        let log_weights: Vec<f64> = (self.weights.log_weights().iter())
            .zip(&drawn)
            .map(|(w, d)| w + d.log_weight)
            .collect();
        let weights = Weights::from_log(&log_weights)?;
        let ess = weights.ess();
        let grid = &self.grid;
        (self.particles.par_iter_mut())
            .zip(&drawn)
            .for_each(|(p, d)| {
                p.predicted = d.pose;
                p.covariance = Matrix3::zeros();
                p.spread = d.spread;
                let origin = mount.map_or(d.pose, |m| d.pose.compose(&m));
                p.grid.integrate(&origin, &beams, grid);
            });
        if mover.is_some() && !first {
            self.stats.steps += 1;
        }
        for d in &drawn {
            self.stats += d.stats;
        }
        let resampled = self.filter.resampling.due(&weights);
        self.weights = weights;
        let mut distinct = self.particles.len();
        if resampled {
            let mut rng = streams.stream(&[0, PURPOSE_RESAMPLE]);
            let drawn = self.filter.resampling.draw(&self.weights, &mut rng);
            distinct = drawn.distinct();
            self.particles = (drawn.ancestors.iter())
                .map(|&a| self.particles[a].clone())
                .collect();
            self.weights = Weights::from_log(&drawn.log_weights)?;
        }
        self.keyframes += 1;
        self.travelled = (0.0, 0.0);
        Ok(GridStep {
            keyframe: true,
            ess,
            resampled,
            distinct,
        })
    }

    /// The weighted estimate of the predictions, each with its spread and motion prior (a
    /// Gaussian mixture): between keyframes the uncertainty grows with the odometry.
    pub fn estimate(&self) -> PoseEstimate {
        PoseEstimate::from_mixture(
            (self.particles.iter()).map(|p| (p.predicted, p.spread + p.covariance)),
            self.weights.as_slice(),
        )
    }

    /// The particles' motion prior since the last keyframe, weighted: the odometry's
    /// covariance of the motion since then (map axes).
    pub fn motion_prior(&self) -> Matrix3<f64> {
        (self.particles.iter())
            .zip(self.weights.as_slice())
            .map(|(p, w)| p.covariance * *w)
            .sum()
    }

    /// Index of the particle with the largest weight (the first of equals).
    pub fn best(&self) -> usize {
        self.weights.argmax()
    }

    /// The best particle's grid as occupancy percentages (`None` before the first scan).
    pub fn occupancy(&self) -> Option<OccupancyGrid> {
        self.particles[self.best()].grid.occupancy()
    }

    /// Bytes the particles' grids hold: every distinct tile once, plus each grid's index.
    pub fn grid_bytes(&self) -> usize {
        let mut tiles = HashSet::new();
        let mut index = 0;
        for p in &self.particles {
            tiles.extend(p.grid.tile_addresses());
            index += p.grid.index_bytes();
        }
        tiles.len() * TILE_BYTES + index
    }
}

/// One particle's outcome of a keyframe.
struct Drawn {
    pose: Pose2,
    /// The log-weight increment.
    log_weight: f64,
    spread: Matrix3<f64>,
    stats: MoveStats,
}

/// `m⁻¹` of a symmetric positive definite `m`.
fn inverse(m: &Matrix3<f64>) -> Result<Matrix3<f64>> {
    m.cholesky()
        .map(|c| c.inverse())
        .ok_or_else(|| Error::InvalidInput {
            what: "motion prior",
            reason: format!("covariance not positive definite: {m:?}"),
        })
}

/// A draw `o ~ N(0, covariance)`.
fn draw_gaussian(covariance: &Matrix3<f64>, rng: &mut SimRng) -> Result<Vector3<f64>> {
    let factor = covariance
        .cholesky()
        .ok_or_else(|| Error::InvalidInput {
            what: "motion prior",
            reason: format!("covariance not positive definite: {covariance:?}"),
        })?
        .l();
    let e = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
    let o = factor * e;
    Ok(Vector3::new(o[0], o[1], wrap_angle(o[2])))
}
