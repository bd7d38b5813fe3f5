//! COA — Coati Optimisation Algorithm (Dehghani et al. 2023; ICOA paper §2.1, eqs. 6–12;
//! docs/ALGORITHMS.md §4.1).
//!
//! Each generation: phase 1 (exploration) — the first half of the population climbs toward
//! the best member `X_b` ("iguana"), the second half reacts to an iguana dropped at a random
//! point `G`; phase 2 (exploitation) — every coati escapes within local bounds `lb/k, ub/k`.
//! Greedy acceptance after each phase. Cost: 2.5 N evaluations per generation.
//!
//! Choices where the authors' MATLAB code differs from the settled formulas (§4.1):
//! - `r` is drawn per dimension (their code: one scalar per member per use), and so is the
//!   ground iguana `G` (their single scalar puts it on the box diagonal);
//! - phase-2 candidates are clipped to the global bounds (their clamp to `[lb/k, ub/k]`
//!   anchors late candidates at the origin);
//! - `X_b` is the best member at the start of the generation (as in their code), so the
//!   whole phase is one batch.
//!
//! The phases are shared with ICOA, which scales `X` by an inertia weight and replaces the
//! phase-1 coefficient `r` by its chaotic sequence.

use super::{Batch, Optimiser, OptimiserKind, Population, Problem, RunState};
use crate::Result;
use crate::rng::SimRng;
use rand::RngExt;

/// Inertia weight of plain COA: `X` enters the updates unscaled.
pub(crate) const NO_INERTIA: f64 = 1.0;

/// The Coati Optimisation Algorithm. It has no tunable constants: `I ∈ {1, 2}` (eq. 7) and the
/// local bounds `lb/k` (eq. 10) are part of the method.
#[derive(Debug, Clone, Default)]
pub struct Coa {
    run: RunState,
    phases: CoaPhases,
}

impl Coa {
    /// A COA optimiser.
    pub fn new() -> Self {
        Self::default()
    }
}

impl Optimiser for Coa {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Coa
    }

    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()> {
        self.run = RunState::start(problem, population, iterations, 1)?;
        Ok(())
    }

    fn step(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
    ) -> Result<()> {
        let k = self.run.next_generation(problem, population)?;
        self.phases
            .explore(&mut self.run, problem, population, rng, NO_INERTIA, |rng| {
                rng.random()
            });
        self.phases
            .escape(&mut self.run, problem, population, rng, k, NO_INERTIA);
        Ok(())
    }

    fn run_state(&self) -> &RunState {
        &self.run
    }
}

/// COA's two phases with their reusable candidate buffers; ICOA runs them too.
#[derive(Debug, Clone, Default)]
pub(crate) struct CoaPhases {
    iguanas: Batch,
    candidates: Batch,
}

impl CoaPhases {
    /// Phase 1, hunting the iguana (eqs. 7–9; ICOA eqs. 16–17), then greedy acceptance.
    ///
    /// First half `i < ⌊N/2⌋`: `X' = ω X + c (X_b − I X)`. Second half: `G = lb + r (ub − lb)`
    /// is evaluated for the member; `X' = X + c (G − I X)` if `F(G) < F(X)`, else
    /// `X' = X + c (X − G)`. `I ∈ {1, 2}` is one fair draw per member, `c` comes from
    /// `coefficient` once per dimension (U(0,1) for COA, the circle map for ICOA), `ω` is
    /// `inertia` (1 for COA).
    pub(crate) fn explore(
        &mut self,
        run: &mut RunState,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
        inertia: f64,
        mut coefficient: impl FnMut(&mut SimRng) -> f64,
    ) {
        let (n, dim) = (population.len(), population.dim());
        let half = n / 2;
        let iguana = run.best_position();

        // The ground iguanas of the second half, one per member, evaluated for that member.
        self.iguanas.reset(dim);
        for i in half..n {
            let ground = self.iguanas.push(i, population.position(i));
            problem.bounds().sample_into(ground, rng);
        }
        run.evaluate(problem, &mut self.iguanas);

        self.candidates.reset(dim);
        for i in 0..n {
            let x = population.position(i);
            let intensity = if rng.random::<bool>() { 2.0 } else { 1.0 };
            let candidate = self.candidates.push(i, x);
            if i < half {
                for d in 0..dim {
                    candidate[d] =
                        inertia * x[d] + coefficient(rng) * (iguana[d] - intensity * x[d]);
                }
            } else {
                let j = i - half;
                let ground = self.iguanas.position(j);
                let ground_is_better = self.iguanas.fitness(j) < population.fitness()[i];
                for d in 0..dim {
                    let towards = if ground_is_better {
                        ground[d] - intensity * x[d]
                    } else {
                        x[d] - ground[d]
                    };
                    candidate[d] = x[d] + coefficient(rng) * towards;
                }
            }
        }
        run.evaluate(problem, &mut self.candidates);
        population.accept_greedy(&self.candidates);
    }

    /// Phase 2, escaping predators (eqs. 10–11; ICOA eq. 18), then greedy acceptance:
    /// `X' = ω X + (1 − 2r) (lb/k + r (ub/k − lb/k))`, two fresh `r` per dimension, where `k`
    /// is the generation (1-based).
    pub(crate) fn escape(
        &mut self,
        run: &mut RunState,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
        k: usize,
        inertia: f64,
    ) {
        let bounds = problem.bounds();
        let k = k as f64;
        self.candidates.reset(population.dim());
        for i in 0..population.len() {
            let x = population.position(i);
            let candidate = self.candidates.push(i, x);
            for d in 0..x.len() {
                let (lower, upper) = (bounds.lower()[d] / k, bounds.upper()[d] / k);
                let sign = 1.0 - 2.0 * rng.random::<f64>();
                candidate[d] =
                    inertia * x[d] + sign * (lower + rng.random::<f64>() * (upper - lower));
            }
        }
        run.evaluate(problem, &mut self.candidates);
        population.accept_greedy(&self.candidates);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimise::test_functions::{Benchmark, TestFunction};
    use crate::rng::seeded;

    #[test]
    fn costs_two_and_a_half_evaluations_per_member_and_generation() {
        let problem = Benchmark::new(TestFunction::Sphere, 3, false).unwrap();
        let mut rng = seeded(1);
        let mut population =
            Population::evaluate(&problem, problem.bounds().sample_uniform(30, &mut rng)).unwrap();
        let summary = Coa::new()
            .run(&problem, &mut population, 200, &mut rng)
            .unwrap();
        // + 30 initial evaluations = 15 030, the reference tables' count.
        assert_eq!(summary.evaluations, 15_000);
    }

    #[test]
    fn never_worsens_a_member() {
        let problem = Benchmark::new(TestFunction::Rastrigin, 3, true).unwrap();
        let mut rng = seeded(2);
        let mut population =
            Population::evaluate(&problem, problem.bounds().sample_uniform(10, &mut rng)).unwrap();
        let mut optimiser = Coa::new();
        optimiser.start(&problem, &population, 20).unwrap();
        for _ in 0..20 {
            let before = population.fitness().to_vec();
            optimiser.step(&problem, &mut population, &mut rng).unwrap();
            assert!(
                population
                    .fitness()
                    .iter()
                    .zip(&before)
                    .all(|(after, before)| after <= before)
            );
        }
        let best = optimiser.best().unwrap();
        assert_eq!(
            best.fitness,
            population
                .fitness()
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min)
        );
    }
}
