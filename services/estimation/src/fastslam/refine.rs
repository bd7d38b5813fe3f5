//! The optimisers of ALGORITHMS.md §4 as FastSLAM's step 2: a [`PoseRefiner`] that runs a
//! [`Mover`] on the particle cloud, population member `i` = particle `i` (§3).
//!
//! Per scan:
//! - the cloud's centre `c` is the weighted mean pose (circular mean heading) of the poses
//!   the proposal drew, with the weights of the previous step;
//! - member `i`'s decision vector is its pose's offset from `c`, heading wrapped;
//! - the box is `± bound_sigmas · σ` of the cloud per dimension, never narrower than the
//!   motion prior's standard deviation (the weighted mean of the particles' `P`);
//! - the fitness is §3's `−log p(z | x, map_i) + λ (x − x̂_i)ᵀ P_i⁻¹ (x − x̂_i) / 2` with
//!   [`Scan::log_likelihood`] under particle `i`'s own map and its own
//!   [`MotionPrior`](super::MotionPrior) `N(x̂_i, P_i)`; when a particle moves, its map
//!   goes with it;
//! - the optimiser draws from a stream seeded per step from the filter's seed; ICOA's
//!   chaotic sequence is seeded once, from the same seed.
//!
//! A scan without usable observations is skipped: the likelihood is flat, and the prior
//! term alone would only pull every particle onto its noise-free prediction.

use super::association::Scan;
use super::estimate::PoseEstimate;
use super::particle::Particle;
use super::{PURPOSE_CHAOS, PURPOSE_OPTIMISE, PoseRefiner};
use crate::moves::{MoveConfig, MoveStats, MoveTarget, Mover, WeightBasis};
use crate::optimise::OptimiserConfig;
use crate::pose::{Pose2, wrap_angle};
use crate::rng::stream;
use crate::{Error, Result};
use nalgebra::{Matrix3, Vector3};

/// Runs the configured optimiser on the particles before they are weighed.
///
/// # Example
/// ```
/// use fastslam_estimation::fastslam::{FastSlam, FastSlamConfig, OptimiserRefiner};
/// use fastslam_estimation::moves::MoveConfig;
/// use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
/// use fastslam_estimation::Pose2;
///
/// let optimiser = OptimiserConfig { kind: OptimiserKind::Icoa, ..OptimiserConfig::default() };
/// let refiner = OptimiserRefiner::new(&optimiser, MoveConfig::default(), 7).unwrap();
/// assert!(refiner.is_some());
/// let none = OptimiserConfig::default();
/// assert!(OptimiserRefiner::new(&none, MoveConfig::default(), 7).unwrap().is_none());
/// ```
#[derive(Debug)]
pub struct OptimiserRefiner {
    mover: Mover,
    seed: u64,
}

impl OptimiserRefiner {
    /// The refiner for `optimiser` with the move settings `moves`, drawing from streams of
    /// `seed` (the filter's); `None` for `kind = "none"`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad optimiser constant or move setting.
    pub fn new(optimiser: &OptimiserConfig, moves: MoveConfig, seed: u64) -> Result<Option<Self>> {
        let mut rng = stream(seed, &[0, 0, PURPOSE_CHAOS]);
        Ok(Mover::new(optimiser, moves, &mut rng)?.map(|mover| Self { mover, seed }))
    }

    /// What the moves did so far (steps, proposed and accepted moves, evaluations).
    pub fn stats(&self) -> MoveStats {
        self.mover.stats()
    }
}

/// The §3 fitness terms of one scan: offsets from `centre` to poses, each particle's map
/// for the likelihood and its motion prior.
struct PoseTarget<'a> {
    scan: &'a Scan<'a>,
    particles: &'a [Particle],
    centre: Pose2,
    /// `P_i⁻¹` per particle.
    information: Vec<Matrix3<f64>>,
}

impl PoseTarget<'_> {
    fn pose(&self, offset: &[f64]) -> Pose2 {
        Pose2::new(
            self.centre.x + offset[0],
            self.centre.y + offset[1],
            self.centre.theta + offset[2],
        )
    }
}

impl MoveTarget for PoseTarget<'_> {
    fn log_likelihood(&self, member: usize, offset: &[f64]) -> f64 {
        let p = &self.particles[member];
        self.scan.log_likelihood(p.map(), &self.pose(offset))
    }

    fn log_prior(&self, member: usize, offset: &[f64]) -> f64 {
        let d = self.particles[member].prior().deviation(&self.pose(offset));
        -0.5 * (d.transpose() * self.information[member] * d)[0]
    }
}

impl PoseRefiner for OptimiserRefiner {
    fn refine(
        &mut self,
        scan: &Scan<'_>,
        particles: &mut [Particle],
        basis: &mut [WeightBasis],
    ) -> Result<()> {
        if scan.observations().is_empty() {
            return Ok(());
        }
        let weights: Vec<f64> = particles.iter().map(|p| p.log_weight().exp()).collect();
        let cloud = PoseEstimate::from_weighted(particles.iter().map(|p| *p.pose()), &weights);
        let centre = cloud.mean;
        let motion = particles
            .iter()
            .zip(&weights)
            .fold(Vector3::zeros(), |acc, (p, w)| {
                acc + *w * p.prior().covariance.diagonal()
            });
        let cloud_sigma: Vec<f64> = cloud
            .covariance
            .diagonal()
            .iter()
            .map(|v| v.sqrt())
            .collect();
        let motion_sigma: Vec<f64> = motion.iter().map(|v| v.sqrt()).collect();
        let bounds = self.mover.config().bounds(&cloud_sigma, &motion_sigma)?;
        let information = particles
            .iter()
            .enumerate()
            .map(|(i, p)| {
                p.prior()
                    .covariance
                    .cholesky()
                    .map(|c| c.inverse())
                    .ok_or_else(|| Error::InvalidInput {
                        what: "motion prior",
                        reason: format!("particle {i}'s covariance is not positive definite"),
                    })
            })
            .collect::<Result<Vec<_>>>()?;
        let start: Vec<f64> = particles
            .iter()
            .flat_map(|p| {
                let pose = p.pose();
                [
                    pose.x - centre.x,
                    pose.y - centre.y,
                    wrap_angle(pose.theta - centre.theta),
                ]
            })
            .collect();
        let target = PoseTarget {
            scan,
            particles,
            centre,
            information,
        };
        let mut rng = stream(self.seed, &[scan.step(), 0, PURPOSE_OPTIMISE]);
        let end = self
            .mover
            .run(&target, bounds, start.clone(), basis, &mut rng)?;
        // Only moved particles get a new pose (centre + offset would round the others).
        let moved: Vec<Option<Pose2>> = end
            .chunks_exact(3)
            .zip(start.chunks_exact(3))
            .map(|(to, from)| (to != from).then(|| target.pose(to)))
            .collect();
        for (p, pose) in particles.iter_mut().zip(moved) {
            if let Some(pose) = pose {
                p.set_pose(pose)?;
            }
        }
        Ok(())
    }
}
