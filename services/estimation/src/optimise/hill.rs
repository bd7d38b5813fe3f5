//! Hill climbing, GMapping's scan matcher (Grisetti, Stachniss & Burgard 2007) as an
//! optimiser (docs/ALGORITHMS.md §4.6): the baseline every metaheuristic here has to beat.
//!
//! Every member climbs on its own. Per generation it tries one step forward and one back
//! along each coordinate (`2D` candidates) and moves to the best of them when that is
//! strictly better; when none is, its step halves. Steps start at a third of the box's
//! half-width (one standard deviation of the motion prior in the corrected modes, whose
//! box is ±3σ). Only the [`HillConfig::climbers`] members that start best climb, and a
//! member whose step has halved [`HillConfig::refinements`] times stops, as GMapping's
//! matcher does after its `iterations` refinements: the generations a member does not
//! climb cost nothing. No random draw: the search is deterministic.

use super::shared::{Batch, RunState};
use super::{Optimiser, OptimiserKind, Population, Problem};
use crate::Result;
use crate::rng::SimRng;
use serde::{Deserialize, Serialize};

/// Initial step as a fraction of the box's half-width per coordinate.
const INITIAL_STEP: f64 = 1.0 / 3.0;

/// The hill climber's constants.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HillConfig {
    /// How many members climb: those of the best starting fitness (count; the first of
    /// equals); the others keep their start. 0: every member. Default 0. GMapping's matcher
    /// climbs from one start.
    pub climbers: usize,
    /// A member stops once its step has halved this many times (count); 0 never stops it
    /// before the run's last generation. Default 0. GMapping's matcher stops after its
    /// `iterations` refinements (5 in `slam_gmapping`).
    pub refinements: usize,
}

/// Coordinate-wise hill climbing with step halving.
#[derive(Debug, Clone, Default)]
pub struct HillClimb {
    config: HillConfig,
    run: RunState,
    candidates: Batch,
    /// Current step per member and coordinate (row-major).
    steps: Vec<f64>,
    /// Times each member's step has halved.
    halvings: Vec<usize>,
    /// Whether each member climbs at all (one of the `climbers` best at the start).
    chosen: Vec<bool>,
}

impl HillClimb {
    /// A hill climber with `config`'s constants.
    pub fn new(config: HillConfig) -> Self {
        Self {
            config,
            ..Self::default()
        }
    }

    /// Whether member `i` still climbs: it is one of the chosen, and its step has not
    /// halved `refinements` times.
    fn climbing(&self, i: usize) -> bool {
        let refinements = self.config.refinements;
        self.chosen[i] && (refinements == 0 || self.halvings[i] < refinements)
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
        self.halvings = vec![0; population.len()];
        self.chosen = best_starts(population.fitness(), self.config.climbers);
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
            if !self.climbing(i) {
                continue;
            }
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
            if self.climbing(i) && population.fitness()[i] >= f {
                self.steps[i * dim..(i + 1) * dim]
                    .iter_mut()
                    .for_each(|s| *s *= 0.5);
                self.halvings[i] += 1;
            }
        }
        Ok(())
    }

    fn run_state(&self) -> &RunState {
        &self.run
    }
}

/// Which members climb: the `climbers` of the lowest `fitness` (the first of equals), or
/// all when `climbers` is 0 or covers them.
fn best_starts(fitness: &[f64], climbers: usize) -> Vec<bool> {
    if climbers == 0 || climbers >= fitness.len() {
        return vec![true; fitness.len()];
    }
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    order.sort_by(|&a, &b| fitness[a].total_cmp(&fitness[b]).then(a.cmp(&b)));
    let mut chosen = vec![false; fitness.len()];
    for &i in &order[..climbers] {
        chosen[i] = true;
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimise::RunSummary;
    use crate::optimise::test_functions::{Benchmark, TestFunction};
    use crate::rng::seeded;

    #[test]
    fn climbs_a_bowl_to_its_bottom_without_drawing() {
        let problem = Benchmark::new(TestFunction::Sphere, 3, false).unwrap();
        let mut rng = seeded(2);
        let start = problem.bounds().sample_uniform(4, &mut rng);
        let mut population = Population::evaluate(&problem, start).unwrap();
        let mut hill = HillClimb::new(HillConfig::default());
        let mut untouched = seeded(9);
        let summary = hill
            .run(&problem, &mut population, 200, &mut untouched)
            .unwrap();
        assert!(summary.best.fitness < 1e-6, "{summary:?}");
        assert_eq!(summary.evaluations, 200 * 4 * 6);
        assert_eq!(untouched, seeded(9), "the search draws nothing");
    }

    /// Ten generations of `config` on the 2-D sphere from `starts` (two coordinates a
    /// member): the climber, the population after them and the run's summary.
    fn climb(config: HillConfig, starts: &[f64]) -> (HillClimb, Population, RunSummary) {
        let problem = Benchmark::new(TestFunction::Sphere, 2, false).unwrap();
        let mut population = Population::evaluate(&problem, starts.to_vec()).unwrap();
        let mut hill = HillClimb::new(config);
        let summary = hill
            .run(&problem, &mut population, 10, &mut seeded(1))
            .unwrap();
        (hill, population, summary)
    }

    #[test]
    fn a_member_stops_after_its_refinements() {
        let starts = [0.0, 0.0, 50.0, 0.0];
        let bounded = HillConfig {
            refinements: 2,
            ..HillConfig::default()
        };
        let (hill, _, summary) = climb(bounded, &starts);
        assert_eq!(hill.halvings[0], 2, "the member at the bottom stopped");
        assert!(summary.evaluations < 10 * 2 * 4, "{summary:?}");
        let (_, _, all) = climb(HillConfig::default(), &starts);
        assert_eq!(all.evaluations, 10 * 2 * 4);
    }

    #[test]
    fn only_the_best_starts_climb() {
        let starts = [40.0, 0.0, 10.0, 0.0, 30.0, 0.0];
        let one = HillConfig {
            climbers: 1,
            ..HillConfig::default()
        };
        let (_, population, summary) = climb(one, &starts);
        assert_eq!(summary.evaluations, 10 * 4, "one member climbed");
        assert_eq!(population.position(0), &starts[0..2]);
        assert_eq!(population.position(2), &starts[4..6]);
        assert!(
            population.fitness()[1] < 100.0,
            "{:?}",
            population.fitness()
        );
    }

    #[test]
    fn a_member_that_cannot_improve_halves_its_step_and_stays() {
        let problem = Benchmark::new(TestFunction::Sphere, 2, false).unwrap();
        let mut population = Population::evaluate(&problem, vec![0.0, 0.0, 50.0, 0.0]).unwrap();
        let mut hill = HillClimb::new(HillConfig::default());
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
