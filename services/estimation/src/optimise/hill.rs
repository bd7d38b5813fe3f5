//! Hill climbing, GMapping's scan matcher (Grisetti, Stachniss & Burgard 2007) as an
//! optimiser (docs/ALGORITHMS.md §4.6): the baseline every metaheuristic here has to beat.
//!
//! Every member climbs on its own. Per generation it tries one step forward and one back
//! along each coordinate (`2D` candidates) and moves to the best of them when that is
//! strictly better; when none is, its step halves. Steps start at a third of the box's
//! half-width (one standard deviation of the motion prior in the corrected modes, whose
//! box is ±3σ). No random draw: the search is deterministic.

use super::shared::{Batch, RunState};
use super::{Optimiser, OptimiserKind, Population, Problem};
use crate::Result;
use crate::rng::SimRng;

/// Initial step as a fraction of the box's half-width per coordinate.
const INITIAL_STEP: f64 = 1.0 / 3.0;

/// Coordinate-wise hill climbing with step halving.
#[derive(Debug, Clone, Default)]
pub struct HillClimb {
    run: RunState,
    candidates: Batch,
    /// Current step per member and coordinate (row-major).
    steps: Vec<f64>,
}

impl HillClimb {
    /// A hill climber (it has no constants).
    pub fn new() -> Self {
        Self::default()
    }
}

impl Optimiser for HillClimb {
    fn kind(&self) -> OptimiserKind {
        OptimiserKind::Hill
    }

    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()> {
        self.run = RunState::start(problem, population, iterations, 1)?;
        let bounds = problem.bounds();
        self.steps = (0..population.len())
            .flat_map(|_| (0..bounds.dim()).map(|d| INITIAL_STEP * bounds.half_width(d)))
            .collect();
        Ok(())
    }

    fn step(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        _rng: &mut SimRng,
    ) -> Result<()> {
        self.run.next_generation(problem, population)?;
        let dim = population.dim();
        self.candidates.reset(dim);
        for i in 0..population.len() {
            for d in 0..dim {
                for sign in [1.0, -1.0] {
                    let step = self.steps[i * dim + d];
                    self.candidates.push(i, population.position(i))[d] += sign * step;
                }
            }
        }
        self.run.evaluate(problem, &mut self.candidates);
        let before = population.fitness().to_vec();
        population.accept_greedy(&self.candidates);
        for (i, &f) in before.iter().enumerate() {
            if population.fitness()[i] >= f {
                self.steps[i * dim..(i + 1) * dim]
                    .iter_mut()
                    .for_each(|s| *s *= 0.5);
            }
        }
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
    fn climbs_a_bowl_to_its_bottom_without_drawing() {
        let problem = Benchmark::new(TestFunction::Sphere, 3, false).unwrap();
        let mut rng = seeded(2);
        let start = problem.bounds().sample_uniform(4, &mut rng);
        let mut population = Population::evaluate(&problem, start).unwrap();
        let mut hill = HillClimb::new();
        let mut untouched = seeded(9);
        let summary = hill
            .run(&problem, &mut population, 200, &mut untouched)
            .unwrap();
        assert!(summary.best.fitness < 1e-6, "{summary:?}");
        assert_eq!(summary.evaluations, 200 * 4 * 6);
        assert_eq!(untouched, seeded(9), "the search draws nothing");
    }

    #[test]
    fn a_member_that_cannot_improve_halves_its_step_and_stays() {
        let problem = Benchmark::new(TestFunction::Sphere, 2, false).unwrap();
        let mut population = Population::evaluate(&problem, vec![0.0, 0.0, 50.0, 0.0]).unwrap();
        let mut hill = HillClimb::new();
        hill.start(&problem, &population, 1).unwrap();
        let first = hill.steps.clone();
        hill.step(&problem, &mut population, &mut seeded(1))
            .unwrap();
        assert_eq!(population.position(0), &[0.0, 0.0]);
        assert_eq!(hill.steps[0], 0.5 * first[0]);
        assert!(
            population.fitness()[1] < 2500.0,
            "the second member went downhill"
        );
    }
}
