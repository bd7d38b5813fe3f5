//! BA — butterfly optimisation (Arora & Singh 2019; IBA paper §2.1, eqs. 4–7;
//! docs/ALGORITHMS.md §4.3).
//!
//! Fragrance `F_i = c · I_i^a` of stimulus `I_i = exp(−(F(x_i) − min_j F(x_j)))` — the fitness
//! shifted so its population minimum is 0, so `I ∈ (0, 1]`. With probability `p` a butterfly
//! flies toward the best, `X' = X + (g* − X) · L · F_i` (eq. 5), otherwise
//! `X' = X + (X_j − X_k) · L · F_i` for random `j ≠ k` (eq. 6); `L` is a Mantegna Lévy step,
//! drawn per dimension. Greedy acceptance. The sensory modality grows after each generation,
//! `c ← c + 0.025 / (c K)` (authors' code). Cost: N evaluations per generation.
//!
//! Units: §4.3 puts positions in units of the bound half-width. Eqs. 5–6 only move a
//! butterfly by a multiple of a *difference* of positions, which scales with the unit, so
//! the update in half-width units converted back is exactly the update in the problem's
//! units: no conversion is needed here (IBA's additive term does need it).
//!
//! On test functions without a likelihood scale the stimulus is tiny for all but the best
//! butterflies (`exp(−ΔF)` with `ΔF` in the hundreds), so few of them move; the reference
//! tests document the effect against BOA_MATLAB, which uses `I = f` instead.

use super::levy::Levy;
use super::{
    Batch, Optimiser, OptimiserKind, Population, Problem, RunState, ensure, index_other_than,
};
use crate::Result;
use crate::rng::SimRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// The fragrance constants BA and IBA share (eq. 4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FragranceConfig {
    /// `c₀`: sensory modality at the start of a run, eq. 4 (fragrance per unit stimulus^a).
    /// Default 0.01.
    pub sensory_modality: f64,
    /// Growth of the sensory modality per run, `c ← c + increment / (c K)` after each
    /// generation (authors' MATLAB code). Default 0.025.
    pub modality_increment: f64,
    /// `a`: power exponent on the stimulus, eq. 4 (dimensionless). Default 0.1.
    pub power_exponent: f64,
}

impl Default for FragranceConfig {
    fn default() -> Self {
        Self {
            sensory_modality: 0.01,
            modality_increment: 0.025,
            power_exponent: 0.1,
        }
    }
}

impl FragranceConfig {
    /// Checks the ranges.
    ///
    /// # Errors
    ///
    /// [`crate::Error::InvalidParameter`] unless `sensory_modality > 0`,
    /// `modality_increment ≥ 0`, `power_exponent ≥ 0`, all finite.
    pub fn validate(&self) -> Result<()> {
        ensure(
            self.sensory_modality > 0.0 && self.sensory_modality.is_finite(),
            "sensory_modality",
            "must be finite and > 0",
        )?;
        ensure(
            self.modality_increment >= 0.0 && self.modality_increment.is_finite(),
            "modality_increment",
            "must be finite and ≥ 0",
        )?;
        ensure(
            self.power_exponent >= 0.0 && self.power_exponent.is_finite(),
            "power_exponent",
            "must be finite and ≥ 0",
        )
    }
}

/// The sensory modality `c` of a run and the fragrance it gives.
#[derive(Debug, Clone)]
pub(crate) struct Fragrance {
    config: FragranceConfig,
    modality: f64,
}

impl Fragrance {
    /// Fragrance at `c = c₀`.
    pub(crate) fn new(config: FragranceConfig) -> Self {
        let modality = config.sensory_modality;
        Self { config, modality }
    }

    /// Back to `c₀` for a new run.
    pub(crate) fn restart(&mut self) {
        self.modality = self.config.sensory_modality;
    }

    /// `F = c · I^a` from `ln I` (computed as `c · exp(a ln I)`, so `I^a` does not underflow to
    /// 0 before `I` does).
    pub(crate) fn of(&self, log_intensity: f64) -> f64 {
        self.modality * (self.config.power_exponent * log_intensity).exp()
    }

    /// The end-of-generation update `c ← c + increment / (c K)`.
    pub(crate) fn advance(&mut self, iterations: usize) {
        self.modality +=
            self.config.modality_increment / (self.modality * iterations.max(1) as f64);
    }
}

/// `F(x_i) − min_j F(x_j)` for every member into `out`: the non-negative fitness the
/// butterflies' stimulus needs (§4.3). `∞ − ∞` (all members infinitely bad) counts as 0.
pub(crate) fn shifted_fitness(population: &Population, out: &mut Vec<f64>) {
    let min = population.min_fitness();
    out.clear();
    out.extend(population.fitness().iter().map(|f| {
        let d = f - min;
        if d.is_nan() { 0.0 } else { d }
    }));
}

/// BA's constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaConfig {
    /// Fragrance constants, eq. 4.
    pub fragrance: FragranceConfig,
    /// `p`: probability of the global search (eq. 5) over the local one (eq. 6). Default 0.8.
    pub switch_probability: f64,
    /// `β_L`: stability index of the Lévy steps (eq. 7, Mantegna). Default 1.5.
    pub levy_exponent: f64,
}

impl Default for BaConfig {
    fn default() -> Self {
        Self {
            fragrance: FragranceConfig::default(),
            switch_probability: 0.8,
            levy_exponent: 1.5,
        }
    }
}

impl BaConfig {
    /// Checks the ranges.
    ///
    /// # Errors
    ///
    /// [`crate::Error::InvalidParameter`] for a bad fragrance constant, `switch_probability`
    /// outside [0, 1] or `levy_exponent` outside (0, 2).
    pub fn validate(&self) -> Result<()> {
        self.fragrance.validate()?;
        ensure(
            (0.0..=1.0).contains(&self.switch_probability),
            "switch_probability",
            "must be in [0, 1]",
        )?;
        Levy::new(self.levy_exponent).map(drop)
    }
}

/// Butterfly optimisation.
#[derive(Debug, Clone)]
pub struct Ba {
    switch_probability: f64,
    levy: Levy,
    fragrance: Fragrance,
    run: RunState,
    candidates: Batch,
    shifted: Vec<f64>,
}

impl Ba {
    /// BA with `config`.
    ///
    /// # Errors
    ///
    /// As [`BaConfig::validate`].
    pub fn new(config: BaConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            switch_probability: config.switch_probability,
            levy: Levy::new(config.levy_exponent)?,
            fragrance: Fragrance::new(config.fragrance),
            run: RunState::default(),
            candidates: Batch::default(),
            shifted: Vec::new(),
        })
    }
}

impl Optimiser for Ba {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Ba
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
        let best = self.run.best_position();
        shifted_fitness(population, &mut self.shifted);

        self.candidates.reset(dim);
        for i in 0..n {
            let fragrance = self.fragrance.of(-self.shifted[i]);
            let x = population.position(i);
            let global = rng.random::<f64>() < self.switch_probability;
            let candidate = self.candidates.push(i, x);
            if global {
                for d in 0..dim {
                    candidate[d] = x[d] + (best[d] - x[d]) * self.levy.sample(rng) * fragrance;
                }
            } else {
                let j = rng.random_range(0..n);
                let k = index_other_than(n, j, rng);
                let (xj, xk) = (population.position(j), population.position(k));
                for d in 0..dim {
                    candidate[d] = x[d] + (xj[d] - xk[d]) * self.levy.sample(rng) * fragrance;
                }
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
    use crate::optimise::FnProblem;
    use crate::optimise::{Bounds, test_functions::Benchmark, test_functions::TestFunction};
    use crate::rng::seeded;

    #[test]
    fn sensory_modality_grows_as_in_the_authors_code() {
        let mut fragrance = Fragrance::new(FragranceConfig::default());
        fragrance.advance(200);
        // 0.01 + 0.025 / (0.01 · 200)
        assert!((fragrance.modality - 0.0225).abs() < 1e-15);
        for _ in 1..200 {
            fragrance.advance(200);
        }
        // ≈ √(c₀² + 2 · 0.025) at the end of any run length.
        assert!(
            (fragrance.modality - 0.2236).abs() < 0.01,
            "{}",
            fragrance.modality
        );
        fragrance.restart();
        assert_eq!(fragrance.modality, 0.01);
        // Fragrance c · I^a with I = e^{-2}: 0.01 · e^{-0.2}.
        assert!((fragrance.of(-2.0) - 0.01 * (-0.2f64).exp()).abs() < 1e-15);
    }

    #[test]
    fn stimulus_uses_fitness_shifted_to_the_population_minimum() {
        let problem = FnProblem::new(Bounds::cube(1, -10.0, 10.0).unwrap(), |_, x: &[f64]| {
            x[0] - 20.0
        });
        let population = Population::evaluate(&problem, vec![1.0, 3.0, -2.0]).unwrap();
        let mut shifted = Vec::new();
        shifted_fitness(&population, &mut shifted);
        assert_eq!(shifted, [3.0, 5.0, 0.0]);
    }

    #[test]
    fn costs_one_evaluation_per_member_and_generation_and_never_worsens() {
        let problem = Benchmark::new(TestFunction::Ackley, 3, true).unwrap();
        let mut rng = seeded(9);
        let mut population =
            Population::evaluate(&problem, problem.bounds().sample_uniform(30, &mut rng)).unwrap();
        let mut ba = Ba::new(BaConfig::default()).unwrap();
        ba.start(&problem, &population, 200).unwrap();
        for _ in 0..200 {
            let before = population.fitness().to_vec();
            ba.step(&problem, &mut population, &mut rng).unwrap();
            assert!(
                population
                    .fitness()
                    .iter()
                    .zip(&before)
                    .all(|(a, b)| a <= b)
            );
        }
        assert_eq!(ba.evaluations(), 6_000);
    }
}
