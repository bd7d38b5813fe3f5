//! FastSLAM 1.0 and 2.0 with per-particle landmark EKFs (docs/ALGORITHMS.md §1).
//!
//! The filter reads top to bottom in [`FastSlam::predict`] and, for an update, the
//! `update` module: one private method per stage of §1, in the order they run; the
//! stages that the pose estimate needs (proposal, weighing) come before the map updates,
//! so the estimate can be published first. Parts:
//! - [`landmarks`]: the per-particle map, persistent and spatially indexed, shared
//!   between resampled copies and copied only where written;
//! - [`association`]: association and weighting of a scan against one particle's map;
//! - [`ekf`]: the per-landmark EKF (Joseph form);
//! - [`evidence`]: negative evidence against spurious landmarks;
//! - [`trail`]: each particle's pose history at keyframes, shared between resampled
//!   copies, for the occupancy grid of the best particle;
//! - [`proposal`]: FastSLAM 2.0's proposal, drawn after the prediction when configured;
//! - `published`: what the filter gives out between steps (the best particle, the
//!   weighted cloud, the published map); `reanchor`: moving it onto a smoothed solution;
//! - [`PoseRefiner`]: the seam for the optimiser after the proposal, with
//!   [`refine::OptimiserRefiner`] the optimisers of §4 behind it in the mode §3 and §3.1
//!   describe.
//!
//! **Deferred sampling.** With FastSLAM 2.0's proposal, or an optimiser in a corrected
//! mode (`proposal`, `resample-move`), a particle's pose is not sampled control by
//! control: between observations it *is* its motion prior `N(x̂, P)` (the noise-free prediction from its
//! last sampled pose, with the control noise accumulated), and it is drawn once, when an
//! observation uses it — from the proposal when a landmark is matched, from the prior
//! when the scan only starts landmarks — as Bailey & Nieto's FastSLAM 2.0 does. A scan
//! that uses nothing of a particle leaves its Gaussian open, so the next proposal
//! corrects the whole stretch since its last draw.
//!
//! **The published estimate** is the weighted cloud *before* resampling (resampling adds
//! noise and duplicates, never information): the weighted mixture of each particle's
//! component — its Gaussian proposal after FastSLAM 2.0's draw, its prior while open, its
//! pose otherwise — with mean `Σ wᵢ μᵢ` (circular heading) and covariance
//! `Σ wᵢ (Σᵢ + dᵢ dᵢᵀ)`, `dᵢ = μᵢ − μ`.
//!
//! Per-particle work runs on rayon when the batch is large enough to pay for the hand-off
//! (`crate::parallel`); every random draw comes from a stream labelled
//! `[step, particle, purpose]` ([`crate::rng::stream`]) and every reduction runs in
//! particle order, so results are bit-identical whatever the number of threads. A step
//! fills buffers kept from the step before, so it allocates no scratch space.

pub mod association;
mod config;
pub mod ekf;
mod estimate;
pub mod evidence;
pub mod innovations;
pub mod landmarks;
mod merge;
pub mod noise_fit;
mod particle;
pub mod proposal;
mod published;
mod reanchor;
pub mod refine;
pub mod snapshot;
pub mod trail;
mod update;

pub use crate::moves::WeightBasis;
use crate::resample::Resampled;
pub use crate::resample::{ResamplingConfig, ResamplingScheme};
pub use association::{Assignment, AssociationConfig, AssociationMode, Scan};
pub use config::{FastSlamConfig, PriorFloor};
pub use estimate::{MapLandmark, PoseEstimate};
pub use evidence::NegativeEvidence;
pub use innovations::{Innovations, NIS_WINDOW_SCANS, NisVerdict, NisWindow, noise_suspect};
pub use landmarks::{Landmark, LandmarkMap, Slot};
pub use noise_fit::{Adapt, NoiseConfig, NoiseFit, NoiseReport};
pub use particle::{MotionPrior, Particle};
pub use proposal::Proposal;
pub use refine::OptimiserRefiner;
pub use snapshot::FilterState;
pub use trail::Trail;

use crate::motion::{Control, MotionModel};
use crate::moves::gaussian::Gaussian;
use crate::observation::{Observation, Sensor};
use crate::parallel;
use crate::pose::Pose2;
use crate::rng::{Streams, stream};
use crate::weights::Weights;
use crate::{Error, Result};
use association::{Decision, ScanAssociation};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use particle::MapChanges;

/// Stream label for the motion noise of one particle in one step.
const PURPOSE_PREDICT: u64 = 0;
/// Stream label for the resampling draw of one step.
const PURPOSE_RESAMPLE: u64 = 1;
/// Stream label for FastSLAM 2.0's draw of one particle in one step.
const PURPOSE_PROPOSAL: u64 = 2;
/// Stream label for the optimiser's draws of one step ([`refine`]).
pub(crate) const PURPOSE_OPTIMISE: u64 = 3;
/// Stream label for seeding ICOA's persistent chaotic sequence, once per filter.
pub(crate) const PURPOSE_CHAOS: u64 = 4;
/// Stream label for the Metropolis–Hastings moves of one resampled copy ([`refine`]).
pub(crate) const PURPOSE_REJUVENATE: u64 = 5;
/// Stream label for a deferred particle's draw from its motion prior.
const PURPOSE_PRIOR_DRAW: u64 = 6;
/// Stream label for a particle's sampled association of one step.
const PURPOSE_ASSOCIATION: u64 = 7;

/// Step 2 of docs/ALGORITHMS.md §1: an optimiser that moves or draws the predicted poses.
/// `None` in [`FastSlam::update_with`] runs no optimiser (plain FastSLAM 1.0 with the
/// motion proposal, FastSLAM 2.0 with `fastslam2`).
pub trait PoseRefiner {
    /// Before weighing: moves or draws particles (through [`Particle::set_pose`]) for this
    /// scan, and says in `basis` (one entry per particle) how each particle's weight of
    /// this step is then obtained ([`WeightBasis`]). `basis` arrives filled by the
    /// proposal (`FinalPosition`, or FastSLAM 2.0's marginal likelihood).
    ///
    /// [`Scan::log_likelihood`] gives the observation log-likelihood of a candidate pose
    /// under a particle's own map, [`Particle::prior`] the motion prior, and [`Scan::step`]
    /// labels the step for seeded streams.
    ///
    /// # Errors
    /// Whatever the optimiser reports; [`FastSlam::update_with`] returns it unchanged and
    /// does not weigh or update the maps.
    fn refine(
        &mut self,
        scan: &Scan<'_>,
        particles: &mut [Particle],
        basis: &mut [WeightBasis],
    ) -> Result<()>;

    /// After resampling, before the maps are updated: may move the copies (`ancestors[k]`
    /// is the particle copy `k` was drawn from) by moves that leave the step's posterior
    /// invariant, keeping their weights, and marks each copy it moved in `moved`. Every
    /// copy must be offered the move, not only the duplicates: which copies duplicate an
    /// ancestor depends on its weight, so moving only those would leave the cloud
    /// over-dispersed. The default moves nothing.
    ///
    /// # Errors
    /// Whatever the optimiser reports; the step then fails as in
    /// [`refine`](Self::refine).
    fn rejuvenate(
        &mut self,
        _scan: &Scan<'_>,
        _particles: &mut [Particle],
        _ancestors: &[usize],
        _moved: &mut [bool],
    ) -> Result<()> {
        Ok(())
    }

    /// Whether the refiner's target takes each particle's prior to be its Gaussian motion
    /// prior `N(x̂, P)`, so the filter must defer sampling ([`FastSlam::defer_sampling`])
    /// for the particles to follow that very prior. Default false.
    fn needs_gaussian_prior(&self) -> bool {
        false
    }
}

/// What one [`FastSlam::update`] did, for filter-health metrics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// Effective sample size after weighing, before resampling (1..=N).
    pub neff: f64,
    /// Whether the particles were resampled.
    pub resampled: bool,
    /// Distinct particles after this step (N when not resampled).
    pub distinct: usize,
    /// Observations that updated a landmark, summed over particles.
    pub matched: usize,
    /// Landmarks created, summed over particles.
    pub new_landmarks: usize,
    /// Observations ignored (between the gates, or a duplicate id), summed over particles.
    pub ignored: usize,
    /// Landmarks removed by negative evidence, summed over particles.
    pub removed: usize,
    /// Observations of the scan rejected before association (not finite, a range outside
    /// (0, max_range + 5 σ_r], or no id under known association).
    pub rejected: usize,
    /// The scan's innovations at the best particle's motion prior, for the noise check
    /// ([`innovations`]).
    pub innovations: Innovations,
}

/// The FastSLAM filter: particles with poses, weights and landmark maps.
///
/// # Example
/// ```
/// use fastslam_estimation::fastslam::{FastSlam, FastSlamConfig};
/// use fastslam_estimation::motion::Control;
/// use fastslam_estimation::observation::Observation;
/// use fastslam_estimation::Pose2;
///
/// let mut slam = FastSlam::new(FastSlamConfig::default(), Pose2::default()).unwrap();
/// slam.predict(&Control { v: 3.0, ..Control::ZERO }, 0.025).unwrap();
/// let seen = [Observation { range: 10.0, bearing: 0.2, id: None }];
/// let report = slam.update(&seen).unwrap();
/// assert_eq!(report.new_landmarks, 100); // one per particle
/// assert!(slam.best_map().is_empty()); // provisional until seen again
/// slam.update(&seen).unwrap();
/// assert_eq!(slam.best_map().len(), 1);
/// ```
#[derive(Debug, Clone)]
pub struct FastSlam {
    config: FastSlamConfig,
    particles: Vec<Particle>,
    weights: Weights,
    step: u64,
    /// The noise check's motion prior: the best particle's pose at the last update,
    /// propagated by every control since (kept whether or not the particles keep theirs).
    check_prior: MotionPrior,
    /// The noise fitted from the noise check's innovations ([`noise_fit`]).
    noise: NoiseFit,
    /// The configuration's motion model and sensor, before the fit scales their noise
    /// (`config` holds the noise in use).
    profile: (MotionModel, Sensor),
    /// Whether [`predict`](Self::predict) propagates every particle's [`MotionPrior`].
    motion_prior: bool,
    /// Whether poses are drawn at observations instead of control by control (see the
    /// module documentation).
    deferred: bool,
    /// Localisation only: the maps are read, never written ([`FastSlam::fix_map`]).
    map_fixed: bool,
    /// Index of the particle that had the largest weight when the last step weighed the
    /// cloud (after resampling: the first copy of that particle, since every copy then
    /// weighs the same).
    best: usize,
    /// Buffers a step fills, kept for the next step.
    scratch: Scratch,
}

/// What a particle stands for in this step's published mixture.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Component {
    /// Its pose, a sample.
    Point,
    /// The Gaussian its pose was drawn from (FastSLAM 2.0's proposal).
    Drawn {
        mean: Pose2,
        covariance: Matrix3<f64>,
    },
    /// Its motion prior `N(x̂, P)`: deferred and not drawn in this step.
    Open,
}

/// The buffers of one step, kept between steps so that a step allocates no scratch space
/// once they have grown to the particle count and scan size. They hold nothing between
/// steps that matters: a clone or a restored filter may start with empty ones.
#[derive(Debug, Clone, Default)]
pub(crate) struct Scratch {
    /// Step 1: each particle's sampled pose and propagated prior, checked before use.
    predicted: Vec<(Pose2, MotionPrior)>,
    /// The scan's observations that pass the checks.
    accepted: Vec<Observation>,
    /// How each particle's weight increment of this step is obtained.
    basis: Vec<WeightBasis>,
    /// FastSLAM 2.0's draw per particle.
    drawn: Vec<Option<proposal::Drawn>>,
    /// What each particle stands for in the published estimate.
    components: Vec<Component>,
    /// Per particle: its association and map changes.
    particles: Vec<ParticleStep>,
    /// Unnormalised log-weights.
    log_weights: Vec<f64>,
    /// The weights of the step before, whose buffers the next normalisation reuses.
    spare_weights: Option<Weights>,
    /// The particles before resampling, emptied after each resampling (capacity kept).
    spare_particles: Vec<Particle>,
    /// Deferred draws and resample-move: which particles moved.
    moved: Vec<bool>,
    /// The noise check's association (see [`innovations`]).
    check: ScanAssociation,
}

/// What one scan does to one particle.
#[derive(Debug, Clone, Default)]
struct ParticleStep {
    association: ScanAssociation,
    changes: MapChanges,
    /// Deferred and not drawn: its motion prior stays open (the map update does not settle it).
    open: bool,
}

impl FastSlam {
    /// A filter with every particle at `initial` (zero spread: the map frame is the start
    /// pose), equal weights and empty maps.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad config, [`Error::InvalidInput`] for a
    /// non-finite initial pose.
    pub fn new(config: FastSlamConfig, initial: Pose2) -> Result<Self> {
        Self::with_prior_map(config, initial, &[])
    }

    /// Like [`new`](Self::new), with every particle's map starting as `landmarks` (a map
    /// from an earlier run, or surveyed landmarks). All particles share the one map.
    ///
    /// # Errors
    /// As [`new`](Self::new), and [`Error::InvalidInput`] for a landmark with a
    /// non-finite mean, a covariance that is not symmetric positive definite, or a
    /// repeated id.
    pub fn with_prior_map(
        config: FastSlamConfig,
        initial: Pose2,
        landmarks: &[MapLandmark],
    ) -> Result<Self> {
        config.validate()?;
        if !initial.is_finite() {
            return Err(Error::InvalidInput {
                what: "initial pose",
                reason: format!("not finite: {initial:?}"),
            });
        }
        let mut map = LandmarkMap::new(config.association.cell_size);
        for landmark in landmarks {
            let c = &landmark.covariance;
            let spd = c[(0, 1)] == c[(1, 0)] && c[(0, 0)] > 0.0 && c.determinant() > 0.0;
            let problem = if !landmark.mean.iter().all(|v| v.is_finite()) {
                Some("mean not finite")
            } else if !(spd && c.iter().all(|v| v.is_finite())) {
                Some("covariance not symmetric positive definite")
            } else if map.get(landmark.id).is_some() {
                Some("repeated id")
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(Error::InvalidInput {
                    what: "prior landmark",
                    reason: format!("landmark {}: {problem}", landmark.id),
                });
            }
            map.insert(Landmark {
                id: landmark.id,
                mean: landmark.mean,
                covariance: landmark.covariance,
                hits: landmark.hits,
                chances: 0,
            });
        }
        let n = config.particles;
        let log_weight = -(n as f64).ln();
        let pose = Pose2::new(initial.x, initial.y, initial.theta);
        let particle = Particle {
            pose,
            log_weight,
            map: map.track_tentative(config.negative_evidence_in_effect().min_hits),
            trail: Trail::default(),
            prior: MotionPrior::settled(pose, &config.prior_floor.covariance()),
        };
        Ok(Self {
            check_prior: particle.prior,
            noise: NoiseFit::default(),
            profile: (config.motion.clone(), config.sensor.clone()),
            particles: vec![particle; n],
            weights: Weights::from_log(&vec![log_weight; n])?,
            deferred: config.proposal == Proposal::FastSlam2,
            config,
            step: 0,
            motion_prior: true,
            map_fixed: false,
            best: 0,
            scratch: Scratch::default(),
        })
    }

    /// The same filter without the [`MotionPrior`]: [`predict`](Self::predict) no longer
    /// propagates it, and [`Particle::prior`] stays the pose of the last update. Only
    /// FastSLAM 2.0's proposal and a [`PoseRefiner`] read the prior, so plain FastSLAM 1.0
    /// gives bit-identical results without it, in less time.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when the filter is configured with FastSLAM 2.0's
    /// proposal or defers sampling, which need the prior.
    ///
    /// # Performance
    /// Saves one 3 × 3 covariance propagation (two Jacobians, a sine and a cosine) per
    /// particle per prediction: about a quarter of FastSLAM 1.0's instructions on Bailey's
    /// webmap.
    pub fn without_motion_prior(mut self) -> Result<Self> {
        if self.config.proposal == Proposal::FastSlam2 || self.deferred {
            return Err(Error::InvalidParameter {
                name: "proposal",
                reason: "fastslam2 and the optimised proposal need the motion prior".into(),
            });
        }
        self.motion_prior = false;
        Ok(self)
    }

    /// The same filter with deferred sampling (see the module documentation): what a
    /// [`PoseRefiner`] whose target [takes the Gaussian motion prior](PoseRefiner::needs_gaussian_prior)
    /// needs. FastSLAM 2.0's proposal defers by itself.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] on a filter
    /// [`without_motion_prior`](Self::without_motion_prior).
    pub fn defer_sampling(mut self) -> Result<Self> {
        if !self.motion_prior {
            return Err(Error::InvalidParameter {
                name: "proposal",
                reason: "deferred sampling needs the motion prior".into(),
            });
        }
        self.deferred = true;
        Ok(self)
    }

    /// Whether poses are drawn at observations (see the module documentation).
    pub fn defers_sampling(&self) -> bool {
        self.deferred
    }

    /// Localisation only from now on: updates weigh the particles against their maps but
    /// neither update, create nor remove landmarks (a surveyed or saved map stays as it is).
    pub fn fix_map(&mut self) {
        self.map_fixed = true;
    }

    /// The configuration the filter runs with, its noise the one in use (the profile's,
    /// or the fitted one under `[noise] adapt`).
    pub fn config(&self) -> &FastSlamConfig {
        &self.config
    }

    /// The noise fit ([`noise_fit`]).
    pub fn noise_fit(&self) -> &NoiseFit {
        &self.noise
    }

    /// The profile's noise beside the fitted one, as standard deviations, and the source
    /// the fit blames.
    pub fn noise_report(&self) -> NoiseReport {
        self.noise.report(&self.profile.0, &self.profile.1)
    }

    /// Under `[noise] adapt = "innovations"`, once the fit has warmed up: runs on the fitted noise (the
    /// motion model's and the configured sensor's; a scan's own sensor keeps its noise).
    fn adapt_noise(&mut self) {
        if !(self.config.noise.adapt == Adapt::Innovations && self.noise.warmed_up()) {
            return;
        }
        self.noise.adopt();
        (self.config.motion, self.config.sensor) =
            self.noise.apply(&self.profile.0, &self.profile.1);
    }

    /// Runs on the profile's noise with its variances scaled by `scales` `(odometry,
    /// sensor)` from the next step on (the back-end's fit under `[noise] adapt =
    /// "smoother"`; each scale within the noise fit's bounds). A checkpoint carries them.
    pub fn run_on_noise(&mut self, scales: [f64; 2]) {
        self.noise.run_on(scales);
        (self.config.motion, self.config.sensor) =
            self.noise.apply(&self.profile.0, &self.profile.1);
    }

    /// Read access to the particles (metrics, optimisers).
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// The particles' current normalised weights and `N_eff`.
    pub fn weights(&self) -> &Weights {
        &self.weights
    }

    /// Step 1: propagates every particle's [`MotionPrior`] over `control` held for `dt`
    /// seconds and samples its pose from the motion model — or, with deferred sampling,
    /// sets the pose to the prior's mean (the pose is drawn when an observation uses it).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a non-finite control, a negative or non-finite `dt`,
    /// or a control so large that a pose would overflow; the filter is then unchanged.
    ///
    /// # Performance
    /// O(N), parallel over particles when N is large; allocates nothing.
    pub fn predict(&mut self, control: &Control, dt: f64) -> Result<()> {
        control.validate()?;
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(Error::InvalidInput {
                what: "dt",
                reason: format!("must be finite and >= 0, got {dt}"),
            });
        }
        let step = self.step + 1;
        let (seed, motion) = (self.config.seed, &self.config.motion);
        let (with_prior, deferred) = (self.motion_prior, self.deferred);
        let predicted = &mut self.scratch.predicted;
        let parallel = parallel::pays(self.particles.len(), 1);
        let streams = Streams::new(seed, &[step]);
        parallel::map_into(parallel, &self.particles, predicted, |i, p| {
            let prior = if with_prior {
                p.prior.predict(motion, control, dt)
            } else {
                p.prior
            };
            if deferred {
                return (prior.mean, prior);
            }
            let mut rng = streams.stream(&[i as u64, PURPOSE_PREDICT]);
            (motion.sample(&p.pose, control, dt, &mut rng), prior)
        });
        let broken = predicted.iter().position(|(pose, prior)| {
            !(pose.is_finite() && prior.mean.is_finite())
                || prior.covariance.iter().any(|v| !v.is_finite())
        });
        if let Some(i) = broken {
            return Err(Error::InvalidInput {
                what: "control",
                reason: format!(
                    "particle {i}'s pose would become non-finite: {:?}",
                    predicted[i]
                ),
            });
        }
        for (particle, &(pose, prior)) in self.particles.iter_mut().zip(predicted.iter()) {
            particle.pose = pose;
            particle.prior = prior;
        }
        self.check_prior = self.check_prior.predict(motion, control, dt);
        self.step = step;
        Ok(())
    }

    /// Records every particle's current pose under `keyframe` in its [`Trail`] (for
    /// grid mapping from the best particle's own trajectory).
    ///
    /// # Performance
    /// O(N): one small allocation per particle; histories stay shared under resampling.
    pub fn record_poses(&mut self, keyframe: u64) {
        for p in &mut self.particles {
            p.trail.push(keyframe, p.pose);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merging_fuses_a_landmark_mapped_twice_into_one() {
        let seen = Observation {
            range: 5.0,
            bearing: 0.1,
            id: None,
        };
        let landmarks_after = |merge_gate| {
            let mut config = FastSlamConfig {
                particles: 5,
                ..FastSlamConfig::default()
            };
            config.association.merge_gate = merge_gate;
            let mut slam = FastSlam::new(config, Pose2::default()).unwrap();
            // One point detected twice in a scan: each detection starts a landmark, and
            // the two Gaussians coincide.
            slam.update(&[seen, seen]).unwrap();
            slam.best().map.len()
        };
        assert_eq!(landmarks_after(0.0), 2, "no merging by default");
        assert_eq!(landmarks_after(9.21), 1);
    }

    #[test]
    fn a_fixed_map_is_neither_updated_nor_extended() {
        let config = FastSlamConfig {
            particles: 20,
            ..FastSlamConfig::default()
        };
        let prior = [MapLandmark {
            id: 4,
            mean: nalgebra::Vector2::new(10.0, 0.0),
            covariance: nalgebra::Matrix2::identity() * 0.5,
            hits: 3,
        }];
        let mut slam = FastSlam::with_prior_map(config, Pose2::default(), &prior).unwrap();
        slam.fix_map();
        let seen = Observation {
            range: 9.5,
            bearing: 0.05,
            id: None,
        };
        let unknown = Observation {
            range: 5.0,
            bearing: -1.0,
            id: None,
        };
        let report = slam.update(&[seen, unknown]).unwrap();
        assert_eq!((report.matched, report.new_landmarks), (0, 0));
        assert_eq!(slam.best_map().as_slice(), &prior);
    }
}
