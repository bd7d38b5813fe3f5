//! Particle weights as an immutable value: normalised once from log-weights with
//! log-sum-exp, checked for NaN and degeneracy, with the effective sample size computed
//! once (docs/ALGORITHMS.md §1 step 5).

use crate::{Error, Result};

/// Normalised particle weights (they sum to 1) with their logarithms and the effective
/// sample size `N_eff = 1 / Σ wᵢ²`.
///
/// A `Weights` always holds at least one weight, no NaN, and at least one positive weight.
///
/// # Example
/// ```
/// use fastslam_estimation::weights::Weights;
/// let w = Weights::from_log(&[0.0, 0.0, f64::NEG_INFINITY]).unwrap();
/// assert_eq!(w.as_slice(), &[0.5, 0.5, 0.0]);
/// assert!((w.ess() - 2.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Weights {
    normalised: Vec<f64>,
    log_normalised: Vec<f64>,
    log_normaliser: f64,
    ess: f64,
}

impl Weights {
    /// Normalises unnormalised log-weights by log-sum-exp (`log wᵢ − log Σ exp(log wⱼ)`).
    ///
    /// −∞ entries are allowed (weight zero) as long as one entry is finite.
    ///
    /// # Errors
    /// [`Error::DegenerateWeights`] when `log_weights` is empty, contains NaN or +∞, or
    /// every entry is −∞.
    ///
    /// # Performance
    /// O(n), two passes and one allocation per output vector.
    pub fn from_log(log_weights: &[f64]) -> Result<Self> {
        let mut weights = Self {
            normalised: Vec::new(),
            log_normalised: Vec::new(),
            log_normaliser: 0.0,
            ess: 0.0,
        };
        weights.renormalise(log_weights)?;
        Ok(weights)
    }

    /// Replaces these weights by [`from_log`](Self::from_log)`(log_weights)`, reusing
    /// their buffers (the filter's step allocates no weights once they have grown to N).
    ///
    /// # Errors
    /// As [`from_log`](Self::from_log); the weights are then unchanged.
    pub fn renormalise(&mut self, log_weights: &[f64]) -> Result<()> {
        let degenerate = |reason: String| Err(Error::DegenerateWeights { reason });
        if log_weights.is_empty() {
            return degenerate("no weights".into());
        }
        if let Some(i) = log_weights.iter().position(|l| l.is_nan()) {
            return degenerate(format!("log-weight {i} is NaN"));
        }
        if let Some(i) = log_weights.iter().position(|&l| l == f64::INFINITY) {
            return degenerate(format!("log-weight {i} is +inf"));
        }
        let max = log_weights
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        if max == f64::NEG_INFINITY {
            return degenerate(format!("all {} log-weights are -inf", log_weights.len()));
        }
        let sum: f64 = log_weights.iter().map(|l| (l - max).exp()).sum();
        let log_normaliser = max + sum.ln();
        self.log_normalised.clear();
        self.log_normalised
            .extend(log_weights.iter().map(|l| l - log_normaliser));
        self.normalised.clear();
        self.normalised
            .extend(self.log_normalised.iter().map(|l| l.exp()));
        self.log_normaliser = log_normaliser;
        self.ess = 1.0 / self.normalised.iter().map(|w| w * w).sum::<f64>();
        Ok(())
    }

    /// The weights whose [`log_weights`](Self::log_weights) and
    /// [`log_normaliser`](Self::log_normaliser) were `log_normalised` and `log_normaliser`
    /// (a filter's saved state): the same numbers, bit for bit, where normalising again
    /// with [`from_log`](Self::from_log) could differ in the last bits.
    ///
    /// # Errors
    /// As [`from_log`](Self::from_log) for the log-weights, and
    /// [`Error::DegenerateWeights`] when the normaliser is not finite.
    pub fn restore(log_normalised: &[f64], log_normaliser: f64) -> Result<Self> {
        let mut weights = Self::from_log(log_normalised)?;
        if !log_normaliser.is_finite() {
            return Err(Error::DegenerateWeights {
                reason: format!("log-normaliser {log_normaliser}"),
            });
        }
        weights.log_normalised.clear();
        weights.log_normalised.extend_from_slice(log_normalised);
        weights.normalised.clear();
        (weights.normalised).extend(log_normalised.iter().map(|l| l.exp()));
        weights.log_normaliser = log_normaliser;
        weights.ess = 1.0 / weights.normalised.iter().map(|w| w * w).sum::<f64>();
        Ok(weights)
    }

    /// The normalised weights, in particle order; they sum to 1.
    pub fn as_slice(&self) -> &[f64] {
        &self.normalised
    }

    /// The logarithms of the normalised weights, in particle order.
    pub fn log_weights(&self) -> &[f64] {
        &self.log_normalised
    }

    /// `log Σ exp(log wᵢ)` of the input: the log of the normalising constant (for a
    /// filter, the log marginal likelihood increment of the step).
    pub fn log_normaliser(&self) -> f64 {
        self.log_normaliser
    }

    /// Effective sample size `N_eff = 1 / Σ wᵢ²`, in `[1, n]`.
    pub fn ess(&self) -> f64 {
        self.ess
    }

    /// Index of the largest weight (the first one on ties).
    pub fn argmax(&self) -> usize {
        self.normalised.iter().enumerate().fold(
            0,
            |best, (i, &w)| if w > self.normalised[best] { i } else { best },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_normalise_by_log_sum_exp_without_overflow() {
        let w = Weights::from_log(&[1000.0, 1000.0 + 2f64.ln()]).unwrap();
        assert!((w.as_slice()[0] - 1.0 / 3.0).abs() < 1e-12);
        assert!((w.as_slice()[1] - 2.0 / 3.0).abs() < 1e-12);
        assert!((w.log_normaliser() - (1000.0 + 3f64.ln())).abs() < 1e-9);
        assert!((w.log_weights()[1] - (2.0f64 / 3.0).ln()).abs() < 1e-12);
        assert_eq!(w.argmax(), 1);
    }

    #[test]
    fn ess_is_n_for_equal_weights_and_one_for_a_single_survivor() {
        let w = Weights::from_log(&[-3.0; 8]).unwrap();
        assert!((w.ess() - 8.0).abs() < 1e-12);
        let w = Weights::from_log(&[f64::NEG_INFINITY, 0.0, f64::NEG_INFINITY]).unwrap();
        assert_eq!(w.ess(), 1.0);
        assert_eq!(w.argmax(), 1);
    }

    #[test]
    fn restored_weights_are_the_saved_ones_bit_for_bit() {
        let w = Weights::from_log(&[0.3, -1.7, 2.9, f64::NEG_INFINITY]).unwrap();
        let r = Weights::restore(w.log_weights(), w.log_normaliser()).unwrap();
        assert_eq!(r, w);
        assert!(Weights::restore(w.log_weights(), f64::NAN).is_err());
        assert!(Weights::restore(&[f64::NAN], 0.0).is_err());
    }

    #[test]
    fn weights_reject_nan() {
        let err = Weights::from_log(&[0.0, f64::NAN, 1.0]).unwrap_err();
        assert!(matches!(err, Error::DegenerateWeights { .. }));
    }

    #[test]
    fn weights_reject_empty_positive_infinity_and_all_negative_infinity() {
        assert!(Weights::from_log(&[]).is_err());
        assert!(Weights::from_log(&[0.0, f64::INFINITY]).is_err());
        assert!(Weights::from_log(&[f64::NEG_INFINITY; 3]).is_err());
    }
}
