//! GWO — grey wolf optimisation (Mirjalili et al. 2014; GWO-RBPF patent;
//! docs/ALGORITHMS.md §4.5).
//!
//! Leaders α, β, δ are the three best positions seen so far in the run. Each wolf moves to
//! the mean of three pulls, `X_n = X_leader − A |C X_leader − X|` with `A = 2a r₁ − a`,
//! `C = 2 r₂` fresh per leader and dimension and `a = a₀ (1 − k/K)`, and is always replaced
//! (no greedy step). Cost: N evaluations per generation. The patent's hill-climbing scan
//! match belongs to a grid back end, not to this interface.

use super::{Batch, Optimiser, OptimiserKind, Population, Problem, RunState, ensure, linear};
use crate::Result;
use crate::rng::SimRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// Number of leaders (α, β, δ).
const LEADERS: usize = 3;

/// GWO's constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GwoConfig {
    /// `a₀`: start of the linearly decreasing `a = a₀ (1 − k/K)` (Mirjalili 2014 eq. 3.3,
    /// dimensionless); `|A| > 1` explores while `a > 1`. Default 2.
    pub initial_a: f64,
}

impl Default for GwoConfig {
    fn default() -> Self {
        Self { initial_a: 2.0 }
    }
}

impl GwoConfig {
    /// `a(k) = a₀ (1 − k/K)` for generation `k` of `K` (Mirjalili 2014 eq. 3.3), held at 0 past
    /// the end.
    pub fn a(&self, k: usize, iterations: usize) -> f64 {
        linear(self.initial_a, 0.0, k, iterations)
    }

    /// Checks the range.
    ///
    /// # Errors
    ///
    /// [`crate::Error::InvalidParameter`] unless `initial_a` is finite and ≥ 0.
    pub fn validate(&self) -> Result<()> {
        ensure(
            self.initial_a >= 0.0 && self.initial_a.is_finite(),
            "initial_a",
            "must be finite and ≥ 0",
        )
    }
}

/// Grey wolf optimisation.
#[derive(Debug, Clone)]
pub struct Gwo {
    config: GwoConfig,
    run: RunState,
    candidates: Batch,
}

impl Gwo {
    /// GWO with `config`.
    ///
    /// # Errors
    ///
    /// As [`GwoConfig::validate`].
    pub fn new(config: GwoConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            run: RunState::default(),
            candidates: Batch::default(),
        })
    }
}

impl Optimiser for Gwo {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Gwo
    }

    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()> {
        self.run = RunState::start(problem, population, iterations, LEADERS)?;
        Ok(())
    }

    fn step(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
    ) -> Result<()> {
        let k = self.run.next_generation(problem, population)?;
        let a = self.config.a(k, self.run.iterations());
        let leaders = self.run.leaders();
        self.candidates.reset(population.dim());
        for i in 0..population.len() {
            let x = population.position(i);
            let candidate = self.candidates.push(i, x);
            for d in 0..x.len() {
                let pulls: f64 = leaders
                    .iter()
                    .map(|leader| {
                        let big_a = 2.0 * a * rng.random::<f64>() - a;
                        let big_c = 2.0 * rng.random::<f64>();
                        let l = leader.position[d];
                        l - big_a * (big_c * l - x[d]).abs()
                    })
                    .sum();
                candidate[d] = pulls / leaders.len() as f64;
            }
        }
        self.run.evaluate(problem, &mut self.candidates);
        population.accept_all(&self.candidates);
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
    fn wolves_always_move_and_leaders_are_the_best_seen() {
        let problem = Benchmark::new(TestFunction::Rastrigin, 3, true).unwrap();
        let mut rng = seeded(4);
        let mut population =
            Population::evaluate(&problem, problem.bounds().sample_uniform(20, &mut rng)).unwrap();
        let mut gwo = Gwo::new(GwoConfig::default()).unwrap();
        gwo.start(&problem, &population, 50).unwrap();
        let mut best_seen = population
            .fitness()
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        for _ in 0..50 {
            let before = population.positions().to_vec();
            gwo.step(&problem, &mut population, &mut rng).unwrap();
            assert_ne!(population.positions(), &before[..]);
            best_seen = population
                .fitness()
                .iter()
                .copied()
                .fold(best_seen, f64::min);
            let leaders = gwo.run.leaders();
            assert_eq!(leaders.len(), LEADERS);
            assert_eq!(leaders[0].fitness, best_seen);
            assert!(leaders.windows(2).all(|w| w[0].fitness <= w[1].fitness));
        }
        assert_eq!(gwo.evaluations(), 50 * 20);
    }

    #[test]
    fn a_falls_linearly_from_two_to_zero() {
        let config = GwoConfig::default();
        assert_eq!(config.a(0, 200), 2.0);
        assert_eq!(config.a(100, 200), 1.0);
        assert_eq!(config.a(200, 200), 0.0);
        assert_eq!(config.a(300, 200), 0.0);
    }
}
