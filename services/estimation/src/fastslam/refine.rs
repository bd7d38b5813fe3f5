//! The optimisers of docs/ALGORITHMS.md §4 inside FastSLAM: a [`PoseRefiner`] that runs
//! a [`Mover`] in the configured [`MoveCorrection`] mode.
//!
//! - **`none`, the papers' mode**, per scan, before weighing: the cloud's centre `c` is
//!   the weighted mean pose (circular mean heading) of the poses the proposal drew, with
//!   the weights of the previous step; member `i`'s decision vector is its pose's offset
//!   from `c`; the box is `± bound_sigmas · σ` of the cloud per dimension, never narrower
//!   than the motion prior's standard deviation (the weighted mean of the particles'
//!   `P`); the fitness is `−log p(z | x, map_i) + λ (x − x̂_i)ᵀ P_i⁻¹ (x − x̂_i) / 2`.
//!   Weighed at the moved poses: biased.
//! - **`proposal`**, per particle, before weighing: the optimiser searches around the
//!   particle's own prediction `x̂_i` ([`crate::moves::local`]); the pose is drawn from the
//!   defensive mixture around the optimum and weighed by
//!   `p(z | x, map_i) N(x; x̂_i, P_i) / q(x)` ([`WeightBasis::Corrected`]).
//! - **`resample-move`**, after resampling, every copy: Metropolis–Hastings steps toward
//!   the same target, proposing from the same density (one search per ancestor serves all
//!   its copies).
//!
//! Both corrected modes take a particle's prior to be its Gaussian `N(x̂_i, P_i)`, so the
//! filter defers sampling with them
//! ([`FastSlam::defer_sampling`](super::FastSlam::defer_sampling)): between observations
//! a particle *is* that Gaussian, and it is drawn from it (or from the proposal) when an
//! observation uses it.
//!
//! In the corrected modes a particle whose association at its pose updates no landmark
//! is left alone: its likelihood does not depend on the pose, so the target is the
//! motion prior, which it already follows. The papers' mode skips a scan without usable
//! observations: the prior term alone would only pull every particle onto its noise-free
//! prediction.

use super::association::Scan;
use super::estimate::PoseEstimate;
use super::landmarks::LandmarkMap;
use super::particle::Particle;
use super::{PURPOSE_CHAOS, PURPOSE_OPTIMISE, PURPOSE_REJUVENATE, PoseRefiner};
use crate::moves::{
    Laplace, LocalTarget, MoveConfig, MoveCorrection, MoveStats, MoveTarget, Mover, WeightBasis,
};
use crate::optimise::OptimiserConfig;
use crate::parallel;
use crate::pose::{Pose2, wrap_angle};
use crate::rng::{Streams, stream};
use crate::{Error, Result};
use nalgebra::{Matrix3, Vector3};

/// Runs the configured optimiser on the particles.
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

    /// The optimiser's configuration.
    pub fn optimiser_config(&self) -> &OptimiserConfig {
        self.mover.optimiser()
    }

    fn correction(&self) -> MoveCorrection {
        self.mover.config().correction
    }

    /// The papers' mode: the cloud is the population.
    fn move_cloud(
        &mut self,
        scan: &Scan<'_>,
        particles: &mut [Particle],
        basis: &mut [WeightBasis],
    ) -> Result<()> {
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
        let target = CloudTarget {
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

    /// `proposal`: each particle with a matched landmark is drawn from its optimised
    /// proposal; the optimiser starts from its prediction and, when the proposal already
    /// moved it (FastSLAM 2.0), from that pose too.
    fn propose(
        &mut self,
        scan: &Scan<'_>,
        particles: &mut [Particle],
        basis: &mut [WeightBasis],
    ) -> Result<()> {
        let streams = Streams::new(self.seed, &[scan.step()]);
        let mover = &self.mover;
        let drawn = per_particle(particles, scan, |i, p, target| {
            let mut rng = streams.stream(&[i as u64, PURPOSE_OPTIMISE]);
            let start = p.prior().deviation(p.pose());
            let starts: &[Vector3<f64>] = if start == Vector3::zeros() {
                &[]
            } else {
                std::slice::from_ref(&start)
            };
            let laplace = mover.laplace(target, &p.prior().covariance, starts, &mut rng)?;
            let (offset, correction) = laplace.draw(&mut rng);
            Ok((target.pose(&offset), correction, laplace.evaluations))
        })?;
        let mut stats = MoveStats {
            steps: 1,
            ..MoveStats::default()
        };
        for ((p, b), d) in particles.iter_mut().zip(basis).zip(drawn) {
            if let Some((pose, correction, evaluations)) = d {
                p.set_pose(pose)?;
                *b = WeightBasis::Corrected(correction);
                stats += MoveStats {
                    steps: 0,
                    proposed: 1,
                    accepted: 1,
                    evaluations,
                };
            }
        }
        self.mover.record(stats);
        Ok(())
    }
}

/// Runs `f` on every particle whose association at its pose updates a landmark (with its
/// [`ParticleTarget`] around its prediction), in parallel when that pays; `None` for the
/// others. Results come back in particle order whatever the thread count.
fn per_particle<R: Send>(
    particles: &[Particle],
    scan: &Scan<'_>,
    f: impl Fn(usize, &Particle, &ParticleTarget<'_>) -> Result<R> + Sync + Send,
) -> Result<Vec<Option<R>>> {
    per_particle_where(particles, scan, &vec![true; particles.len()], f)
}

/// [`per_particle`] restricted to the particles marked in `selected`.
fn per_particle_where<R: Send>(
    particles: &[Particle],
    scan: &Scan<'_>,
    selected: &[bool],
    f: impl Fn(usize, &Particle, &ParticleTarget<'_>) -> Result<R> + Sync + Send,
) -> Result<Vec<Option<R>>> {
    // A search costs hundreds of likelihood evaluations: parallel whenever rayon has more
    // than one thread.
    let parallel = parallel::pays(particles.len(), parallel::MIN_PARALLEL_WORK);
    let mut out = Vec::with_capacity(particles.len());
    parallel::map_into(parallel, particles, &mut out, |i, p| {
        if !selected[i] {
            return Ok(None);
        }
        let target = ParticleTarget {
            scan,
            map: p.map(),
            prediction: p.prior().mean,
        };
        let (_, matched) = scan.pose_information(p.map(), p.pose());
        if !matched {
            return Ok(None);
        }
        f(i, p, &target).map(Some)
    });
    out.into_iter().collect()
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
        match self.correction() {
            MoveCorrection::None => self.move_cloud(scan, particles, basis),
            MoveCorrection::Proposal => self.propose(scan, particles, basis),
            MoveCorrection::ResampleMove => Ok(()),
        }
    }

    fn rejuvenate(
        &mut self,
        scan: &Scan<'_>,
        particles: &mut [Particle],
        ancestors: &[usize],
        moved: &mut [bool],
    ) -> Result<()> {
        if self.correction() != MoveCorrection::ResampleMove || scan.observations().is_empty() {
            return Ok(());
        }
        let streams = Streams::new(self.seed, &[scan.step()]);
        let (mover, steps) = (&self.mover, self.mover.config().mh_steps);
        // Copies of one ancestor share its map and prior, so one search serves them all:
        // it runs for the first copy of each ancestor.
        let mut first = vec![usize::MAX; particles.len()];
        let leads: Vec<bool> = ancestors
            .iter()
            .enumerate()
            .map(|(k, &a)| {
                let lead = first[a] == usize::MAX;
                if lead {
                    first[a] = k;
                }
                lead
            })
            .collect();
        // The search must not start from the copies' current pose: the independence
        // proposal may not depend on the state of the chain it moves.
        let searches = per_particle_where(particles, scan, &leads, |k, p, target| {
            let mut rng = streams.stream(&[k as u64, PURPOSE_OPTIMISE]);
            mover.laplace(target, &p.prior().covariance, &[], &mut rng)
        })?;
        let shared: Vec<&Option<Laplace<3>>> =
            ancestors.iter().map(|&a| &searches[first[a]]).collect();
        let chains = parallel::pays(particles.len(), parallel::MIN_PARALLEL_WORK);
        let mut results = Vec::with_capacity(particles.len());
        parallel::map_into(chains, particles, &mut results, |k, p| {
            let laplace = shared[k].as_ref()?;
            let mut rng = streams.stream(&[k as u64, PURPOSE_REJUVENATE]);
            let target = ParticleTarget {
                scan,
                map: p.map(),
                prediction: p.prior().mean,
            };
            let current = p.prior().deviation(p.pose());
            let (offset, accepted) = laplace.rejuvenate(&target, current, steps, &mut rng);
            Some(((offset != current).then(|| target.pose(&offset)), accepted))
        });
        let mut stats = MoveStats {
            steps: 1,
            evaluations: searches.iter().flatten().map(|l| l.evaluations).sum(),
            ..MoveStats::default()
        };
        for ((p, m), r) in particles.iter_mut().zip(moved.iter_mut()).zip(results) {
            let Some((pose, accepted)) = r else {
                continue;
            };
            stats += MoveStats {
                steps: 0,
                proposed: steps as u64,
                accepted,
                evaluations: steps as u64 + 1,
            };
            if let Some(pose) = pose {
                p.set_pose(pose)?;
                *m = true;
            }
        }
        self.mover.record(stats);
        Ok(())
    }

    fn needs_gaussian_prior(&self) -> bool {
        self.correction().is_valid()
    }
}

/// The papers' fitness terms of one scan: offsets from `centre` to poses, each particle's
/// map for the likelihood and its motion prior.
struct CloudTarget<'a> {
    scan: &'a Scan<'a>,
    particles: &'a [Particle],
    centre: Pose2,
    /// `P_i⁻¹` per particle.
    information: Vec<Matrix3<f64>>,
}

impl CloudTarget<'_> {
    fn pose(&self, offset: &[f64]) -> Pose2 {
        Pose2::new(
            self.centre.x + offset[0],
            self.centre.y + offset[1],
            self.centre.theta + offset[2],
        )
    }
}

impl MoveTarget for CloudTarget<'_> {
    fn log_likelihood(&self, member: usize, offset: &[f64]) -> f64 {
        let p = &self.particles[member];
        self.scan.log_likelihood(p.map(), &self.pose(offset))
    }

    fn log_prior(&self, member: usize, offset: &[f64]) -> f64 {
        let d = self.particles[member].prior().deviation(&self.pose(offset));
        -0.5 * (d.transpose() * self.information[member] * d)[0]
    }
}

/// One particle's target in the corrected modes: poses as offsets from its prediction,
/// the likelihood and information under its own map.
struct ParticleTarget<'a> {
    scan: &'a Scan<'a>,
    map: &'a LandmarkMap,
    prediction: Pose2,
}

impl ParticleTarget<'_> {
    fn pose(&self, offset: &Vector3<f64>) -> Pose2 {
        let x = &self.prediction;
        Pose2::new(x.x + offset[0], x.y + offset[1], x.theta + offset[2])
    }
}

impl LocalTarget<3> for ParticleTarget<'_> {
    fn log_likelihood(&self, offset: &Vector3<f64>) -> f64 {
        self.scan.log_likelihood(self.map, &self.pose(offset))
    }

    fn information(&self, offset: &Vector3<f64>) -> Matrix3<f64> {
        self.scan.pose_information(self.map, &self.pose(offset)).0
    }
}
