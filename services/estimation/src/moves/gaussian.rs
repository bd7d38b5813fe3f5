//! Gaussian densities of small fixed dimension and the defensive mixture that the
//! corrected optimiser modes propose from (docs/ALGORITHMS.md §3.1).
//!
//! Everything here works in *offset* coordinates: a particle's state minus its own
//! prediction `x̂` (heading wrapped by the caller), so the motion prior is `N(0, P)`.

use crate::rng::SimRng;
use nalgebra::{SMatrix, SVector};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::f64::consts::TAU;

/// A Gaussian `N(μ, Σ)` with its Cholesky factor, ready to evaluate and sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Gaussian<const D: usize> {
    mean: SVector<f64, D>,
    covariance: SMatrix<f64, D, D>,
    /// Lower Cholesky factor `L`, `Σ = L Lᵀ`.
    factor: SMatrix<f64, D, D>,
    /// `−½ log det(2πΣ)`.
    log_normaliser: f64,
}

impl<const D: usize> Gaussian<D> {
    /// `N(mean, covariance)`; `None` when the covariance is not symmetric positive
    /// definite or anything is not finite.
    pub fn new(mean: SVector<f64, D>, covariance: SMatrix<f64, D, D>) -> Option<Self> {
        if !(mean.iter().all(|v| v.is_finite()) && covariance.iter().all(|v| v.is_finite())) {
            return None;
        }
        let covariance = 0.5 * (covariance + covariance.transpose());
        let factor = covariance.cholesky()?.l();
        let log_det: f64 = factor.diagonal().iter().map(|d| 2.0 * d.ln()).sum();
        let log_normaliser = -0.5 * (D as f64 * TAU.ln() + log_det);
        log_normaliser.is_finite().then_some(Self {
            mean,
            covariance,
            factor,
            log_normaliser,
        })
    }

    /// The mean `μ`.
    pub fn mean(&self) -> &SVector<f64, D> {
        &self.mean
    }

    /// The covariance `Σ`.
    pub fn covariance(&self) -> &SMatrix<f64, D, D> {
        &self.covariance
    }

    /// `log N(x; μ, Σ)`.
    ///
    /// # Performance
    /// One triangular solve: O(D²).
    pub fn log_density(&self, x: &SVector<f64, D>) -> f64 {
        let d = x - self.mean;
        let w = self
            .factor
            .solve_lower_triangular(&d)
            .unwrap_or_else(|| SVector::repeat(f64::INFINITY));
        self.log_normaliser - 0.5 * w.norm_squared()
    }

    /// One draw `μ + L e`, `e ~ N(0, I)` (`D` standard normal draws from `rng`).
    pub fn sample(&self, rng: &mut SimRng) -> SVector<f64, D> {
        let e = SVector::<f64, D>::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
        self.mean + self.factor * e
    }
}

/// The defensive mixture `q = α N(x*, κΣ*) + (1 − α) N(0, P)` (docs/ALGORITHMS.md §3.1):
/// the Laplace Gaussian at the optimiser's optimum, mixed with the motion prior so that a
/// second mode of the target that the optimum missed is still proposed as often as the
/// bootstrap filter would propose it.
#[derive(Debug, Clone, PartialEq)]
pub struct Defensive<const D: usize> {
    optimum: Gaussian<D>,
    prior: Gaussian<D>,
    /// `ln α` and `ln(1 − α)`; the prior part is skipped when `α = 1`.
    log_alpha: f64,
    log_rest: f64,
    alpha: f64,
}

impl<const D: usize> Defensive<D> {
    /// The mixture of `optimum` (weight `alpha` in (0, 1]) and `prior`.
    pub fn new(optimum: Gaussian<D>, prior: Gaussian<D>, alpha: f64) -> Self {
        Self {
            optimum,
            prior,
            log_alpha: alpha.ln(),
            log_rest: (1.0 - alpha).ln(),
            alpha,
        }
    }

    /// The Gaussian at the optimum.
    pub fn optimum(&self) -> &Gaussian<D> {
        &self.optimum
    }

    /// `log q(x)`.
    pub fn log_density(&self, x: &SVector<f64, D>) -> f64 {
        let a = self.log_alpha + self.optimum.log_density(x);
        if self.alpha >= 1.0 {
            return a;
        }
        let b = self.log_rest + self.prior.log_density(x);
        let max = a.max(b);
        if max == f64::NEG_INFINITY {
            return max;
        }
        max + ((a - max).exp() + (b - max).exp()).ln()
    }

    /// One draw: from the optimum's Gaussian with probability `α`, else from the prior
    /// (one uniform and `D` standard normal draws from `rng`).
    pub fn sample(&self, rng: &mut SimRng) -> SVector<f64, D> {
        if rng.random::<f64>() < self.alpha {
            self.optimum.sample(rng)
        } else {
            self.prior.sample(rng)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::seeded;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn log_density_is_the_normal_density() {
        let g = Gaussian::new(Vector2::new(1.0, -2.0), Matrix2::new(4.0, 1.0, 1.0, 2.0)).unwrap();
        let x = Vector2::new(0.5, -1.0);
        let s = g.covariance();
        let d = x - g.mean();
        let expected = -0.5 * (d.transpose() * s.try_inverse().unwrap() * d)[0]
            - TAU.ln()
            - 0.5 * s.determinant().ln();
        assert!((g.log_density(&x) - expected).abs() < 1e-12);
    }

    #[test]
    fn not_positive_definite_or_not_finite_is_refused() {
        assert!(Gaussian::new(Vector2::zeros(), Matrix2::new(1.0, 2.0, 2.0, 1.0)).is_none());
        assert!(Gaussian::new(Vector2::new(f64::NAN, 0.0), Matrix2::identity()).is_none());
        assert!(Gaussian::new(Vector2::zeros(), Matrix2::zeros()).is_none());
    }

    #[test]
    fn samples_have_the_mean_and_covariance() {
        let g = Gaussian::new(Vector2::new(3.0, 1.0), Matrix2::new(2.0, 0.6, 0.6, 0.5)).unwrap();
        let mut rng = seeded(4);
        let n = 40_000;
        let draws: Vec<_> = (0..n).map(|_| g.sample(&mut rng)).collect();
        let mean = draws.iter().sum::<Vector2<f64>>() / n as f64;
        let cov = draws
            .iter()
            .map(|x| (x - mean) * (x - mean).transpose())
            .sum::<Matrix2<f64>>()
            / n as f64;
        assert!((mean - g.mean()).norm() < 0.03, "{mean}");
        assert!((cov - g.covariance()).norm() < 0.05, "{cov}");
    }

    #[test]
    fn mixture_density_integrates_to_one_and_sampling_follows_it() {
        // 1-D: integrate on a grid; the share of draws near each component follows α.
        let optimum = Gaussian::new(SVector::<f64, 1>::new(4.0), SMatrix::<f64, 1, 1>::new(0.25));
        let prior = Gaussian::new(SVector::<f64, 1>::new(0.0), SMatrix::<f64, 1, 1>::new(1.0));
        let q = Defensive::new(optimum.unwrap(), prior.unwrap(), 0.8);
        let h = 1e-3;
        let integral: f64 = (-10_000..20_000)
            .map(|k| q.log_density(&SVector::<f64, 1>::new(k as f64 * h)).exp() * h)
            .sum();
        assert!((integral - 1.0).abs() < 1e-6, "{integral}");
        let mut rng = seeded(9);
        let near_optimum =
            (0..20_000).filter(|_| q.sample(&mut rng)[0] > 2.5).count() as f64 / 20_000.0;
        // P(x > 2.5) = 0.8 · Φ(3) + 0.2 · (1 − Φ(2.5)) ≈ 0.7989 + 0.0012.
        assert!((near_optimum - 0.800).abs() < 0.01, "{near_optimum}");
    }
}
