//! Resampling schemes (docs/ALGORITHMS.md §1 step 6 and §4.4).
//!
//! Every full scheme has one signature, `fn scheme(w: &Weights, m: usize, rng) -> Vec<usize>`,
//! returning the ancestor index of each of the `m` new particles (their weights are then
//! uniform). IBA's partial resampling keeps some particles with their weights, so it
//! returns the ancestors together with the new weights ([`PartialResample`]).
//! [`ResamplingConfig`] decides when to resample and with which scheme; FastSLAM and the
//! generic particle filter share it.

use crate::Result;
use crate::check::{in_range, require};
use crate::weights::Weights;
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// Systematic (low-variance) resampling: one uniform draw `u ~ U(0, 1/m)`, then the
/// ancestors of the points `u + k/m`, `k = 0..m`, on the cumulative weights.
///
/// Each index `i` appears `⌊m wᵢ⌋` or `⌈m wᵢ⌉` times; the output is sorted ascending and
/// never selects a zero-weight particle.
///
/// # Performance
/// O(n + m), one allocation.
pub fn systematic(w: &Weights, m: usize, rng: &mut impl Rng) -> Vec<usize> {
    let weights = w.as_slice();
    // The last particle with positive weight: rounding in the cumulative sum must not
    // push a point onto a zero-weight tail. `Weights` guarantees one positive weight.
    let last = weights.iter().rposition(|&wi| wi > 0.0).unwrap_or(0);
    let step = 1.0 / m as f64;
    let u0 = rng.random::<f64>() * step;
    let mut out = Vec::with_capacity(m);
    let mut i = 0;
    let mut cumulative = weights[0];
    for k in 0..m {
        let u = u0 + k as f64 * step;
        while u >= cumulative && i < last {
            i += 1;
            cumulative += weights[i];
        }
        out.push(i);
    }
    out
}

/// Bias-corrected exponentially weighted average threshold of IBA's partial resampling
/// (docs/ALGORITHMS.md §4.4, IBA paper eq. 13): with the weights sorted ascending,
/// `vᵢ = β vᵢ₋₁ + (1−β) wᵢ` (`v₀ = 0`), `δᵢ = vᵢ / (1 − βⁱ)`, threshold `δ̄ = mean(δᵢ)`.
///
/// `beta` must lie in (0, 1) (the paper uses 0.9); the filter's config checks it.
///
/// # Performance
/// O(n log n) for the sort.
pub fn ewa_threshold(w: &Weights, beta: f64) -> f64 {
    let mut sorted = w.as_slice().to_vec();
    sorted.sort_by(f64::total_cmp);
    let mut v = 0.0;
    let mut beta_pow = 1.0;
    let mut sum_delta = 0.0;
    for &wi in &sorted {
        v = beta * v + (1.0 - beta) * wi;
        beta_pow *= beta;
        sum_delta += v / (1.0 - beta_pow);
    }
    sum_delta / sorted.len() as f64
}

/// Outcome of partial resampling: new particle `k` is a copy of particle `indices[k]`
/// with normalised weight `weights[k]`.
#[derive(Debug, Clone, PartialEq)]
pub struct PartialResample {
    /// Ancestor of each new particle; `indices[k] == k` for a kept particle.
    pub indices: Vec<usize>,
    /// Normalised weight of each new particle; they sum to 1 (the mass is preserved).
    pub weights: Vec<f64>,
    /// How many particles were replaced (`L` in the paper).
    pub replaced: usize,
}

/// IBA's partial resampling (docs/ALGORITHMS.md §4.4): particles with `wᵢ ≥ δ̄`
/// ([`ewa_threshold`]) are kept in place with their weights; the `L` others are replaced
/// by `L` [`systematic`] draws from the whole set, each with weight `W_L / L`, where `W_L`
/// is the total weight of the replaced particles.
///
/// # Performance
/// O(n log n) for the threshold, then O(n).
pub fn partial_ewa(w: &Weights, beta: f64, rng: &mut impl Rng) -> PartialResample {
    let threshold = ewa_threshold(w, beta);
    let weights = w.as_slice();
    let replaced_slots: Vec<usize> = (0..weights.len())
        .filter(|&i| weights[i] < threshold)
        .collect();
    let mut indices: Vec<usize> = (0..weights.len()).collect();
    let mut new_weights = weights.to_vec();
    let replaced = replaced_slots.len();
    if replaced > 0 {
        let mass: f64 = replaced_slots.iter().map(|&i| weights[i]).sum();
        let draws = systematic(w, replaced, rng);
        for (&slot, ancestor) in replaced_slots.iter().zip(draws) {
            indices[slot] = ancestor;
            new_weights[slot] = mass / replaced as f64;
        }
    }
    PartialResample {
        indices,
        weights: new_weights,
        replaced,
    }
}

/// Which resampling scheme runs when `N_eff` falls below the threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResamplingScheme {
    /// Systematic (low-variance) resampling of the whole set; weights become uniform.
    #[default]
    Systematic,
    /// IBA's partial resampling with the bias-corrected EWA threshold (docs/ALGORITHMS.md §4.4).
    PartialEwa,
}

/// When and how to resample (docs/ALGORITHMS.md §1 step 6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ResamplingConfig {
    /// The scheme.
    pub scheme: ResamplingScheme,
    /// Resample when `N_eff < neff_ratio · N` (dimensionless, in [0, 1]; 0 never
    /// resamples, 1 resamples at every step unless the weights are exactly equal).
    /// Library default 0.5 (docs/ALGORITHMS.md); the Bailey scenario sets 0.75.
    pub neff_ratio: f64,
    /// `β` of the EWA threshold of partial resampling (dimensionless, in (0, 1)); IBA 0.9.
    pub ewa_beta: f64,
}

impl Default for ResamplingConfig {
    fn default() -> Self {
        Self {
            scheme: ResamplingScheme::Systematic,
            neff_ratio: 0.5,
            ewa_beta: 0.9,
        }
    }
}

/// The particles after resampling: new particle `k` is a copy of `ancestors[k]` with the
/// normalised log-weight `log_weights[k]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Resampled {
    /// Ancestor of each new particle.
    pub ancestors: Vec<usize>,
    /// Normalised log-weight of each new particle (uniform after systematic resampling).
    pub log_weights: Vec<f64>,
}

impl Resampled {
    /// Number of distinct ancestors (the diversity left after resampling).
    pub fn distinct(&self) -> usize {
        let mut seen = vec![false; self.ancestors.len()];
        self.ancestors.iter().for_each(|&a| seen[a] = true);
        seen.iter().filter(|&&s| s).count()
    }
}

impl ResamplingConfig {
    /// Checks the ratio and β.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] for `neff_ratio ∉ [0, 1]` or `ewa_beta ∉ (0, 1)`.
    pub fn validate(&self) -> Result<()> {
        in_range("resampling.neff_ratio", self.neff_ratio, 0.0, 1.0)?;
        require(
            self.ewa_beta > 0.0 && self.ewa_beta < 1.0,
            "resampling.ewa_beta",
            || format!("must lie in (0, 1), got {}", self.ewa_beta),
        )
    }

    /// True when `w` is degenerate enough to resample: `N_eff < neff_ratio · N`.
    pub fn due(&self, w: &Weights) -> bool {
        w.ess() < self.neff_ratio * w.as_slice().len() as f64
    }

    /// Resamples all `N` particles with the configured scheme: [`systematic`] (uniform
    /// weights after) or [`partial_ewa`] (kept particles keep their weights).
    ///
    /// # Performance
    /// O(N) for systematic, O(N log N) for partial resampling.
    pub fn draw(&self, w: &Weights, rng: &mut impl Rng) -> Resampled {
        let n = w.as_slice().len();
        match self.scheme {
            ResamplingScheme::Systematic => Resampled {
                ancestors: systematic(w, n, rng),
                log_weights: vec![-(n as f64).ln(); n],
            },
            ResamplingScheme::PartialEwa => {
                let partial = partial_ewa(w, self.ewa_beta, rng);
                Resampled {
                    ancestors: partial.indices,
                    log_weights: partial.weights.iter().map(|w| w.ln()).collect(),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::seeded;

    fn weights(linear: &[f64]) -> Weights {
        let logs: Vec<f64> = linear.iter().map(|w| w.ln()).collect();
        Weights::from_log(&logs).unwrap()
    }

    fn counts(indices: &[usize], n: usize) -> Vec<usize> {
        let mut c = vec![0; n];
        indices.iter().for_each(|&i| c[i] += 1);
        c
    }

    #[test]
    fn systematic_preserves_expected_counts() {
        let mut rng = seeded(11);
        for trial in 0..200 {
            let n = 1 + trial % 17;
            let raw: Vec<f64> = (0..n).map(|_| rng.random::<f64>().powi(3)).collect();
            let w = weights(&raw);
            let m = 1 + (trial * 7) % 50;
            let idx = systematic(&w, m, &mut rng);
            assert_eq!(idx.len(), m);
            assert!(idx.windows(2).all(|p| p[0] <= p[1]), "output sorted");
            for (i, &c) in counts(&idx, n).iter().enumerate() {
                let expected = m as f64 * w.as_slice()[i];
                let (lo, hi) = ((expected - 1e-9).floor(), (expected + 1e-9).ceil());
                assert!(
                    (lo..=hi).contains(&(c as f64)),
                    "trial {trial}: index {i} drawn {c} times, expected {expected}"
                );
            }
        }
    }

    #[test]
    fn systematic_never_picks_zero_weight_particles() {
        let w = Weights::from_log(&[
            f64::NEG_INFINITY,
            0.0,
            f64::NEG_INFINITY,
            0.0,
            f64::NEG_INFINITY,
        ])
        .unwrap();
        let mut rng = seeded(3);
        for _ in 0..100 {
            assert!(
                systematic(&w, 9, &mut rng)
                    .iter()
                    .all(|&i| i == 1 || i == 3)
            );
        }
    }

    #[test]
    fn ewa_threshold_matches_hand_computation() {
        // Sorted 0.1, 0.2, 0.3, 0.4 with β = 0.9: δ = 0.1, 0.029/0.19, 0.0561/0.271,
        // 0.09049/0.3439; mean 0.180692866…
        let w = weights(&[0.3, 0.1, 0.4, 0.2]);
        let expected = (0.1 + 0.029 / 0.19 + 0.0561 / 0.271 + 0.09049 / 0.3439) / 4.0;
        assert!((ewa_threshold(&w, 0.9) - expected).abs() < 1e-12);
        assert!((expected - 0.180_692_866_393_624_7).abs() < 1e-12);
    }

    #[test]
    fn partial_ewa_keeps_heavy_particles_and_preserves_mass() {
        let w = weights(&[0.3, 0.1, 0.4, 0.2]);
        let p = partial_ewa(&w, 0.9, &mut seeded(5));
        assert_eq!(p.replaced, 1);
        assert_eq!(&p.indices[0..1], &[0]);
        assert_eq!(&p.indices[2..], &[2, 3]);
        assert_eq!(&p.weights[0..1], &w.as_slice()[0..1]);
        assert_eq!(&p.weights[2..], &w.as_slice()[2..]);
        assert!((p.weights[1] - 0.1).abs() < 1e-12, "W_L / L = 0.1");
        assert!((p.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn partial_ewa_spreads_replaced_mass_evenly_over_systematic_draws() {
        let mut rng = seeded(9);
        for _ in 0..50 {
            let raw: Vec<f64> = (0..40).map(|_| rng.random::<f64>().powi(4)).collect();
            let w = weights(&raw);
            let p = partial_ewa(&w, 0.9, &mut rng);
            assert!((p.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let threshold = ewa_threshold(&w, 0.9);
            let replaced: Vec<usize> = (0..40).filter(|&i| w.as_slice()[i] < threshold).collect();
            assert_eq!(replaced.len(), p.replaced);
            let mass: f64 = replaced.iter().map(|&i| w.as_slice()[i]).sum();
            for &i in &replaced {
                assert!((p.weights[i] - mass / replaced.len() as f64).abs() < 1e-15);
                assert!(w.as_slice()[p.indices[i]] > 0.0);
            }
        }
    }
}
