//! Running an optimiser inside a particle filter (docs/ALGORITHMS.md §3), shared by
//! FastSLAM's pose refiner and the generic particle filter, so both run the very same
//! search, fitness and weights. What the optimiser's answer does is the
//! [`MoveCorrection`]:
//!
//! - **`none`, the papers' mode** ([`cloud`]): population member `i` is particle `i`; the
//!   cloud is moved toward high fitness and weighed at the moved positions. A member's move
//!   depends on every other member, so it has no proposal density and no importance weight
//!   can be correct: the filter is biased (over-confident). Kept for the comparison.
//! - **`proposal`** ([`local`]): the optimiser serves one particle at a time, searching
//!   candidate states for that particle alone around its own prediction `x̂`. Its optimum
//!   `x*` and the Laplace covariance there define a proposal density
//!   ([`gaussian::Defensive`]); the particle is drawn from it and weighed by
//!   `p(z | x) N(x; x̂, P) / q(x)`. Correct for any `x*`.
//! - **`resample-move`** ([`local`]): after resampling, every copy takes
//!   Metropolis–Hastings steps toward `π(x) ∝ p(z | x) N(x; x̂, P)` with the same density
//!   as an independence proposal; the weights stay as they are.
//!
//! In every mode the fitness is `F(x) = −log p(z | x) + λ (x − x̂)ᵀ P⁻¹ (x − x̂) / 2`
//! (`λ` = [`MoveConfig::prior_weight`]).

pub mod cloud;
pub mod gaussian;
pub mod local;

pub use cloud::MoveTarget;
pub use local::{Laplace, LocalTarget};

use crate::check::{in_range, named_choices, non_negative, positive, require};
use crate::optimise::{Bounds, Optimiser, OptimiserConfig};
use crate::rng::SimRng;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// What an optimiser's answer does to the particles and their weights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum MoveCorrection {
    /// The papers' scheme: the whole cloud is the optimiser's population, every move is
    /// kept and the weights are computed at the final positions. Biased: moving particles
    /// toward high likelihood and then weighing them by it makes the filter
    /// over-confident (docs/ALGORITHMS.md §3).
    #[default]
    #[serde(rename = "none")]
    None,
    /// The optimiser finds each particle's mode; the particle is drawn from the Laplace
    /// Gaussian there (mixed with the motion prior) and weighed by target / proposal.
    #[serde(rename = "proposal")]
    Proposal,
    /// After resampling, every copy takes Metropolis–Hastings steps toward the step's
    /// posterior, proposing from the same density; weights unchanged.
    #[serde(rename = "resample-move")]
    ResampleMove,
}

named_choices!(MoveCorrection, "move_correction", {
    None => "none",
    Proposal => "proposal",
    ResampleMove => "resample-move",
});

impl MoveCorrection {
    /// Whether the filter stays a correct importance sampler whatever the optimiser does.
    pub fn is_valid(self) -> bool {
        self != Self::None
    }
}

/// How a filter uses its optimiser (docs/ALGORITHMS.md §3, §3.1).
///
/// ```toml
/// bound_sigmas = 3.0
/// prior_weight = 1.0
/// correction = "proposal"
/// candidates = 8
/// inflation = 1.0
/// defensive_weight = 0.8
/// mh_steps = 2
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MoveConfig {
    /// Half-width of the search box per dimension in standard deviations (dimensionless,
    /// positive): of the predicted cloud in the papers' mode, of the particle's own motion
    /// prior in the corrected modes. Default 3.
    pub bound_sigmas: f64,
    /// `λ`, the weight of the motion-prior term in the fitness (dimensionless, ≥ 0);
    /// default 1, 0 = the papers' likelihood-only fitness.
    pub prior_weight: f64,
    /// What the optimiser's answer does: `none` (the papers), `proposal` or
    /// `resample-move`.
    pub correction: MoveCorrection,
    /// Corrected modes: the optimiser's population per particle — candidate states for
    /// that one particle (count, ≥ 2). Default 8: the state has at most 3 dimensions and
    /// the target one mode per association hypothesis.
    pub candidates: usize,
    /// Corrected modes: `κ ≥ 1`, the factor on the Laplace covariance, for targets with
    /// heavier tails than a Gaussian (dimensionless). Default 1: the defensive mixture
    /// already covers the tails.
    pub inflation: f64,
    /// Corrected modes: `α`, the weight of the Laplace Gaussian in the defensive mixture
    /// `α N(x*, κΣ*) + (1 − α) N(x̂, P)` (in (0, 1]). Default 0.8: one draw in five comes
    /// from the motion prior, so a mode the optimiser missed is still proposed at a fifth
    /// of the bootstrap filter's rate and the weights stay bounded by `1 / (1 − α)` times
    /// the bootstrap weights.
    pub defensive_weight: f64,
    /// `resample-move`: Metropolis–Hastings steps per resampled copy (count, ≥ 1).
    /// Default 2.
    pub mh_steps: usize,
}

impl Default for MoveConfig {
    fn default() -> Self {
        Self {
            bound_sigmas: 3.0,
            prior_weight: 1.0,
            correction: MoveCorrection::None,
            candidates: 8,
            inflation: 1.0,
            defensive_weight: 0.8,
            mh_steps: 2,
        }
    }
}

/// Largest population per particle [`MoveConfig::candidates`] accepts.
pub const MAX_CANDIDATES: usize = 1024;
/// Most Metropolis–Hastings steps per particle [`MoveConfig::mh_steps`] accepts.
pub const MAX_MH_STEPS: usize = 1024;

impl MoveConfig {
    /// Checks the ranges.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the first bad value (`moves.bound_sigmas`,
    /// `moves.prior_weight`, `moves.candidates`, `moves.inflation`,
    /// `moves.defensive_weight`, `moves.mh_steps`).
    pub fn validate(&self) -> Result<()> {
        positive("moves.bound_sigmas", self.bound_sigmas)?;
        non_negative("moves.prior_weight", self.prior_weight)?;
        require(
            (2..=MAX_CANDIDATES).contains(&self.candidates),
            "moves.candidates",
            || format!("must lie in 2..={MAX_CANDIDATES}, got {}", self.candidates),
        )?;
        require(
            self.inflation.is_finite() && self.inflation >= 1.0,
            "moves.inflation",
            || format!("must be finite and >= 1, got {}", self.inflation),
        )?;
        in_range("moves.defensive_weight", self.defensive_weight, 0.0, 1.0)?;
        require(
            self.defensive_weight > 0.0,
            "moves.defensive_weight",
            || "must be > 0".into(),
        )?;
        require(
            (1..=MAX_MH_STEPS).contains(&self.mh_steps),
            "moves.mh_steps",
            || format!("must lie in 1..={MAX_MH_STEPS}, got {}", self.mh_steps),
        )
    }

    /// The papers' search box of offsets from the cloud's centre: `± max(bound_sigmas ·
    /// cloud_sigma_d, motion_sigma_d)` per dimension.
    ///
    /// # Errors
    /// [`Error::InvalidBounds`] when a half-width is zero or not finite (a cloud without
    /// spread and a step without motion noise).
    pub fn bounds(&self, cloud_sigma: &[f64], motion_sigma: &[f64]) -> Result<Bounds> {
        let half_widths: Vec<f64> = cloud_sigma
            .iter()
            .zip(motion_sigma)
            .map(|(c, m)| (self.bound_sigmas * c).max(*m))
            .collect();
        Bounds::symmetric(&half_widths)
    }
}

/// How one particle's log-weight increment of a filter step is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum WeightBasis {
    /// The observation log-likelihood at the particle's final position (the bootstrap
    /// filter, FastSLAM 1.0, and the papers' optimisers).
    #[default]
    FinalPosition,
    /// This log-weight increment, already computed: FastSLAM 2.0's marginal likelihood
    /// under the combined covariance.
    Given(f64),
    /// The observation log-likelihood at the final position plus this term: an
    /// importance-weight correction `log N(x; x̂, P) − log q(x)` of a state drawn from a
    /// proposal `q` ([`MoveCorrection::Proposal`]).
    Corrected(f64),
}

impl WeightBasis {
    /// The increment, given the observation log-likelihood at the final position (only
    /// read for [`FinalPosition`](Self::FinalPosition) and
    /// [`Corrected`](Self::Corrected)).
    pub fn increment(self, log_likelihood_at_final: f64) -> f64 {
        match self {
            Self::FinalPosition => log_likelihood_at_final,
            Self::Given(increment) => increment,
            Self::Corrected(correction) => log_likelihood_at_final + correction,
        }
    }
}

/// Counts of what the moves did, summed over the steps of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MoveStats {
    /// Filter steps in which the optimiser ran.
    pub steps: u64,
    /// Proposed moves: particles the papers' optimiser moved, particles drawn from the
    /// optimised proposal, or Metropolis–Hastings proposals.
    pub proposed: u64,
    /// Proposed moves that were kept (all of them but rejected Metropolis–Hastings
    /// proposals).
    pub accepted: u64,
    /// Fitness evaluations, including each run's initial population.
    pub evaluations: u64,
}

impl std::ops::Add for MoveStats {
    type Output = Self;

    /// The counts of two runs together.
    fn add(self, other: Self) -> Self {
        Self {
            steps: self.steps + other.steps,
            proposed: self.proposed + other.proposed,
            accepted: self.accepted + other.accepted,
            evaluations: self.evaluations + other.evaluations,
        }
    }
}

impl std::ops::AddAssign for MoveStats {
    fn add_assign(&mut self, other: Self) {
        *self = *self + other;
    }
}

/// The optimiser of a filter with its move settings.
#[derive(Debug)]
pub struct Mover {
    /// The papers' mode: one optimiser over the whole cloud, whose persistent state (ICOA's
    /// chaotic sequence) carries over from step to step.
    cloud: Box<dyn Optimiser>,
    /// The corrected modes build one optimiser per particle and step from this.
    optimiser: OptimiserConfig,
    config: MoveConfig,
    stats: MoveStats,
}

impl Mover {
    /// The optimiser `optimiser` selects with the move settings `config`, or `None` for
    /// `kind = "none"`. ICOA's chaotic sequence of the papers' mode is seeded from `rng`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad optimiser constant or move setting.
    pub fn new(
        optimiser: &OptimiserConfig,
        config: MoveConfig,
        rng: &mut SimRng,
    ) -> Result<Option<Self>> {
        config.validate()?;
        Ok(optimiser.build(rng)?.map(|cloud| Self {
            cloud,
            optimiser: optimiser.clone(),
            config,
            stats: MoveStats::default(),
        }))
    }

    /// The move settings.
    pub fn config(&self) -> &MoveConfig {
        &self.config
    }

    /// The optimiser's configuration.
    pub fn optimiser(&self) -> &OptimiserConfig {
        &self.optimiser
    }

    /// What the moves did so far.
    pub fn stats(&self) -> MoveStats {
        self.stats
    }

    /// Adds counts of moves made outside [`Mover::run`] (per-particle work collected by
    /// the filter).
    pub fn record(&mut self, stats: MoveStats) {
        self.stats += stats;
    }

    /// A fresh optimiser for one particle's search (corrected modes); ICOA seeds its
    /// chaotic sequence from `rng`.
    fn local_optimiser(&self, rng: &mut SimRng) -> Result<Box<dyn Optimiser>> {
        self.optimiser
            .build(rng)?
            .ok_or_else(|| Error::InvalidParameter {
                name: "optimizer.kind",
                reason: "a corrected move needs an optimiser".into(),
            })
    }
}
