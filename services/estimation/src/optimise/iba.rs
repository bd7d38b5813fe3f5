//! IBA — improved butterfly optimisation (IBA paper §2.2, eqs. 8–12; docs/ALGORITHMS.md §4.4).
//! The paper's partial resampling (eq. 13, §4.4 item 4) is a resampling scheme of the filter,
//! not part of this optimiser; [`IbaConfig::partial_resampling`] tells the filter to use it.
//!
//! - **Observation-aware stimulus** (eqs. 8–9): `I_i = exp(−D_i² / 2)`, where `D_i²` is the
//!   fitness the filter passes — §3's normalised innovations plus motion-prior term — shifted
//!   so its population minimum is 0, as for BA.
//! - **Adaptive fragrance radius** (eq. 10): butterfly `i` moves relative to a random partner
//!   `j ≠ i` only if `‖x_i − x_j‖ ≤ η · max(F_i, F_j)` (the radius of the more fragrant of the
//!   two), distance in units of the bound half-width; otherwise `i` does not move and costs
//!   no evaluation this generation.
//! - **Adaptive step factor** (eq. 11) `α(i) = exp(−R I_i / I_j)` and update (eq. 12):
//!   `X' = X + (X_j − X_k) · |L| · F_i + α(i) · u`, `u ~ U(−0.5, 0.5)` per dimension in
//!   half-width units (the paper's `rand ÷ 2` would drift everything toward +x, +y, +θ),
//!   `k ≠ j` random (it may be `i`, which makes the step an attraction toward `j`), `|L|`
//!   per dimension. Greedy acceptance.
//!
//! Eq. 12 is IBA's one position update: it replaces both of BA's searches, so there is no
//! switch probability. Since `F_i ≤ c` and `c` stays small (BA's sensory modality
//! schedule: below ≈ 0.22 over K = 200 generations, ≈ 0.34 at K = 10), the radius is at
//! most a third of η half-widths: in a spread-out population almost
//! no pair is that close and IBA moves few butterflies — the "reduced computation" the paper
//! claims for the radius. The reference tests document what this gives on test functions.

use super::ba::{Fragrance, FragranceConfig, shifted_fitness};
use super::levy::Levy;
use super::{
    Batch, Optimiser, OptimiserKind, Population, Problem, RunState, ensure, index_other_than,
};
use crate::Result;
use crate::rng::SimRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// IBA's constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IbaConfig {
    /// Fragrance constants, eq. 4 (as BA).
    pub fragrance: FragranceConfig,
    /// `β_L`: stability index of the Lévy steps (eq. 7, Mantegna). Default 1.5.
    pub levy_exponent: f64,
    /// `η`: fragrance radius per unit fragrance, eq. 10, in (0, 1) (half-widths per unit
    /// fragrance). The paper gives only the range; default 0.5, its middle.
    pub radius_factor: f64,
    /// `R`: observation noise variance scale in the step factor, eq. 11 (dimensionless, the
    /// innovations are already normalised). Default 1.
    pub noise_variance: f64,
    /// Whether a filter running IBA resamples with IBA's partial EWA scheme (§2.3, eq. 13;
    /// docs/ALGORITHMS.md §4.4 item 4) instead of its configured scheme. Default true: the paper's
    /// method is the optimiser *and* the partial resampling.
    pub partial_resampling: bool,
}

impl Default for IbaConfig {
    fn default() -> Self {
        Self {
            fragrance: FragranceConfig::default(),
            levy_exponent: 1.5,
            radius_factor: 0.5,
            noise_variance: 1.0,
            partial_resampling: true,
        }
    }
}

impl IbaConfig {
    /// Checks the ranges.
    ///
    /// # Errors
    ///
    /// [`crate::Error::InvalidParameter`] for a bad fragrance constant, `levy_exponent`
    /// outside (0, 2), `radius_factor` outside (0, 1) or `noise_variance` not finite and > 0.
    pub fn validate(&self) -> Result<()> {
        self.fragrance.validate()?;
        Levy::new(self.levy_exponent)?;
        ensure(
            self.radius_factor > 0.0 && self.radius_factor < 1.0,
            "radius_factor",
            "must be in (0, 1)",
        )?;
        ensure(
            self.noise_variance > 0.0 && self.noise_variance.is_finite(),
            "noise_variance",
            "must be finite and > 0",
        )
    }
}

/// Improved butterfly optimisation.
#[derive(Debug, Clone)]
pub struct Iba {
    radius_factor: f64,
    noise_variance: f64,
    levy: Levy,
    fragrance: Fragrance,
    run: RunState,
    candidates: Batch,
    /// `D_i²`, the shifted fitness; `ln I_i = −D_i² / 2`.
    shifted: Vec<f64>,
    /// `F_i`.
    fragrances: Vec<f64>,
}

impl Iba {
    /// IBA with `config`.
    ///
    /// # Errors
    ///
    /// As [`IbaConfig::validate`].
    pub fn new(config: IbaConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            radius_factor: config.radius_factor,
            noise_variance: config.noise_variance,
            levy: Levy::new(config.levy_exponent)?,
            fragrance: Fragrance::new(config.fragrance),
            run: RunState::default(),
            candidates: Batch::default(),
            shifted: Vec::new(),
            fragrances: Vec::new(),
        })
    }

    /// Step factor of eq. 11, `α = exp(−R I_i / I_j)`, with the ratio taken in the log domain
    /// from `D²` so it survives when both intensities underflow (two infinitely bad members
    /// give a ratio of 1).
    fn step_factor(&self, i: usize, j: usize) -> f64 {
        let ratio = ((self.shifted[j] - self.shifted[i]) / 2.0).exp();
        let ratio = if ratio.is_nan() { 1.0 } else { ratio };
        (-self.noise_variance * ratio).exp()
    }
}

impl Optimiser for Iba {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Iba
    }

    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()> {
        self.run = RunState::start(problem, population, iterations, 1)?;
        self.fragrance.restart();
        Ok(())
    }

    fn step(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
    ) -> Result<()> {
        self.run.next_generation(problem, population)?;
        let (n, dim) = (population.len(), population.dim());
        let bounds = problem.bounds();
        shifted_fitness(population, &mut self.shifted);
        self.fragrances.clear();
        self.fragrances
            .extend(self.shifted.iter().map(|d2| self.fragrance.of(-d2 / 2.0)));

        self.candidates.reset(dim);
        for i in 0..n {
            let j = index_other_than(n, i, rng);
            let k = index_other_than(n, j, rng);
            let (x, xj, xk) = (
                population.position(i),
                population.position(j),
                population.position(k),
            );
            let radius = self.radius_factor * self.fragrances[i].max(self.fragrances[j]);
            let distance_squared: f64 = (0..dim)
                .map(|d| ((x[d] - xj[d]) / bounds.half_width(d)).powi(2))
                .sum();
            if distance_squared > radius * radius {
                continue;
            }
            let alpha = self.step_factor(i, j);
            let fragrance = self.fragrances[i];
            let candidate = self.candidates.push(i, x);
            for d in 0..dim {
                let levy = self.levy.sample(rng).abs();
                let jitter = rng.random::<f64>() - 0.5;
                candidate[d] = x[d]
                    + (xj[d] - xk[d]) * levy * fragrance
                    + alpha * jitter * bounds.half_width(d);
            }
        }
        self.run.evaluate(problem, &mut self.candidates);
        population.accept_greedy(&self.candidates);
        self.fragrance.advance(self.run.iterations());
        Ok(())
    }

    fn run_state(&self) -> &RunState {
        &self.run
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimise::{Bounds, FnProblem};
    use crate::rng::seeded;

    fn quadratic() -> FnProblem<impl Fn(usize, &[f64]) -> f64 + Sync> {
        FnProblem::new(Bounds::cube(2, -1.0, 1.0).unwrap(), |_, x: &[f64]| {
            x.iter().map(|v| v * v).sum()
        })
    }

    #[test]
    fn butterflies_outside_every_radius_do_not_move_or_cost_evaluations() {
        let problem = quadratic();
        // Members 0.5 half-widths or more apart: beyond η · c ≤ 0.5 · 0.23.
        let start = vec![-0.9, -0.9, 0.9, 0.9, -0.9, 0.9, 0.9, -0.9];
        let mut population = Population::evaluate(&problem, start.clone()).unwrap();
        let mut rng = seeded(1);
        let summary = Iba::new(IbaConfig::default())
            .unwrap()
            .run(&problem, &mut population, 50, &mut rng)
            .unwrap();
        assert_eq!(summary.evaluations, 0);
        assert_eq!(population.positions(), &start[..]);
    }

    #[test]
    fn close_butterflies_move_and_never_worsen() {
        let problem = quadratic();
        // A tight cluster (0.001 apart) well inside the initial radius 0.5 · 0.01 = 0.005.
        let start: Vec<f64> = (0..8)
            .flat_map(|i| [0.5 + 1e-3 * (i % 2) as f64, 0.5 + 1e-3 * (i / 2) as f64])
            .collect();
        let mut population = Population::evaluate(&problem, start).unwrap();
        let before = population.fitness().to_vec();
        let mut rng = seeded(2);
        let summary = Iba::new(IbaConfig::default())
            .unwrap()
            .run(&problem, &mut population, 20, &mut rng)
            .unwrap();
        assert!(summary.evaluations > 0);
        assert!(summary.moved > 0);
        assert!(
            population
                .fitness()
                .iter()
                .zip(&before)
                .all(|(a, b)| a <= b)
        );
    }

    #[test]
    fn step_factor_follows_the_intensity_ratio() {
        let mut iba = Iba::new(IbaConfig::default()).unwrap();
        // D² = 0 for i, 2 for j: I_i / I_j = e^{1}; α = exp(−e).
        iba.shifted = vec![0.0, 2.0, f64::INFINITY, f64::INFINITY];
        assert!((iba.step_factor(0, 1) - (-std::f64::consts::E).exp()).abs() < 1e-15);
        assert!((iba.step_factor(1, 0) - (-(-1.0f64).exp()).exp()).abs() < 1e-15);
        assert!((iba.step_factor(2, 3) - (-1.0f64).exp()).abs() < 1e-15);
        assert_eq!(iba.step_factor(2, 0), 1.0);
    }
}
