//! Moving a particle cloud with an optimiser (ALGORITHMS.md §3), shared by FastSLAM's pose
//! refiner and the generic particle filter, so both run the very same search, fitness and
//! correction.
//!
//! - **Search space.** Member `i` is particle `i`; its decision vector is its offset from the
//!   centre of the predicted cloud, inside `± bound_sigmas · σ` of the cloud per dimension,
//!   never narrower than one step's motion noise ([`MoveConfig::bounds`]).
//! - **Fitness** (minimised): `F(x) = −log p(z | x) − λ · log prior(x)` where
//!   `log prior(x) = −(x − x̂)ᵀ P⁻¹ (x − x̂) / 2` is the Gaussian motion prior's exponent
//!   around the particle's own noise-free prediction `x̂` ([`MoveTarget`]); `λ = 0` is the
//!   papers' likelihood-only fitness.
//! - **Weights.** Each particle's weight increment of the step is described by a
//!   [`WeightBasis`]; see [`MoveCorrection`] for what each correction does to it.
//!
//! # What the Metropolis–Hastings correction is, and is not
//!
//! With [`MoveCorrection::Mh`], the optimiser's final position `x'` of member `i` is treated
//! as a proposal from its start `x` and accepted with probability
//! `min(1, π(x') / π(x))`, where `π(x) ∝ p(z | x) · N(x; x̂, P)` is the particle's posterior
//! for this step — always with the full motion prior, whatever `λ` the optimiser used. A
//! rejected move leaves the particle where the prediction put it. Accepted or not, the
//! particle keeps the weight it had before the move (the likelihood at its start, or the
//! proposal's weight): a move that leaves `π` invariant does not change the weights, and
//! re-weighing at the moved position would count the observation twice.
//!
//! The limit: that acceptance ratio is the Metropolis–Hastings ratio of a *symmetric*
//! proposal, `q(x' | x) = q(x | x')`. The optimiser's move is not symmetric — it is a
//! deterministic-looking descent driven by the whole population, whose reverse move has
//! no computable density — so the corrected filter is not an exact sampler of `π`. It
//! rejects the moves that lower the posterior density (which a greedy likelihood-only
//! optimiser makes whenever it trades prior for likelihood) and keeps the weights honest,
//! but it still pulls accepted particles toward the mode. The metrics (NEES, the 90 %
//! interval's coverage) show how much.
//!
//! A consequence worth knowing: with `λ = 1` the fitness *is* `−log π` (up to a constant),
//! so the greedy optimisers (COA, ICOA, BA, IBA) only ever keep moves that raise `π`, and
//! the test accepts every one of them; it rejects only moves of the always-moving
//! optimisers (GWO, QPSO, PSO) that went downhill, and, with `λ < 1`, moves that trade
//! prior for likelihood. It cannot undo the collapse of the cloud onto each particle's
//! mode.

use crate::check::{named_choices, non_negative, positive};
use crate::optimise::{Bounds, Optimiser, OptimiserConfig, Population, Problem};
use crate::rng::SimRng;
use crate::{Error, Result};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// What an optimiser's move does to the particle's weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MoveCorrection {
    /// The papers' scheme: every move is kept and the weights are computed at the final
    /// positions. Moving particles toward high likelihood and then weighing them by it
    /// makes the filter over-confident (ALGORITHMS.md §3).
    #[default]
    None,
    /// Metropolis–Hastings accept/reject of each move against likelihood × motion prior,
    /// weights from before the move; see the module documentation for its limits.
    Mh,
}

named_choices!(MoveCorrection, "move_correction", { None => "none", Mh => "mh" });

/// How a filter moves its particles with an optimiser (ALGORITHMS.md §3).
///
/// ```toml
/// bound_sigmas = 3.0
/// prior_weight = 1.0
/// correction = "mh"
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MoveConfig {
    /// Half-width of the search box per dimension in standard deviations of the predicted
    /// cloud (dimensionless, > 0); §3 default 3.
    pub bound_sigmas: f64,
    /// `λ`, the weight of the motion-prior term in the fitness (dimensionless, ≥ 0); §3
    /// default 1, 0 = the papers' likelihood-only fitness.
    pub prior_weight: f64,
    /// What a move does to the weights: `none` (the papers) or `mh`.
    pub correction: MoveCorrection,
}

impl Default for MoveConfig {
    fn default() -> Self {
        Self {
            bound_sigmas: 3.0,
            prior_weight: 1.0,
            correction: MoveCorrection::None,
        }
    }
}

impl MoveConfig {
    /// Checks the ranges.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `moves.bound_sigmas` (not finite and > 0) or
    /// `moves.prior_weight` (not finite and ≥ 0).
    pub fn validate(&self) -> Result<()> {
        positive("moves.bound_sigmas", self.bound_sigmas)?;
        non_negative("moves.prior_weight", self.prior_weight)
    }

    /// The §3 search box of offsets from the cloud's centre: `± max(bound_sigmas ·
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
    /// under the combined covariance, or the likelihood before a corrected move.
    Given(f64),
}

/// What a [`Mover`] needs to know about the particles of one step: per member, the
/// observation log-likelihood and the motion prior at a candidate offset from the cloud's
/// centre. Member `i` is particle `i`.
pub trait MoveTarget: Sync {
    /// `log p(z | x)` of member `member` (with its own map, in FastSLAM) at `offset`.
    fn log_likelihood(&self, member: usize, offset: &[f64]) -> f64;

    /// `−(x − x̂ᵢ)ᵀ Pᵢ⁻¹ (x − x̂ᵢ) / 2` at `offset`: the exponent of member `member`'s Gaussian
    /// motion prior around its own noise-free prediction (0 there).
    fn log_prior(&self, member: usize, offset: &[f64]) -> f64;

    /// Whether evaluations are worth spreading over rayon's threads
    /// ([`Problem::parallel`]): true unless one evaluation costs only nanoseconds.
    fn parallel(&self) -> bool {
        true
    }
}

/// The §3 fitness of a [`MoveTarget`] over a box: `−log p(z | x) − λ · log prior(x)`.
struct Fitness<'a> {
    target: &'a dyn MoveTarget,
    bounds: Bounds,
    prior_weight: f64,
}

impl Fitness<'_> {
    /// `log p(z | x)` recovered from a fitness value at `x` (cheaper than evaluating the
    /// likelihood again; exact up to rounding).
    fn log_likelihood(&self, member: usize, x: &[f64], fitness: f64) -> f64 {
        -fitness - self.prior_weight * self.target.log_prior(member, x)
    }
}

impl Problem for Fitness<'_> {
    fn bounds(&self) -> &Bounds {
        &self.bounds
    }

    fn fitness(&self, member: usize, x: &[f64]) -> f64 {
        -self.target.log_likelihood(member, x)
            - self.prior_weight * self.target.log_prior(member, x)
    }

    fn parallel(&self) -> bool {
        self.target.parallel()
    }
}

/// Counts of what the moves did, summed over the steps of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MoveStats {
    /// Filter steps in which the optimiser ran.
    pub steps: u64,
    /// Particles the optimiser moved (proposed moves).
    pub proposed: u64,
    /// Proposed moves that were kept (all of them without correction).
    pub accepted: u64,
    /// Fitness evaluations, including each step's initial population.
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

/// The optimiser of a filter with its §3 settings: runs one move per filter step.
#[derive(Debug)]
pub struct Mover {
    optimiser: Box<dyn Optimiser>,
    iterations: usize,
    config: MoveConfig,
    stats: MoveStats,
}

impl Mover {
    /// The optimiser `optimiser` selects with the move settings `config`, or `None` for
    /// `kind = "none"`. ICOA's chaotic sequence is seeded from `rng`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad optimiser constant or move setting.
    pub fn new(
        optimiser: &OptimiserConfig,
        config: MoveConfig,
        rng: &mut SimRng,
    ) -> Result<Option<Self>> {
        config.validate()?;
        Ok(optimiser.build(rng)?.map(|built| Self {
            optimiser: built,
            iterations: optimiser.iterations,
            config,
            stats: MoveStats::default(),
        }))
    }

    /// The move settings.
    pub fn config(&self) -> &MoveConfig {
        &self.config
    }

    /// What the moves did so far.
    pub fn stats(&self) -> MoveStats {
        self.stats
    }

    /// One move of the cloud: runs the optimiser for `K` generations from the offsets
    /// `start` (row-major, one row per particle, possibly outside `bounds`), applies the
    /// correction, and updates each particle's `basis` (see [`MoveCorrection`]). Returns
    /// every particle's offset after the move; draws the optimiser's and the acceptance
    /// test's random numbers from `rng`, in particle order.
    ///
    /// # Errors
    /// [`Error::PopulationMismatch`] when `start` does not fit `bounds` or `basis`, or
    /// holds a non-finite coordinate.
    ///
    /// # Performance
    /// `N` fitness evaluations for the start plus the optimiser's per generation (see
    /// [`crate::optimise`]); each evaluation is one likelihood and one prior.
    pub fn run(
        &mut self,
        target: &dyn MoveTarget,
        bounds: Bounds,
        start: Vec<f64>,
        basis: &mut [WeightBasis],
        rng: &mut SimRng,
    ) -> Result<Vec<f64>> {
        let dim = bounds.dim();
        if start.len() != basis.len() * dim {
            return Err(Error::PopulationMismatch {
                reason: format!(
                    "{} coordinates for {} particles of dimension {dim}",
                    start.len(),
                    basis.len()
                ),
            });
        }
        let problem = Fitness {
            target,
            bounds,
            prior_weight: self.config.prior_weight,
        };
        let mut population = Population::evaluate(&problem, start.clone())?;
        let initial_fitness = population.fitness().to_vec();
        let summary = self
            .optimiser
            .run(&problem, &mut population, self.iterations, rng)?;
        self.stats.steps += 1;
        self.stats.evaluations += summary.evaluations + basis.len() as u64;
        self.stats.proposed += summary.moved as u64;

        let mut offsets = start;
        for (i, weight) in basis.iter_mut().enumerate() {
            let row = i * dim..(i + 1) * dim;
            let moved = population.moved()[i];
            match self.config.correction {
                MoveCorrection::None => {
                    *weight = WeightBasis::FinalPosition;
                    if moved {
                        offsets[row].copy_from_slice(population.position(i));
                        self.stats.accepted += 1;
                    }
                }
                MoveCorrection::Mh if moved => {
                    let (from, to) = (&offsets[row.clone()], population.position(i));
                    let before = problem.log_likelihood(i, from, initial_fitness[i]);
                    let after = problem.log_likelihood(i, to, population.fitness()[i]);
                    let log_ratio =
                        after + target.log_prior(i, to) - before - target.log_prior(i, from);
                    // ln u < log ratio with u in (0, 1]: a NaN ratio (−∞ − −∞) rejects.
                    if (1.0 - rng.random::<f64>()).ln() < log_ratio {
                        if *weight == WeightBasis::FinalPosition {
                            *weight = WeightBasis::Given(before);
                        }
                        offsets[row].copy_from_slice(to);
                        self.stats.accepted += 1;
                    }
                }
                MoveCorrection::Mh => {}
            }
        }
        Ok(offsets)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimise::OptimiserKind;
    use crate::rng::seeded;

    /// A 1-D Gaussian world: likelihood N(z; x, r), prior N(x; x̂ᵢ, p) per member.
    struct Gaussian {
        z: f64,
        r: f64,
        p: f64,
        predictions: Vec<f64>,
    }

    impl Gaussian {
        /// `members` particles all predicted at 0.
        fn new(z: f64, r: f64, p: f64, members: usize) -> Self {
            Self {
                z,
                r,
                p,
                predictions: vec![0.0; members],
            }
        }
    }

    impl MoveTarget for Gaussian {
        fn log_likelihood(&self, _: usize, x: &[f64]) -> f64 {
            -0.5 * (x[0] - self.z).powi(2) / self.r
        }

        fn log_prior(&self, member: usize, x: &[f64]) -> f64 {
            -0.5 * (x[0] - self.predictions[member]).powi(2) / self.p
        }
    }

    fn mover(kind: OptimiserKind, correction: MoveCorrection, prior_weight: f64) -> Mover {
        let optimiser = OptimiserConfig {
            kind,
            ..OptimiserConfig::default()
        };
        let config = MoveConfig {
            correction,
            prior_weight,
            ..MoveConfig::default()
        };
        Mover::new(&optimiser, config, &mut seeded(1))
            .unwrap()
            .unwrap()
    }

    #[test]
    fn bounds_are_the_wider_of_the_cloud_and_the_motion_noise() {
        let config = MoveConfig::default();
        let b = config.bounds(&[1.0, 0.01], &[0.5, 0.2]).unwrap();
        assert_eq!(b.upper(), &[3.0, 0.2]);
        assert_eq!(b.lower(), &[-3.0, -0.2]);
        assert!(config.bounds(&[0.0], &[0.0]).is_err());
    }

    #[test]
    fn names_parse_and_unknown_ones_list_the_choices() {
        for c in MoveCorrection::ALL {
            assert_eq!(c.to_string().parse::<MoveCorrection>().unwrap(), c);
        }
        let err = "metropolis"
            .parse::<MoveCorrection>()
            .unwrap_err()
            .to_string();
        assert!(err.contains("none, mh"), "{err}");
        let bad = MoveConfig {
            bound_sigmas: 0.0,
            ..MoveConfig::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(Error::InvalidParameter {
                name: "moves.bound_sigmas",
                ..
            })
        ));
    }

    /// One move of `start` with `mover` in the box ±max(3 · 1, 0.1) = ±3.
    fn move_once(
        mover: &mut Mover,
        target: &Gaussian,
        start: &[f64],
        basis: &mut [WeightBasis],
        seed: u64,
    ) -> Vec<f64> {
        let bounds = MoveConfig::default().bounds(&[1.0], &[0.1]).unwrap();
        mover
            .run(target, bounds, start.to_vec(), basis, &mut seeded(seed))
            .unwrap()
    }

    #[test]
    fn uncorrected_moves_reach_the_likelihood_peak_and_weigh_at_the_final_position() {
        // λ = 0: the papers' fitness, every particle heads for z = 2.
        let target = Gaussian::new(2.0, 0.01, 1.0, 20);
        let start: Vec<f64> = (0..20).map(|i| -1.0 + 0.1 * i as f64).collect();
        let mut basis = vec![WeightBasis::Given(-1.0); 20];
        let mut m = mover(OptimiserKind::Pso, MoveCorrection::None, 0.0);
        let end = move_once(&mut m, &target, &start, &mut basis, 2);
        let mean = end.iter().sum::<f64>() / 20.0;
        assert!((mean - 2.0).abs() < 0.1, "{mean}");
        assert!(basis.iter().all(|b| *b == WeightBasis::FinalPosition));
        assert_eq!(m.stats().accepted, m.stats().proposed);
    }

    #[test]
    fn metropolis_hastings_rejects_moves_that_lower_the_posterior_and_keeps_the_weights() {
        // λ = 0 pulls toward z = 2, but the prior N(0, 0.01) makes that far less probable:
        // the posterior mode is at 2/101 ≈ 0.02; far moves must be rejected.
        let target = Gaussian::new(2.0, 1.0, 0.01, 30);
        let start: Vec<f64> = (0..30).map(|i| -0.15 + 0.01 * i as f64).collect();
        let mut basis = vec![WeightBasis::FinalPosition; 30];
        basis[0] = WeightBasis::Given(-7.0);
        let mut m = mover(OptimiserKind::Coa, MoveCorrection::Mh, 0.0);
        let end = move_once(&mut m, &target, &start, &mut basis, 3);
        let stats = m.stats();
        assert!(
            stats.proposed > 0 && stats.accepted < stats.proposed,
            "{stats:?}"
        );
        assert!(end.iter().all(|x| x.abs() < 0.6), "{end:?}");
        for i in 0..30 {
            if end[i] == start[i] {
                assert!(i == 0 || basis[i] == WeightBasis::FinalPosition);
            } else if i > 0 {
                let before = target.log_likelihood(i, &start[i..=i]);
                assert_eq!(basis[i], WeightBasis::Given(before), "member {i}");
            }
        }
        assert_eq!(basis[0], WeightBasis::Given(-7.0), "a given weight is kept");
    }

    #[test]
    fn with_the_full_prior_in_the_fitness_greedy_moves_always_pass_the_test() {
        // The limit of the correction: with λ = 1 the fitness is −log π, so a greedy
        // optimiser only ever proposes moves that raise π, and the test accepts them all.
        let target = Gaussian::new(2.0, 1.0, 0.01, 30);
        let start: Vec<f64> = (0..30).map(|i| -0.15 + 0.01 * i as f64).collect();
        let mut basis = vec![WeightBasis::FinalPosition; 30];
        let mut m = mover(OptimiserKind::Coa, MoveCorrection::Mh, 1.0);
        move_once(&mut m, &target, &start, &mut basis, 3);
        let stats = m.stats();
        assert!(stats.proposed > 0, "{stats:?}");
        assert_eq!(stats.accepted, stats.proposed);
    }

    #[test]
    fn start_must_fit_the_particles() {
        let target = Gaussian::new(0.0, 1.0, 1.0, 3);
        let mut m = mover(OptimiserKind::Gwo, MoveCorrection::None, 1.0);
        let bounds = Bounds::symmetric(&[1.0]).unwrap();
        let mut basis = vec![WeightBasis::FinalPosition; 3];
        assert!(matches!(
            m.run(&target, bounds, vec![0.0; 2], &mut basis, &mut seeded(0)),
            Err(Error::PopulationMismatch { .. })
        ));
    }
}
