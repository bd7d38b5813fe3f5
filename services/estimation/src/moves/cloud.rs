//! The papers' mode (docs/ALGORITHMS.md §3): the particle cloud is the optimiser's
//! population.
//!
//! - **Search space.** Member `i` is particle `i`; its decision vector is its offset from
//!   the centre of the predicted cloud, inside `± bound_sigmas · σ` of the cloud per
//!   dimension, never narrower than the particles' motion prior (the weighted mean of
//!   their `P`, accumulated since the last update; [`super::MoveConfig::bounds`]).
//! - **Fitness** (minimised): `F(x) = −log p(z | x) − λ · log prior(x)` where
//!   `log prior(x) = −(x − x̂)ᵀ P⁻¹ (x − x̂) / 2` is the Gaussian motion prior's exponent
//!   around the particle's own noise-free prediction `x̂` ([`MoveTarget`]).
//! - **Weights** are computed at the final positions ([`WeightBasis::FinalPosition`]).
//!
//! This is biased: a member's move depends on the whole population, so it has no
//! proposal density, and weighing a particle by the likelihood it was moved toward counts
//! the observation twice. The corrected modes ([`super::local`]) exist for that reason.

use super::{Mover, WeightBasis};
use crate::optimise::{Bounds, Population, Problem};
use crate::rng::SimRng;
use crate::{Error, Result};

/// What the papers' mode needs to know about the particles of one step: per member, the
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

impl Mover {
    /// One papers'-mode move of the cloud: runs the optimiser for `K` generations from the
    /// offsets `start` (row-major, one row per particle, possibly outside `bounds`) and
    /// sets every particle's `basis` to [`WeightBasis::FinalPosition`]. Returns every
    /// particle's offset after the move; draws the optimiser's random numbers from `rng`.
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
        let mut population = Population::evaluate(&problem, start)?;
        let summary = self
            .cloud
            .run(&problem, &mut population, self.optimiser.iterations, rng)?;
        self.stats.steps += 1;
        self.stats.evaluations += summary.evaluations + basis.len() as u64;
        self.stats.proposed += summary.moved as u64;
        self.stats.accepted += summary.moved as u64;
        basis.fill(WeightBasis::FinalPosition);
        Ok(population.positions().to_vec())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moves::{MoveConfig, MoveCorrection};
    use crate::optimise::{OptimiserConfig, OptimiserKind};
    use crate::rng::seeded;

    /// A 1-D Gaussian world: likelihood N(z; x, r), prior N(x; 0, p) for every member.
    struct Gaussian {
        z: f64,
        r: f64,
        p: f64,
    }

    impl MoveTarget for Gaussian {
        fn log_likelihood(&self, _: usize, x: &[f64]) -> f64 {
            -0.5 * (x[0] - self.z).powi(2) / self.r
        }

        fn log_prior(&self, _: usize, x: &[f64]) -> f64 {
            -0.5 * x[0].powi(2) / self.p
        }
    }

    fn mover(kind: OptimiserKind, prior_weight: f64) -> Mover {
        let optimiser = OptimiserConfig {
            kind,
            ..OptimiserConfig::default()
        };
        let config = MoveConfig {
            correction: MoveCorrection::None,
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
    fn moves_reach_the_likelihood_peak_and_weigh_at_the_final_position() {
        // λ = 0: the papers' fitness, every particle heads for z = 2.
        let target = Gaussian {
            z: 2.0,
            r: 0.01,
            p: 1.0,
        };
        let start: Vec<f64> = (0..20).map(|i| -1.0 + 0.1 * i as f64).collect();
        let mut basis = vec![WeightBasis::Given(-1.0); 20];
        let mut m = mover(OptimiserKind::Pso, 0.0);
        let bounds = MoveConfig::default().bounds(&[1.0], &[0.1]).unwrap();
        let end = m
            .run(&target, bounds, start, &mut basis, &mut seeded(2))
            .unwrap();
        let mean = end.iter().sum::<f64>() / 20.0;
        assert!((mean - 2.0).abs() < 0.1, "{mean}");
        assert!(basis.iter().all(|b| *b == WeightBasis::FinalPosition));
        assert_eq!(m.stats().accepted, m.stats().proposed);
    }

    #[test]
    fn start_must_fit_the_particles() {
        let target = Gaussian {
            z: 0.0,
            r: 1.0,
            p: 1.0,
        };
        let mut m = mover(OptimiserKind::Gwo, 1.0);
        let bounds = Bounds::symmetric(&[1.0]).unwrap();
        let mut basis = vec![WeightBasis::FinalPosition; 3];
        assert!(matches!(
            m.run(&target, bounds, vec![0.0; 2], &mut basis, &mut seeded(0)),
            Err(Error::PopulationMismatch { .. })
        ));
    }
}
