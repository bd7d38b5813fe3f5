//! The search box of an optimiser: per-dimension intervals, checked when built, with
//! clipping and uniform sampling.

use crate::rng::SimRng;
use crate::{Error, Result};
use rand::RngExt;

/// The search box: a finite interval `[lower_d, upper_d]` with `lower_d < upper_d` per
/// dimension, checked when built so no optimiser has to.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Bounds {
    /// Bounds from per-dimension lower and upper limits.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidBounds`] when the lengths differ, there are no dimensions, a limit is
    /// not finite (NaN, ±∞), or `lower_d ≥ upper_d`.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self> {
        if lower.len() != upper.len() {
            return Err(Error::InvalidBounds {
                reason: format!(
                    "{} lower limits but {} upper limits",
                    lower.len(),
                    upper.len()
                ),
            });
        }
        if lower.is_empty() {
            return Err(Error::InvalidBounds {
                reason: "no dimensions".into(),
            });
        }
        for (d, (&lo, &hi)) in lower.iter().zip(&upper).enumerate() {
            if !lo.is_finite() || !hi.is_finite() {
                return Err(Error::InvalidBounds {
                    reason: format!("dimension {d}: [{lo}, {hi}] is not finite"),
                });
            }
            if lo >= hi {
                return Err(Error::InvalidBounds {
                    reason: format!("dimension {d}: lower {lo} is not below upper {hi}"),
                });
            }
        }
        Ok(Self { lower, upper })
    }

    /// `±half_width_d` per dimension: the §3 search box of pose offsets (`± bound_sigmas × σ`).
    ///
    /// # Errors
    ///
    /// As [`Bounds::new`]; a half-width must be finite and positive.
    pub fn symmetric(half_widths: &[f64]) -> Result<Self> {
        Self::new(
            half_widths.iter().map(|h| -h).collect(),
            half_widths.to_vec(),
        )
    }

    /// The same interval `[lower, upper]` in each of `dim` dimensions (test functions).
    ///
    /// # Errors
    ///
    /// As [`Bounds::new`].
    pub fn cube(dim: usize, lower: f64, upper: f64) -> Result<Self> {
        Self::new(vec![lower; dim], vec![upper; dim])
    }

    /// Number of dimensions `D`.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// Lower limits, one per dimension.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    /// Upper limits, one per dimension.
    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    /// `upper_d − lower_d`.
    pub fn width(&self, d: usize) -> f64 {
        self.upper[d] - self.lower[d]
    }

    /// Half of [`Bounds::width`]: the unit of the butterflies' positions (§4.3).
    pub fn half_width(&self, d: usize) -> f64 {
        0.5 * self.width(d)
    }

    /// Midpoint of dimension `d`.
    pub fn centre(&self, d: usize) -> f64 {
        0.5 * (self.lower[d] + self.upper[d])
    }

    /// True when `x` has `dim()` coordinates, each inside its interval.
    pub fn contains(&self, x: &[f64]) -> bool {
        x.len() == self.dim()
            && x.iter()
                .zip(self.lower.iter().zip(&self.upper))
                .all(|(v, (lo, hi))| lo <= v && v <= hi)
    }

    /// Clips every coordinate of `x` into its interval (docs/ALGORITHMS.md §3: every candidate is
    /// clipped). ±∞ goes to the nearer limit; a NaN coordinate (from degenerate arithmetic
    /// such as `0 × ∞` in a Lévy step) goes to the centre, so a candidate is always a point
    /// of the box.
    pub fn clip(&self, x: &mut [f64]) {
        for (d, v) in x.iter_mut().enumerate() {
            *v = if v.is_nan() {
                self.centre(d)
            } else {
                v.clamp(self.lower[d], self.upper[d])
            };
        }
    }

    /// `members` points drawn uniformly in the box, row-major (`members × dim`), drawn in
    /// member order then dimension order.
    pub fn sample_uniform(&self, members: usize, rng: &mut SimRng) -> Vec<f64> {
        let mut positions = vec![0.0; members * self.dim()];
        for row in positions.chunks_exact_mut(self.dim()) {
            self.sample_into(row, rng);
        }
        positions
    }

    /// Overwrites `x` with a uniform point of the box: `lower + r (upper − lower)` (COA eq. 8).
    pub(super) fn sample_into(&self, x: &mut [f64], rng: &mut SimRng) {
        for (d, v) in x.iter_mut().enumerate() {
            *v = self.lower[d] + rng.random::<f64>() * self.width(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_reject_nan_infinite_inverted_and_mismatched() {
        let bad = [
            (vec![f64::NAN], vec![1.0]),
            (vec![0.0], vec![f64::NAN]),
            (vec![f64::NEG_INFINITY], vec![1.0]),
            (vec![0.0], vec![f64::INFINITY]),
            (vec![1.0], vec![1.0]),
            (vec![2.0], vec![1.0]),
            (vec![0.0, 0.0], vec![1.0]),
            (vec![], vec![]),
        ];
        for (lower, upper) in bad {
            let result = Bounds::new(lower.clone(), upper.clone());
            assert!(
                matches!(result, Err(Error::InvalidBounds { .. })),
                "accepted [{lower:?}, {upper:?}]"
            );
        }
        assert!(Bounds::symmetric(&[0.0]).is_err());
        assert!(Bounds::symmetric(&[1.0, 2.0]).is_ok());
    }

    #[test]
    fn clip_moves_outside_points_to_the_nearest_limit_and_nan_to_the_centre() {
        let bounds = Bounds::new(vec![-1.0, 0.0, 2.0, -5.0], vec![1.0, 10.0, 4.0, 5.0]).unwrap();
        let mut x = [-3.0, 5.0, f64::INFINITY, f64::NAN];
        bounds.clip(&mut x);
        assert_eq!(x, [-1.0, 5.0, 4.0, 0.0]);
        assert!(bounds.contains(&x));
        assert!(!bounds.contains(&[0.0, 0.0, 1.9, 0.0]));
    }
}
