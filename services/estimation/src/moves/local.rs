//! The corrected modes (docs/ALGORITHMS.md §3.1): the optimiser serves **one particle at a
//! time**, and its answer becomes a proposal density.
//!
//! Per particle, in offset coordinates `o = x − x̂` around its own prediction (so its
//! motion prior is `N(0, P)`):
//! 1. **Search.** The population is [`MoveConfig::candidates`](super::MoveConfig::candidates)
//!    candidate states for this particle alone: `x̂` itself, any extra starts the caller
//!    has (the pose FastSLAM 2.0 drew), and the optimiser's own initial draws in the box
//!    `± bound_sigmas · √P_dd`. The optimiser minimises
//!    `F(o) = −log p(z | o) + λ oᵀ P⁻¹ o / 2` for `K` generations; `o*` is the best
//!    candidate seen.
//! 2. **Laplace.** `Σ* = κ (I(o*) + P⁻¹)⁻¹`, with `I = Σⱼ Hⱼᵀ Sⱼ⁻¹ Hⱼ` the Gauss–Newton
//!    information of the observations at `o*` ([`LocalTarget::information`]).
//! 3. **Proposal** `q = α N(o*, Σ*) + (1 − α) N(0, P)` ([`Defensive`]).
//!
//! Then either (`proposal`) draw `o ~ q` and weigh by
//! `log p(z | o) + log N(o; 0, P) − log q(o)` ([`Laplace::draw`]: the caller adds the
//! likelihood), or (`resample-move`) take Metropolis–Hastings steps from the particle's
//! state toward `π(o) ∝ p(z | o) N(o; 0, P)` with `q` as an independence proposal
//! ([`Laplace::rejuvenate`]). Both are correct whatever `o*` is: a poor optimum only
//! costs weight variance (or acceptance rate).
//!
//! Each particle's search builds its own optimiser from the configuration and draws from
//! the stream the caller hands it, so particles can be searched in parallel with
//! bit-identical results. ICOA's chaotic sequence is therefore seeded per particle and
//! step from that stream instead of running on across the filter.

use super::Mover;
use super::gaussian::{Defensive, Gaussian};
use crate::optimise::{Bounds, Population, Problem};
use crate::rng::SimRng;
use crate::{Error, Result};
use nalgebra::{SMatrix, SVector};
use rand::RngExt;

/// One particle's target in offset coordinates `o = x − x̂` (heading wrapped by the
/// implementation).
pub trait LocalTarget<const D: usize>: Sync {
    /// `log p(z | x̂ + o)`, with the particle's own map in FastSLAM.
    fn log_likelihood(&self, offset: &SVector<f64, D>) -> f64;

    /// Gauss–Newton information `Σⱼ Hⱼᵀ Sⱼ⁻¹ Hⱼ` of the observations at `offset`, `Hⱼ`
    /// the Jacobian of observation `j` with respect to the state and `Sⱼ` its innovation
    /// covariance given the state; zero when no observation depends on the state.
    fn information(&self, offset: &SVector<f64, D>) -> SMatrix<f64, D, D>;
}

/// The fitness `F(o) = −log p(z | o) + λ oᵀ P⁻¹ o / 2` over the particle's box.
struct LocalFitness<'a, const D: usize> {
    target: &'a dyn LocalTarget<D>,
    bounds: Bounds,
    prior_information: SMatrix<f64, D, D>,
    prior_weight: f64,
}

impl<const D: usize> Problem for LocalFitness<'_, D> {
    fn bounds(&self) -> &Bounds {
        &self.bounds
    }

    fn fitness(&self, _: usize, x: &[f64]) -> f64 {
        let o = SVector::<f64, D>::from_column_slice(x);
        let prior = 0.5 * (o.transpose() * self.prior_information * o)[0];
        -self.target.log_likelihood(&o) + self.prior_weight * prior
    }

    /// One particle's population is small; the filter parallelises over particles.
    fn parallel(&self) -> bool {
        false
    }
}

/// One particle's optimised proposal: the defensive mixture around the optimiser's
/// optimum, and the motion prior `N(0, P)` of the target.
#[derive(Debug, Clone, PartialEq)]
pub struct Laplace<const D: usize> {
    proposal: Defensive<D>,
    prior: Gaussian<D>,
    /// Fitness evaluations the search made, its initial population included.
    pub evaluations: u64,
}

impl<const D: usize> Laplace<D> {
    /// The optimiser's optimum `o*` (offset from the prediction).
    pub fn optimum(&self) -> &SVector<f64, D> {
        self.proposal.optimum().mean()
    }

    /// The Laplace covariance `κΣ*` at the optimum.
    pub fn covariance(&self) -> &SMatrix<f64, D, D> {
        self.proposal.optimum().covariance()
    }

    /// `log N(o; 0, P) − log q(o)`: what the importance weight of a state drawn from `q`
    /// adds to its observation log-likelihood.
    pub fn log_correction(&self, offset: &SVector<f64, D>) -> f64 {
        self.prior.log_density(offset) - self.proposal.log_density(offset)
    }

    /// `proposal` mode: draws `o ~ q` and returns it with [`log_correction`](Self::log_correction).
    pub fn draw(&self, rng: &mut SimRng) -> (SVector<f64, D>, f64) {
        let offset = self.proposal.sample(rng);
        (offset, self.log_correction(&offset))
    }

    /// `resample-move` mode: `steps` Metropolis–Hastings steps from `from` toward
    /// `π(o) ∝ p(z | o) N(o; 0, P)`, each proposing `o′ ~ q` independently of the current
    /// state and accepting with probability
    /// `min(1, π(o′) q(o) / (π(o) q(o′)))`. Returns the final offset and the number of
    /// accepted proposals. `q` must not depend on `from` (do not search from it): an
    /// independence sampler is only invariant when its proposal is.
    ///
    /// # Performance
    /// `steps + 1` likelihood evaluations.
    pub fn rejuvenate(
        &self,
        target: &dyn LocalTarget<D>,
        from: SVector<f64, D>,
        steps: usize,
        rng: &mut SimRng,
    ) -> (SVector<f64, D>, u64) {
        let log_ratio = |o: &SVector<f64, D>| {
            target.log_likelihood(o) + self.prior.log_density(o) - self.proposal.log_density(o)
        };
        let (mut current, mut current_ratio) = (from, log_ratio(&from));
        let mut accepted = 0;
        for _ in 0..steps {
            let candidate = self.proposal.sample(rng);
            let candidate_ratio = log_ratio(&candidate);
            // ln u < log acceptance with u in (0, 1]; a NaN ratio rejects.
            if (1.0 - rng.random::<f64>()).ln() < candidate_ratio - current_ratio {
                current = candidate;
                current_ratio = candidate_ratio;
                accepted += 1;
            }
        }
        (current, accepted)
    }
}

impl Mover {
    /// Step 1–3 of the module documentation for one particle with motion prior
    /// `N(0, prior_covariance)`: the optimiser's search (starting from `0`, then `starts`,
    /// then its own draws), the Laplace covariance at the optimum and the defensive
    /// mixture. Draws from `rng` only.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the prior covariance is not symmetric positive
    /// definite; the optimiser's errors.
    ///
    /// # Performance
    /// `candidates` evaluations plus the optimiser's per generation
    /// ([`crate::optimise`]), then one information matrix and a `D × D` inverse.
    pub fn laplace<const D: usize>(
        &self,
        target: &dyn LocalTarget<D>,
        prior_covariance: &SMatrix<f64, D, D>,
        starts: &[SVector<f64, D>],
        rng: &mut SimRng,
    ) -> Result<Laplace<D>> {
        let not_spd = || Error::InvalidInput {
            what: "motion prior",
            reason: format!("covariance not positive definite: {prior_covariance:?}"),
        };
        let prior = Gaussian::new(SVector::zeros(), *prior_covariance).ok_or_else(not_spd)?;
        let prior_information = prior_covariance.cholesky().ok_or_else(not_spd)?.inverse();
        let half_widths: Vec<f64> = (0..D)
            .map(|d| self.config.bound_sigmas * prior_covariance[(d, d)].sqrt())
            .collect();
        let bounds = Bounds::symmetric(&half_widths)?;
        let mut optimiser = self.local_optimiser(rng)?;
        let members = self.config.candidates;
        let mut positions = Vec::with_capacity(members * D);
        for start in std::iter::once(&SVector::zeros())
            .chain(starts)
            .take(members)
        {
            let mut row: Vec<f64> = start.iter().copied().collect();
            bounds.clip(&mut row);
            positions.extend(row);
        }
        let drawn = members - positions.len() / D;
        positions.extend(optimiser.initial_positions(&bounds, drawn, rng));
        let problem = LocalFitness {
            target,
            bounds,
            prior_information,
            prior_weight: self.config.prior_weight,
        };
        let mut population = Population::evaluate(&problem, positions)?;
        let summary = optimiser.run(&problem, &mut population, self.optimiser.iterations, rng)?;
        let optimum = SVector::<f64, D>::from_column_slice(&summary.best.position);
        let information = target.information(&optimum) + prior_information;
        let laplace = information
            .cholesky()
            .map(|c| c.inverse() * self.config.inflation)
            .and_then(|covariance| Gaussian::new(optimum, covariance))
            .or_else(|| Gaussian::new(optimum, *prior_covariance))
            .ok_or_else(not_spd)?;
        Ok(Laplace {
            proposal: Defensive::new(laplace, prior.clone(), self.config.defensive_weight),
            prior,
            evaluations: summary.evaluations + members as u64,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moves::{MoveConfig, MoveCorrection};
    use crate::optimise::{OptimiserConfig, OptimiserKind};
    use crate::rng::seeded;
    use nalgebra::{Matrix1, Vector1};

    /// `y = o + v`, `v ~ N(0, r)`: a linear-Gaussian target whose posterior is known.
    struct Linear {
        y: f64,
        r: f64,
    }

    impl LocalTarget<1> for Linear {
        fn log_likelihood(&self, o: &Vector1<f64>) -> f64 {
            -0.5 * (self.y - o[0]).powi(2) / self.r
        }
        fn information(&self, _: &Vector1<f64>) -> Matrix1<f64> {
            Matrix1::new(1.0 / self.r)
        }
    }

    fn mover(kind: OptimiserKind) -> Mover {
        let optimiser = OptimiserConfig {
            kind,
            ..OptimiserConfig::default()
        };
        let config = MoveConfig {
            correction: MoveCorrection::Proposal,
            ..MoveConfig::default()
        };
        Mover::new(&optimiser, config, &mut seeded(1))
            .unwrap()
            .unwrap()
    }

    #[test]
    fn the_laplace_gaussian_of_a_linear_target_is_its_posterior() {
        // Prior N(0, 1), y = 1.5 with r = 0.5: posterior N(1, 1/3).
        let target = Linear { y: 1.5, r: 0.5 };
        for kind in OptimiserKind::ALL.into_iter().skip(1) {
            let laplace = mover(kind)
                .laplace(&target, &Matrix1::new(1.0), &[], &mut seeded(3))
                .unwrap();
            // Within a third of the posterior's σ (0.58) after 10 generations of 8 members:
            // the butterflies' small steps land furthest from the mode.
            assert!(
                (laplace.optimum()[0] - 1.0).abs() < 0.2,
                "{kind}: {laplace:?}"
            );
            assert!(
                (laplace.covariance()[0] - 1.0 / 3.0).abs() < 1e-12,
                "{kind}"
            );
            assert!(laplace.evaluations >= 8, "{kind}");
        }
    }

    #[test]
    fn draws_weighted_by_the_correction_reproduce_the_posterior() {
        // Self-normalised importance sampling with q: mean 1, variance 1/3.
        let target = Linear { y: 1.5, r: 0.5 };
        let laplace = mover(OptimiserKind::Ba)
            .laplace(&target, &Matrix1::new(1.0), &[], &mut seeded(5))
            .unwrap();
        let mut rng = seeded(6);
        let (mut sw, mut sx, mut sxx) = (0.0, 0.0, 0.0);
        for _ in 0..40_000 {
            let (o, correction) = laplace.draw(&mut rng);
            let w = (target.log_likelihood(&o) + correction).exp();
            sw += w;
            sx += w * o[0];
            sxx += w * o[0] * o[0];
        }
        let mean = sx / sw;
        let variance = sxx / sw - mean * mean;
        assert!((mean - 1.0).abs() < 0.01, "{mean}");
        assert!((variance - 1.0 / 3.0).abs() < 0.01, "{variance}");
    }

    #[test]
    fn metropolis_hastings_leaves_the_posterior_invariant() {
        // Start a chain far out; after the steps, the states follow the posterior.
        let target = Linear { y: 1.5, r: 0.5 };
        let laplace = mover(OptimiserKind::Gwo)
            .laplace(&target, &Matrix1::new(1.0), &[], &mut seeded(7))
            .unwrap();
        let mut rng = seeded(8);
        let n = 20_000;
        let states: Vec<f64> = (0..n)
            .map(|_| {
                let start = Vector1::new(1.0 + (1.0f64 / 3.0).sqrt() * 0.5);
                laplace.rejuvenate(&target, start, 3, &mut rng).0[0]
            })
            .collect();
        let mean = states.iter().sum::<f64>() / n as f64;
        let variance = states.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / n as f64;
        // A start 0.5 σ off the mean: three independence steps with acceptance ≈ 1 forget it.
        assert!((mean - 1.0).abs() < 0.02, "{mean}");
        assert!((variance - 1.0 / 3.0).abs() < 0.02, "{variance}");
    }

    #[test]
    fn a_prior_that_is_not_positive_definite_is_an_error() {
        let target = Linear { y: 0.0, r: 1.0 };
        assert!(matches!(
            mover(OptimiserKind::Coa).laplace(&target, &Matrix1::new(0.0), &[], &mut seeded(1)),
            Err(Error::InvalidInput { .. })
        ));
    }
}
