//! Lévy-flight steps by Mantegna's algorithm (BA and IBA, docs/ALGORITHMS.md §4.3):
//! `L = u / |v|^{1/β}` with `u ~ N(0, σ_u²)`, `v ~ N(0, 1)` and
//! `σ_u = [Γ(1+β) sin(πβ/2) / (Γ((1+β)/2) β 2^{(β−1)/2})]^{1/β}` (0.69657 for β = 1.5).
//!
//! `σ_u` is a standard deviation: libraries that pass `σ_u²` as the normal's scale shrink
//! every step by 0.7×; the tests pin the median of `|L|` so that bug would show.

use crate::rng::SimRng;
use crate::{Error, Result};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// Mantegna's `σ_u` for stability index `beta`, from the Gamma-function formula.
pub fn mantegna_sigma_u(beta: f64) -> f64 {
    let numerator = libm::tgamma(1.0 + beta) * (PI * beta / 2.0).sin();
    let denominator = libm::tgamma((1.0 + beta) / 2.0) * beta * 2f64.powf((beta - 1.0) / 2.0);
    (numerator / denominator).powf(1.0 / beta)
}

/// A Lévy step generator for one stability index β.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levy {
    beta: f64,
    sigma_u: f64,
}

impl Levy {
    /// Steps with stability index `beta` (`λ` of IBA paper eq. 7; 1.5 by convention).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] unless `0 < beta < 2` (at 2 the formula's `sin π` makes
    /// `σ_u = 0`; beyond, the distribution is not Lévy-stable).
    pub fn new(beta: f64) -> Result<Self> {
        if beta > 0.0 && beta < 2.0 {
            Ok(Self {
                beta,
                sigma_u: mantegna_sigma_u(beta),
            })
        } else {
            Err(Error::InvalidParameter {
                name: "levy_exponent",
                reason: format!("{beta} is not in (0, 2)"),
            })
        }
    }

    /// The stability index β.
    pub fn beta(&self) -> f64 {
        self.beta
    }

    /// Standard deviation `σ_u` of the numerator.
    pub fn sigma_u(&self) -> f64 {
        self.sigma_u
    }

    /// One step `L` (two standard-normal draws: `u` first, then `v`). Heavy-tailed and
    /// symmetric; `±∞` when `v` is exactly 0 (probability ≈ 0), which clipping absorbs.
    pub fn sample(&self, rng: &mut SimRng) -> f64 {
        let u = self.sigma_u * rng.sample::<f64, _>(StandardNormal);
        let v: f64 = rng.sample(StandardNormal);
        u / v.abs().powf(1.0 / self.beta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::seeded;

    #[test]
    fn sigma_u_for_beta_one_and_a_half_is_0_69657() {
        // scipy: (gamma(2.5) sin(0.75π) / (gamma(1.25) 1.5 2^0.25))^(1/1.5) = 0.6965745025576968
        assert!((mantegna_sigma_u(1.5) - 0.696_574_502_557_696_8).abs() < 1e-12);
        assert!((Levy::new(1.5).unwrap().sigma_u() - 0.69657).abs() < 5e-6);
        // β = 1: σ_u = [Γ(2) sin(π/2) / (Γ(1) · 1 · 1)] = 1, the Cauchy case.
        assert!((mantegna_sigma_u(1.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn median_and_tail_of_the_step_match_the_exact_law() {
        // Exact values by numerical integration of P(|L| ≤ t) = E_v[2Φ(t|v|^{1/β}/σ_u) − 1]
        // (scipy quad + brentq): median |L| = 0.63100; P(|L| > 10) = 0.012612. With σ_u²
        // as the scale (the library bug) the median would be 0.4395.
        let levy = Levy::new(1.5).unwrap();
        let mut rng = seeded(2024);
        let n = 100_000;
        let mut steps: Vec<f64> = (0..n).map(|_| levy.sample(&mut rng).abs()).collect();
        let beyond_ten = steps.iter().filter(|&&s| s > 10.0).count() as f64 / n as f64;
        steps.sort_by(f64::total_cmp);
        let median = steps[n / 2];
        // Standard errors ≈ 0.003 (median) and 0.00035 (tail fraction); tolerances ≈ 4σ.
        assert!((median - 0.6310).abs() < 0.013, "median |L| = {median}");
        assert!(
            (beyond_ten - 0.01261).abs() < 0.0015,
            "P(|L| > 10) = {beyond_ten}"
        );
    }

    #[test]
    fn steps_are_symmetric() {
        let levy = Levy::new(1.5).unwrap();
        let mut rng = seeded(7);
        let n = 100_000;
        let positive = (0..n).filter(|_| levy.sample(&mut rng) > 0.0).count() as f64 / n as f64;
        assert!((positive - 0.5).abs() < 0.006, "{positive}");
    }

    #[test]
    fn beta_outside_zero_two_is_rejected() {
        for bad in [0.0, 2.0, -1.0, f64::NAN] {
            assert!(Levy::new(bad).is_err(), "{bad}");
        }
    }
}
