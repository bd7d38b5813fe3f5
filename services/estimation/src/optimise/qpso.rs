//! QPSO — quantum-behaved particle swarm (Sun et al. 2004/2012; QPSO-RBPF-SLAM paper;
//! docs/ALGORITHMS.md §4.5).
//!
//! Personal bests `P_i`, `mbest = mean(P)`, and per dimension `φ ~ U(0,1)`,
//! `p = φ P_i + (1 − φ) g*`, `X' = p ± β |mbest − X| ln(1/u)` with `u ~ U(0,1]` and the sign
//! by a fair coin; the contraction–expansion coefficient `β` falls linearly 1.0 → 0.5.
//! Positions always move (the personal bests are the memory; greedy positions would make
//! `P_i ≡ X_i`), personal bests are updated greedily. Cost: N evaluations per generation.

use super::{
    Batch, Optimiser, OptimiserKind, PersonalBests, Population, Problem, RunState, ensure, linear,
};
use crate::Result;
use crate::rng::SimRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// QPSO's constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QpsoConfig {
    /// `β` where the schedule starts: contraction–expansion coefficient (Sun et al. 2012,
    /// eq. 12; dimensionless); generation `k = 1..K` uses `start + (end − start) k / K`.
    /// Default 1.0.
    pub contraction_start: f64,
    /// `β` at generation `K` (linear in between). Default 0.5.
    pub contraction_end: f64,
}

impl Default for QpsoConfig {
    fn default() -> Self {
        Self {
            contraction_start: 1.0,
            contraction_end: 0.5,
        }
    }
}

impl QpsoConfig {
    /// `β(k)`, linear from `contraction_start` to `contraction_end` over `K` generations.
    pub fn contraction(&self, k: usize, iterations: usize) -> f64 {
        linear(self.contraction_start, self.contraction_end, k, iterations)
    }

    /// Checks the ranges.
    ///
    /// # Errors
    ///
    /// [`crate::Error::InvalidParameter`] unless both coefficients are finite and > 0 (QPSO
    /// diverges for β above ≈ 1.78, which is left to the user).
    pub fn validate(&self) -> Result<()> {
        for (value, name) in [
            (self.contraction_start, "contraction_start"),
            (self.contraction_end, "contraction_end"),
        ] {
            ensure(
                value > 0.0 && value.is_finite(),
                name,
                "must be finite and > 0",
            )?;
        }
        Ok(())
    }
}

/// Quantum-behaved particle swarm optimisation.
#[derive(Debug, Clone)]
pub struct Qpso {
    config: QpsoConfig,
    run: RunState,
    personal: PersonalBests,
    candidates: Batch,
    mean_best: Vec<f64>,
}

impl Qpso {
    /// QPSO with `config`.
    ///
    /// # Errors
    ///
    /// As [`QpsoConfig::validate`].
    pub fn new(config: QpsoConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            run: RunState::default(),
            personal: PersonalBests::default(),
            candidates: Batch::default(),
            mean_best: Vec::new(),
        })
    }
}

impl Optimiser for Qpso {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Qpso
    }

    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()> {
        self.run = RunState::start(problem, population, iterations, 1)?;
        self.personal = PersonalBests::from_population(population);
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
        let beta = self.config.contraction(k, self.run.iterations());
        let global = self.run.best_position();
        self.mean_best.clear();
        self.mean_best.resize(dim, 0.0);
        for i in 0..n {
            for (m, p) in self.mean_best.iter_mut().zip(self.personal.position(i)) {
                *m += p / n as f64;
            }
        }

        self.candidates.reset(dim);
        for i in 0..n {
            let (x, own) = (population.position(i), self.personal.position(i));
            let candidate = self.candidates.push(i, x);
            for d in 0..dim {
                let phi = rng.random::<f64>();
                let attractor = phi * own[d] + (1.0 - phi) * global[d];
                let u = 1.0 - rng.random::<f64>(); // in (0, 1], so ln(1/u) is finite
                let spread = beta * (self.mean_best[d] - x[d]).abs() * (1.0 / u).ln();
                candidate[d] = if rng.random::<bool>() {
                    attractor + spread
                } else {
                    attractor - spread
                };
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
    fn contraction_falls_from_one_to_one_half() {
        let config = QpsoConfig::default();
        assert_eq!(config.contraction(0, 200), 1.0);
        assert_eq!(config.contraction(100, 200), 0.75);
        assert_eq!(config.contraction(200, 200), 0.5);
    }

    #[test]
    fn personal_bests_never_worsen_while_positions_move_freely() {
        let problem = Benchmark::new(TestFunction::Rastrigin, 3, true).unwrap();
        let mut rng = seeded(6);
        let mut population =
            Population::evaluate(&problem, problem.bounds().sample_uniform(20, &mut rng)).unwrap();
        let mut qpso = Qpso::new(QpsoConfig::default()).unwrap();
        qpso.start(&problem, &population, 40).unwrap();
        let mut someone_got_worse = false;
        for _ in 0..40 {
            let (before, personal_before) = (
                population.fitness().to_vec(),
                qpso.personal.fitness().to_vec(),
            );
            qpso.step(&problem, &mut population, &mut rng).unwrap();
            someone_got_worse |= population.fitness().iter().zip(&before).any(|(a, b)| a > b);
            assert!(
                qpso.personal
                    .fitness()
                    .iter()
                    .zip(&personal_before)
                    .all(|(a, b)| a <= b)
            );
            assert!(
                qpso.personal
                    .fitness()
                    .iter()
                    .zip(population.fitness())
                    .all(|(p, f)| p <= f)
            );
        }
        assert!(someone_got_worse, "QPSO positions must not be greedy");
        assert_eq!(qpso.evaluations(), 40 * 20);
    }
}
