//! A generic particle filter over a state-space model given as data (STYLE habit 2): the
//! model says how `X₀` is drawn, the Gaussian law of `Xₜ` given `Xₜ₋₁`, and the observation
//! log-likelihood; the filter is the same algorithm for every model. It shares [`Weights`],
//! the resampling schemes ([`ResamplingConfig`]) and the optimiser moves ([`Mover`],
//! docs/ALGORITHMS.md §3) with FastSLAM, so the UNGM benchmark (§5) measures the very code
//! the SLAM filter runs.
//!
//! One step `t` (observations are `y₁..y_T`):
//! 1. propose: `xᵢ ~ N(f(t, xᵢ), diag σ²)` (the bootstrap proposal), or, with an
//!    optimiser in the `proposal` mode, from the optimised proposal of §3.1 around
//!    `f(t, xᵢ)`, weighed by target / proposal;
//! 2. move (optional, the papers' mode): the [`Mover`] on offsets from the weighted mean
//!    of the propagated cloud, with the fitness
//!    `−log p(yₜ | x) + λ Σ_d ((x − f(t, x_prev))_d / σ_d)² / 2`;
//! 3. weigh: `log wᵢ += log p(yₜ | xᵢ)` at the final position, or what the
//!    [`WeightBasis`] says;
//! 4. summarise the weighted cloud ([`Posterior`]);
//! 5. resample when due; in the `resample-move` mode every copy then takes
//!    Metropolis–Hastings steps toward `p(yₜ | x) N(x; f(t, x_prev), σ²)` (§3.1).
//!
//! The corrected modes handle scalar states (`D = 1`), as the UNGM is.

use crate::check::require;
use crate::moves::{
    Laplace, LocalTarget, MoveCorrection, MoveStats, MoveTarget, Mover, WeightBasis,
};
use crate::resample::ResamplingConfig;
use crate::rng::SimRng;
use crate::weights::Weights;
use crate::{Error, Result};
use nalgebra::{Matrix1, Vector1};
use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// A state-space model with Gaussian transitions of independent components, as data.
pub trait StateSpaceModel: Sync {
    /// What one observation is.
    type Observation: Sync;

    /// Dimension `D` of the state.
    fn dim(&self) -> usize;

    /// Draws `X₀` into `x` (length `D`).
    fn sample_initial(&self, rng: &mut SimRng, x: &mut [f64]);

    /// The mean `f(t, x_prev)` of `Xₜ` given `Xₜ₋₁ = previous`, into `mean`.
    fn transition_mean(&self, t: usize, previous: &[f64], mean: &mut [f64]);

    /// Standard deviation of the transition noise, per component (length `D`, all > 0).
    fn transition_sigma(&self) -> &[f64];

    /// `log p(yₜ | xₜ = x)`.
    fn log_likelihood(&self, t: usize, x: &[f64], y: &Self::Observation) -> f64;

    /// Gauss–Newton information `Hᵀ R⁻¹ H` of observation `y` about a scalar state at `x`
    /// (`H = ∂h/∂x`): what the optimised proposal's Laplace covariance needs. Models of
    /// dimension above 1 never have it asked for.
    fn observation_information(&self, t: usize, x: f64, y: &Self::Observation) -> f64;
}

/// Size and resampling of the generic filter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilterConfig {
    /// Number of particles `N` (≥ 2: the optimisers need a population of two).
    pub particles: usize,
    /// When and how to resample. Default: systematic at every step (`neff_ratio = 1`),
    /// the bootstrap filter of §5's measurements.
    pub resampling: ResamplingConfig,
    /// Probability mass of the central interval [`Posterior`] reports (dimensionless, in
    /// (0, 1)); §5 reports the coverage of the 90 % interval.
    pub interval: f64,
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            particles: 100,
            resampling: ResamplingConfig {
                neff_ratio: 1.0,
                ..ResamplingConfig::default()
            },
            interval: 0.9,
        }
    }
}

impl FilterConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        require(self.particles >= 2, "particles", || {
            format!("must be >= 2, got {}", self.particles)
        })?;
        self.resampling.validate()?;
        require(
            self.interval > 0.0 && self.interval < 1.0,
            "interval",
            || format!("must lie in (0, 1), got {}", self.interval),
        )
    }
}

/// The weighted cloud after weighing at one step, per state component.
#[derive(Debug, Clone, PartialEq)]
pub struct Posterior {
    /// Weighted mean (the estimate).
    pub mean: Vec<f64>,
    /// Weighted variance around the mean.
    pub variance: Vec<f64>,
    /// Lower end of the central interval (the `(1 − interval)/2` weighted quantile).
    pub lower: Vec<f64>,
    /// Upper end of the central interval.
    pub upper: Vec<f64>,
    /// Effective sample size before resampling.
    pub ess: f64,
    /// Weighted mean of the cloud the step leaves for the next one: after resampling and
    /// any moves when the step resampled, else the weighted cloud itself.
    pub carried_mean: Vec<f64>,
    /// Weighted variance of that cloud.
    pub carried_variance: Vec<f64>,
}

/// The weighted `q`-quantile of `(value, weight)` pairs (weights summing to 1): the
/// smallest value whose cumulative weight, values taken in ascending order, reaches `q`.
/// Reorders `items`.
///
/// # Performance
/// Expected O(n): quickselect on the values, descending into the side that holds the
/// quantile's cumulative weight.
fn weighted_quantile(items: &mut [(f64, f64)], q: f64) -> f64 {
    let by_value = |a: &(f64, f64), b: &(f64, f64)| a.0.total_cmp(&b.0);
    let mut slice = items;
    let mut target = q;
    let mut fallback = f64::NAN;
    while !slice.is_empty() {
        let mid = slice.len() / 2;
        slice.select_nth_unstable_by(mid, by_value);
        let below: f64 = slice[..mid].iter().map(|&(_, w)| w).sum();
        let (pivot, weight) = slice[mid];
        if below >= target {
            slice = &mut slice[..mid];
        } else if below + weight >= target {
            return pivot;
        } else {
            target -= below + weight;
            fallback = pivot;
            slice = &mut slice[mid + 1..];
        }
    }
    // Rounding left the cumulative weight just short of `q`: the largest value.
    fallback
}

/// The §3 move target of one step of the generic filter.
struct Step<'a, M: StateSpaceModel> {
    model: &'a M,
    t: usize,
    y: &'a M::Observation,
    centre: &'a [f64],
    /// `f(t, x_prev)` per particle, row-major.
    means: &'a [f64],
}

impl<M: StateSpaceModel> Step<'_, M> {
    fn state(&self, offset: &[f64]) -> Vec<f64> {
        self.centre.iter().zip(offset).map(|(c, o)| c + o).collect()
    }
}

impl<M: StateSpaceModel> MoveTarget for Step<'_, M> {
    fn log_likelihood(&self, _: usize, offset: &[f64]) -> f64 {
        self.model
            .log_likelihood(self.t, &self.state(offset), self.y)
    }

    fn log_prior(&self, member: usize, offset: &[f64]) -> f64 {
        let d = self.centre.len();
        let mean = &self.means[member * d..(member + 1) * d];
        let sigma = self.model.transition_sigma();
        (0..d)
            .map(|k| -0.5 * ((self.centre[k] + offset[k] - mean[k]) / sigma[k]).powi(2))
            .sum()
    }

    fn parallel(&self) -> bool {
        false
    }
}

/// One particle's scalar target of step `t` around its prediction `mean`.
struct ScalarTarget<'a, M: StateSpaceModel> {
    model: &'a M,
    t: usize,
    y: &'a M::Observation,
    mean: f64,
}

impl<M: StateSpaceModel> LocalTarget<1> for ScalarTarget<'_, M> {
    fn log_likelihood(&self, offset: &Vector1<f64>) -> f64 {
        self.model
            .log_likelihood(self.t, &[self.mean + offset[0]], self.y)
    }

    fn information(&self, offset: &Vector1<f64>) -> Matrix1<f64> {
        Matrix1::new(
            self.model
                .observation_information(self.t, self.mean + offset[0], self.y),
        )
    }
}

/// Runs the filter on `observations` (`yₜ` for `t = 1..=T`) and returns the posterior
/// summary of every step. `mover` (an optimiser in one of the modes of §3 and §3.1, or
/// `None` for the bootstrap filter) runs as the module documentation says. Every draw
/// comes from `rng`, in particle order.
///
/// # Errors
/// [`Error::InvalidParameter`] for a bad config or a corrected mode on a state of
/// dimension above 1, [`Error::DegenerateWeights`] when every particle's weight vanishes,
/// or the mover's error.
///
/// # Performance
/// O(T · N) plus the mover's evaluations and an O(N) selection per step and component for
/// the interval.
pub fn run<M: StateSpaceModel>(
    model: &M,
    observations: &[M::Observation],
    config: &FilterConfig,
    mut mover: Option<&mut Mover>,
    rng: &mut SimRng,
) -> Result<Vec<Posterior>> {
    config.validate()?;
    let (n, d) = (config.particles, model.dim());
    let sigma = model.transition_sigma().to_vec();
    if sigma.len() != d || sigma.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(Error::InvalidParameter {
            name: "transition_sigma",
            reason: format!("needs {d} finite values > 0, got {sigma:?}"),
        });
    }
    let correction = mover.as_deref().map(|m| m.config().correction);
    require(
        d == 1 || !correction.is_some_and(MoveCorrection::is_valid),
        "moves.correction",
        || format!("the corrected modes handle scalar states, this one has {d} dimensions"),
    )?;
    let proposing = correction == Some(MoveCorrection::Proposal);
    let mut states = vec![0.0; n * d];
    for x in states.chunks_exact_mut(d) {
        model.sample_initial(rng, x);
    }
    let mut log_weights = vec![-(n as f64).ln(); n];
    let mut means = vec![0.0; n * d];
    let mut basis = vec![WeightBasis::FinalPosition; n];
    let mut out = Vec::with_capacity(observations.len());
    for (k, y) in observations.iter().enumerate() {
        let t = k + 1;
        basis.fill(WeightBasis::FinalPosition);
        // 1. Propose: the bootstrap draw, or the optimised proposal.
        for (i, (x, mean)) in states
            .chunks_exact_mut(d)
            .zip(means.chunks_exact_mut(d))
            .enumerate()
        {
            model.transition_mean(t, x, mean);
            match mover.as_deref_mut() {
                Some(mover) if proposing => {
                    let target = ScalarTarget {
                        model,
                        t,
                        y,
                        mean: mean[0],
                    };
                    let prior = Matrix1::new(sigma[0] * sigma[0]);
                    let laplace = mover.laplace(&target, &prior, &[], rng)?;
                    let (offset, correction) = laplace.draw(rng);
                    x[0] = mean[0] + offset[0];
                    basis[i] = WeightBasis::Corrected(correction);
                    mover.record(MoveStats {
                        steps: u64::from(i == 0),
                        proposed: 1,
                        accepted: 1,
                        evaluations: laplace.evaluations,
                    });
                }
                _ => {
                    for c in 0..d {
                        x[c] = mean[c] + sigma[c] * rng.sample::<f64, _>(StandardNormal);
                    }
                }
            }
        }
        // 2. Move the cloud (the papers' mode).
        if let Some(mover) = mover.as_deref_mut()
            && correction == Some(MoveCorrection::None)
        {
            let weights = Weights::from_log(&log_weights)?;
            let (centre, spread) = weighted_moments(&states, d, weights.as_slice());
            let bounds = mover.config().bounds(&spread, &sigma)?;
            let start: Vec<f64> = states
                .chunks_exact(d)
                .flat_map(|x| x.iter().zip(&centre).map(|(v, c)| v - c))
                .collect();
            let target = Step {
                model,
                t,
                y,
                centre: &centre,
                means: &means,
            };
            let end = mover.run(&target, bounds, start.clone(), &mut basis, rng)?;
            for ((x, to), from) in states
                .chunks_exact_mut(d)
                .zip(end.chunks_exact(d))
                .zip(start.chunks_exact(d))
            {
                if to != from {
                    x.copy_from_slice(&target.state(to));
                }
            }
        }
        // 3. Weigh.
        for ((lw, x), b) in log_weights
            .iter_mut()
            .zip(states.chunks_exact(d))
            .zip(&basis)
        {
            *lw += b.increment(model.log_likelihood(t, x, y));
        }
        let weights = Weights::from_log(&log_weights)?;
        // 4. Summarise.
        out.push(posterior(&states, d, &weights, config.interval));
        // 5. Resample when due; resample-move moves the copies.
        log_weights.copy_from_slice(weights.log_weights());
        if config.resampling.due(&weights) {
            let resampled = config.resampling.draw(&weights, rng);
            let mut next = Vec::with_capacity(states.len());
            let mut next_means = Vec::with_capacity(means.len());
            for &a in &resampled.ancestors {
                next.extend_from_slice(&states[a * d..(a + 1) * d]);
                next_means.extend_from_slice(&means[a * d..(a + 1) * d]);
            }
            states = next;
            means = next_means;
            log_weights = resampled.log_weights;
            if let Some(mover) = mover.as_deref_mut()
                && correction == Some(MoveCorrection::ResampleMove)
            {
                rejuvenate(
                    model,
                    t,
                    y,
                    mover,
                    &resampled.ancestors,
                    &mut states,
                    &means,
                    sigma[0],
                    rng,
                )?;
            }
        }
        let carried = Weights::from_log(&log_weights)?;
        let (mean, std) = weighted_moments(&states, d, carried.as_slice());
        if let Some(last) = out.last_mut() {
            last.carried_variance = std.iter().map(|s| s * s).collect();
            last.carried_mean = mean;
        }
    }
    Ok(out)
}

/// Resample-move for scalar states: every copy takes the mover's Metropolis–Hastings
/// steps toward `p(yₜ | x) N(x; mean, σ²)`, with one search per ancestor serving all its
/// copies (they share the prediction `mean`).
#[allow(clippy::too_many_arguments)]
fn rejuvenate<M: StateSpaceModel>(
    model: &M,
    t: usize,
    y: &M::Observation,
    mover: &mut Mover,
    ancestors: &[usize],
    states: &mut [f64],
    means: &[f64],
    sigma: f64,
    rng: &mut SimRng,
) -> Result<()> {
    let steps = mover.config().mh_steps;
    let prior = Matrix1::new(sigma * sigma);
    let mut searched: Vec<Option<Laplace<1>>> = vec![None; ancestors.len()];
    let mut stats = MoveStats {
        steps: 1,
        ..MoveStats::default()
    };
    for (k, &a) in ancestors.iter().enumerate() {
        let target = ScalarTarget {
            model,
            t,
            y,
            mean: means[k],
        };
        let current = Vector1::new(states[k] - means[k]);
        let laplace = match &searched[a] {
            Some(laplace) => laplace,
            None => {
                // Not started from `current`: the independence proposal may not depend
                // on the state of the chain it moves.
                let laplace = mover.laplace(&target, &prior, &[], rng)?;
                stats.evaluations += laplace.evaluations;
                searched[a].insert(laplace)
            }
        };
        let (offset, accepted) = laplace.rejuvenate(&target, current, steps, rng);
        states[k] = means[k] + offset[0];
        stats.proposed += steps as u64;
        stats.accepted += accepted;
        stats.evaluations += steps as u64 + 1;
    }
    mover.record(stats);
    Ok(())
}

/// Weighted mean and standard deviation per component of row-major `states`.
fn weighted_moments(states: &[f64], d: usize, weights: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut mean = vec![0.0; d];
    for (x, w) in states.chunks_exact(d).zip(weights) {
        mean.iter_mut().zip(x).for_each(|(m, v)| *m += w * v);
    }
    let mut variance = vec![0.0; d];
    for (x, w) in states.chunks_exact(d).zip(weights) {
        for c in 0..d {
            variance[c] += w * (x[c] - mean[c]).powi(2);
        }
    }
    (mean, variance.iter().map(|v| v.sqrt()).collect())
}

/// The [`Posterior`] of a weighted cloud with a central interval of mass `interval`.
fn posterior(states: &[f64], d: usize, weights: &Weights, interval: f64) -> Posterior {
    let (mean, std) = weighted_moments(states, d, weights.as_slice());
    let tail = (1.0 - interval) / 2.0;
    let mut lower = Vec::with_capacity(d);
    let mut upper = Vec::with_capacity(d);
    for c in 0..d {
        let mut items: Vec<(f64, f64)> = states
            .chunks_exact(d)
            .zip(weights.as_slice())
            .map(|(x, &w)| (x[c], w))
            .collect();
        lower.push(weighted_quantile(&mut items, tail));
        upper.push(weighted_quantile(&mut items, 1.0 - tail));
    }
    Posterior {
        mean,
        variance: std.iter().map(|s| s * s).collect(),
        carried_mean: Vec::new(),
        carried_variance: Vec::new(),
        lower,
        upper,
        ess: weights.ess(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::seeded;

    /// A scalar random walk observed directly: `x_t = x_{t−1} + w`, `y_t = x_t + v`, the
    /// case the Kalman filter solves exactly.
    struct RandomWalk {
        q: f64,
        r: f64,
        sigma: [f64; 1],
    }

    impl StateSpaceModel for RandomWalk {
        type Observation = f64;
        fn dim(&self) -> usize {
            1
        }
        fn sample_initial(&self, rng: &mut SimRng, x: &mut [f64]) {
            x[0] = rng.sample::<f64, _>(StandardNormal);
        }
        fn transition_mean(&self, _: usize, previous: &[f64], mean: &mut [f64]) {
            mean[0] = previous[0];
        }
        fn transition_sigma(&self) -> &[f64] {
            &self.sigma
        }
        fn log_likelihood(&self, _: usize, x: &[f64], y: &f64) -> f64 {
            -0.5 * (y - x[0]).powi(2) / self.r
        }
        fn observation_information(&self, _: usize, _: f64, _: &f64) -> f64 {
            1.0 / self.r
        }
    }

    #[test]
    fn bootstrap_filter_matches_the_kalman_filter_on_a_linear_gaussian_model() {
        let model = RandomWalk {
            q: 0.5,
            r: 1.0,
            sigma: [0.5f64.sqrt()],
        };
        let mut rng = seeded(9);
        let (mut x, mut ys) = (0.0, Vec::new());
        for _ in 0..50 {
            x += model.sigma[0] * rng.sample::<f64, _>(StandardNormal);
            ys.push(x + model.r.sqrt() * rng.sample::<f64, _>(StandardNormal));
        }
        let config = FilterConfig {
            particles: 20_000,
            ..FilterConfig::default()
        };
        let posteriors = run(&model, &ys, &config, None, &mut seeded(10)).unwrap();
        // Kalman filter from N(0, 1).
        let (mut m, mut p) = (0.0, 1.0);
        let (mut worst_mean, mut worst_end) = (0.0_f64, 0.0_f64);
        for (y, post) in ys.iter().zip(&posteriors) {
            p += model.q;
            let k = p / (p + model.r);
            m += k * (y - m);
            p *= 1.0 - k;
            worst_mean = worst_mean.max((post.mean[0] - m).abs() / p.sqrt());
            // The 90 % interval is m ± 1.645 √p.
            let half = 1.644_853_6 * p.sqrt();
            let end = (post.upper[0] - (m + half)).max(post.lower[0] - (m - half));
            worst_end = worst_end.max(end.abs() / p.sqrt());
        }
        // In posterior standard deviations σ. With N_eff ≈ 14 000 the Monte Carlo error of
        // the mean is ≈ 0.01 σ and that of a 5 % quantile ≈ 0.02 σ, and resampling at every
        // step adds to both; the bounds allow about five such errors for the worst of the 50
        // steps (measured: 0.029 σ and 0.078 σ).
        assert!(worst_mean < 0.06, "mean off by {worst_mean} σ");
        assert!(worst_end < 0.12, "interval end off by {worst_end} σ");
    }

    #[test]
    fn weighted_quantiles_follow_the_cumulative_weight() {
        let mut items = [(3.0, 0.5), (1.0, 0.1), (2.0, 0.4)];
        assert_eq!(weighted_quantile(&mut items, 0.05), 1.0);
        assert_eq!(weighted_quantile(&mut items, 0.1), 1.0);
        assert_eq!(weighted_quantile(&mut items, 0.5), 2.0);
        assert_eq!(weighted_quantile(&mut items, 0.95), 3.0);
        assert_eq!(
            weighted_quantile(&mut items, 1.0 + 1e-12),
            3.0,
            "rounding short of q"
        );
        // Against sorting, on random weights.
        let mut rng = seeded(2);
        for n in [1, 2, 7, 100, 1001] {
            let mut items: Vec<(f64, f64)> = (0..n).map(|_| (rng.random(), rng.random())).collect();
            let total: f64 = items.iter().map(|i| i.1).sum();
            items.iter_mut().for_each(|i| i.1 /= total);
            let mut sorted = items.clone();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            for q in [0.05, 0.3, 0.5, 0.95] {
                let mut cumulative = 0.0;
                let expected = sorted
                    .iter()
                    .find(|i| {
                        cumulative += i.1;
                        cumulative >= q
                    })
                    .map_or(sorted[n - 1].0, |i| i.0);
                assert_eq!(weighted_quantile(&mut items, q), expected, "n {n}, q {q}");
            }
        }
    }

    #[test]
    fn config_rejects_a_single_particle_and_a_full_interval() {
        assert!(FilterConfig::default().validate().is_ok());
        for bad in [
            FilterConfig {
                particles: 1,
                ..FilterConfig::default()
            },
            FilterConfig {
                interval: 1.0,
                ..FilterConfig::default()
            },
        ] {
            assert!(matches!(
                bad.validate(),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }
}
