//! PSO — canonical particle swarm (Kennedy & Eberhart 1995, inertia weight of Shi & Eberhart
//! 1998; docs/ALGORITHMS.md §4.5).
//!
//! `v ← w v + c₁ r₁ (P_i − X) + c₂ r₂ (g* − X)` per dimension with `w` falling linearly
//! 0.9 → 0.4, each component clamped to `±v_max = ±0.2 (ub − lb)`; `X' = X + v`, clipped to the
//! bounds. Positions always move; personal bests are updated greedily. Velocities start at 0
//! (a particle of the filter starts at its prediction with no momentum), so the first
//! generation is a pure pull toward the best. Cost: N evaluations per generation.

use super::{
    Batch, Optimiser, OptimiserKind, PersonalBests, Population, Problem, RunState, ensure, linear,
};
use crate::Result;
use crate::rng::SimRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// PSO's constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PsoConfig {
    /// Inertia weight `w` where the schedule starts (Shi & Eberhart 1998;
    /// dimensionless): generation `k = 1..K` uses `start + (end − start) k / K`, so the
    /// first one is already a step along. Default 0.9.
    pub inertia_start: f64,
    /// Inertia weight at generation `K` (linear in between). Default 0.4.
    pub inertia_end: f64,
    /// `c₁`: pull toward the personal best (dimensionless). Default 2.
    pub cognitive: f64,
    /// `c₂`: pull toward the global best (dimensionless). Default 2.
    pub social: f64,
    /// `v_max` per dimension as a fraction of the width `ub − lb`. Default 0.2.
    pub max_speed: f64,
}

impl Default for PsoConfig {
    fn default() -> Self {
        Self {
            inertia_start: 0.9,
            inertia_end: 0.4,
            cognitive: 2.0,
            social: 2.0,
            max_speed: 0.2,
        }
    }
}

impl PsoConfig {
    /// Inertia weight `w(k)`, linear from `inertia_start` to `inertia_end` over `K` generations.
    pub fn inertia(&self, k: usize, iterations: usize) -> f64 {
        linear(self.inertia_start, self.inertia_end, k, iterations)
    }

    /// Checks the ranges.
    ///
    /// # Errors
    ///
    /// [`crate::Error::InvalidParameter`] unless the inertia weights and accelerations are
    /// finite and ≥ 0 and `max_speed` is finite and > 0.
    pub fn validate(&self) -> Result<()> {
        for (value, name) in [
            (self.inertia_start, "inertia_start"),
            (self.inertia_end, "inertia_end"),
            (self.cognitive, "cognitive"),
            (self.social, "social"),
        ] {
            ensure(
                value >= 0.0 && value.is_finite(),
                name,
                "must be finite and ≥ 0",
            )?;
        }
        ensure(
            self.max_speed > 0.0 && self.max_speed.is_finite(),
            "max_speed",
            "must be finite and > 0",
        )
    }
}

/// Canonical particle swarm optimisation.
#[derive(Debug, Clone)]
pub struct Pso {
    config: PsoConfig,
    run: RunState,
    personal: PersonalBests,
    velocities: Vec<f64>,
    candidates: Batch,
}

impl Pso {
    /// PSO with `config`.
    ///
    /// # Errors
    ///
    /// As [`PsoConfig::validate`].
    pub fn new(config: PsoConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            run: RunState::default(),
            personal: PersonalBests::default(),
            velocities: Vec::new(),
            candidates: Batch::default(),
        })
    }
}

impl Optimiser for Pso {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Pso
    }

    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()> {
        self.run = RunState::start(problem, population, iterations, 1)?;
        self.personal = PersonalBests::from_population(population);
        self.velocities = vec![0.0; population.positions().len()];
        Ok(())
    }

    fn step(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
    ) -> Result<()> {
        let k = self.run.next_generation(problem, population)?;
        let (n, dim) = (population.len(), population.dim());
        let c = &self.config;
        let inertia = c.inertia(k, self.run.iterations());
        let global = self.run.best_position();
        let bounds = problem.bounds();

        self.candidates.reset(dim);
        for i in 0..n {
            let (x, own) = (population.position(i), self.personal.position(i));
            let velocity = &mut self.velocities[i * dim..(i + 1) * dim];
            let candidate = self.candidates.push(i, x);
            for d in 0..dim {
                let max_speed = c.max_speed * bounds.width(d);
                let pull = c.cognitive * rng.random::<f64>() * (own[d] - x[d])
                    + c.social * rng.random::<f64>() * (global[d] - x[d]);
                velocity[d] = (inertia * velocity[d] + pull).clamp(-max_speed, max_speed);
                candidate[d] = x[d] + velocity[d];
            }
        }
        self.run.evaluate(problem, &mut self.candidates);
        population.accept_all(&self.candidates);
        self.personal.update(&self.candidates);
        Ok(())
    }

    fn run_state(&self) -> &RunState {
        &self.run
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimise::test_functions::{Benchmark, TestFunction};
    use crate::rng::seeded;

    #[test]
    fn inertia_falls_from_0_9_to_0_4() {
        let config = PsoConfig::default();
        assert_eq!(config.inertia(0, 200), 0.9);
        assert!((config.inertia(100, 200) - 0.65).abs() < 1e-15);
        assert_eq!(config.inertia(200, 200), 0.4);
    }

    #[test]
    fn speed_is_clamped_and_personal_bests_are_greedy() {
        let problem = Benchmark::new(TestFunction::Sphere, 3, true).unwrap();
        let mut rng = seeded(8);
        let mut population =
            Population::evaluate(&problem, problem.bounds().sample_uniform(15, &mut rng)).unwrap();
        let mut pso = Pso::new(PsoConfig::default()).unwrap();
        pso.start(&problem, &population, 30).unwrap();
        let max_speed = 0.2 * 200.0;
        let mut clamped = false;
        for _ in 0..30 {
            let personal_before = pso.personal.fitness().to_vec();
            pso.step(&problem, &mut population, &mut rng).unwrap();
            assert!(pso.velocities.iter().all(|v| v.abs() <= max_speed));
            clamped |= pso.velocities.iter().any(|v| v.abs() == max_speed);
            assert!(
                pso.personal
                    .fitness()
                    .iter()
                    .zip(&personal_before)
                    .all(|(a, b)| a <= b)
            );
        }
        assert!(clamped, "the clamp was never exercised");
        assert_eq!(pso.evaluations(), 30 * 15);
    }
}
