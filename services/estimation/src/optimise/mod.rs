//! Particle optimisers behind one interface (docs/ALGORITHMS.md §3–§4): COA, ICOA, BA, IBA, GWO,
//! QPSO and PSO move a population of `D`-dimensional vectors inside a [`Bounds`] box toward
//! lower fitness.
//!
//! The same code runs inside the particle filter and on plain test functions
//! ([`test_functions`]):
//!
//! - **Member `i` is particle `i`.** Its fitness depends on the member (each particle has its
//!   own map), so a [`Problem`] is asked for `fitness(member, x)`; test functions ignore the
//!   index. Lower is better.
//! - **One generation per [`Optimiser::step`]**, after [`Optimiser::start`] has seen the
//!   evaluated [`Population`] and the number of generations `K` of the run (the schedules
//!   ω(k), a(k), β(k) need it). [`Optimiser::run`] does both.
//! - **Reading back.** Final positions are read from the population; its
//!   [`Population::moved`] flags tell the filter which particles changed (their weights and
//!   maps must then be recomputed at the new pose).
//! - **`none` is no optimiser.** [`OptimiserConfig::build`] returns `Ok(None)` for
//!   [`OptimiserKind::None`], so plain FastSLAM skips the step instead of running a fake.
//!
//! # Determinism
//!
//! Every random draw comes from the one [`SimRng`] passed to `step`, in member order,
//! while a generation's candidates are generated. The candidates are then clipped to the
//! bounds and evaluated as one batch — in parallel with rayon when
//! [`Problem::parallel`] says so. Each evaluation is a pure function of (member, candidate)
//! and results are collected in member order, so a run is bit-identical whatever the thread
//! count.
//!
//! # Fitness evaluations per generation (population `N`)
//!
//! | optimiser | evaluations | 30 members × 200 generations (+ 30 initial) |
//! |---|---|---|
//! | COA | 2.5 N (N/2 ground iguanas, N phase 1, N phase 2) | 15 030 |
//! | ICOA | 3.5 N (COA + N elite/Cauchy candidates) | 21 030 |
//! | BA, GWO, QPSO, PSO | N | 6 030 |
//! | IBA | at most N (a butterfly outside every fragrance radius does not move) | ≤ 6 030 |
//!
//! BOA_MATLAB in the reference tables counts 12 030 because the authors' code evaluates each
//! butterfly twice per generation; the method needs one.
//!
//! # Example
//!
//! ```
//! use fastslam_estimation::optimise::test_functions::{Benchmark, TestFunction};
//! use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind, Population, Problem};
//! use fastslam_estimation::rng::seeded;
//!
//! # fn main() -> fastslam_estimation::Result<()> {
//! let problem = Benchmark::new(TestFunction::Sphere, 3, false)?;
//! let kind: OptimiserKind = "pso".parse()?; // the name used in config files
//! let config = OptimiserConfig { kind, ..OptimiserConfig::default() };
//! let mut rng = seeded(1);
//! let Some(mut optimiser) = config.build(&mut rng)? else { return Ok(()) };
//! let start = optimiser.initial_positions(problem.bounds(), 20, &mut rng);
//! let mut population = Population::evaluate(&problem, start)?;
//! let summary = optimiser.run(&problem, &mut population, 50, &mut rng)?;
//! assert!(summary.best.fitness < 1.0);
//! assert_eq!(summary.evaluations, 20 * 50);
//! # Ok(())
//! # }
//! ```

mod ba;
mod bounds;
pub mod chaos;
mod coa;
mod config;
mod gwo;
mod hill;
mod iba;
mod icoa;
pub mod levy;
mod population;
mod pso;
mod qpso;
mod shared;
pub mod test_functions;

pub use ba::{Ba, BaConfig, FragranceConfig};
pub use bounds::Bounds;
pub use coa::Coa;
pub use config::{OptimiserConfig, OptimiserKind};
pub use gwo::{Gwo, GwoConfig};
pub use hill::{HillClimb, HillConfig};
pub use iba::{Iba, IbaConfig};
pub use icoa::{Icoa, IcoaConfig};
pub use population::{FnProblem, Population, Problem};
pub use pso::{Pso, PsoConfig};
pub use qpso::{Qpso, QpsoConfig};
pub use shared::RunState;

use crate::rng::SimRng;
use crate::{Error, Result};
use shared::{Batch, PersonalBests, ensure, index_other_than, linear, progress};
use std::fmt;

/// Fewest members a run accepts: the butterflies need two distinct partners `j ≠ k`, and a
/// population of one has nothing to learn from.
pub const MIN_POPULATION: usize = 2;

/// A position and its fitness, as evaluated for `member` (fitness is per member).
#[derive(Debug, Clone, PartialEq)]
pub struct Best {
    /// The member whose fitness was evaluated at `position`.
    pub member: usize,
    /// The position.
    pub position: Vec<f64>,
    /// Its fitness (lower is better).
    pub fitness: f64,
}

/// What [`Optimiser::run`] reports.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Best position seen during the run (including the initial population).
    pub best: Best,
    /// Fitness evaluations made by the run (the initial population's are not counted).
    pub evaluations: u64,
    /// Members whose position differs from where they were when the population was built
    /// (or last cleared).
    pub moved: usize,
}

/// A population optimiser: one generation per [`Optimiser::step`] (STYLE habit 4).
///
/// Object safe, so the filter holds a `Box<dyn Optimiser>` built by
/// [`OptimiserConfig::build`].
pub trait Optimiser: Send + Sync + fmt::Debug {
    /// Which optimiser this is.
    fn kind(&self) -> OptimiserKind;

    /// Begins a run of `iterations` generations (`K`) from an evaluated population:
    /// resets the generation counter, the best-so-far and per-run memories (personal bests,
    /// velocities, sensory modality). Persistent state — ICOA's chaotic sequence — carries
    /// over from run to run.
    ///
    /// # Errors
    ///
    /// [`Error::PopulationMismatch`] when the population's dimension is not the problem's or
    /// it has fewer than [`MIN_POPULATION`] members.
    fn start(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
    ) -> Result<()>;

    /// One generation: draws candidates from `rng`, evaluates them, accepts per the method.
    /// Steps beyond the `K` announced to `start` keep the schedules at their final values.
    ///
    /// # Errors
    ///
    /// [`Error::PopulationMismatch`] when `start` has not been called with a population of
    /// this shape.
    fn step(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        rng: &mut SimRng,
    ) -> Result<()>;

    /// The book-keeping of the current run (generation, evaluations, best seen), which every
    /// optimiser keeps in one [`RunState`]; [`Optimiser::best`] and
    /// [`Optimiser::evaluations`] read it.
    fn run_state(&self) -> &RunState;

    /// Best position seen since `start` (`None` before).
    fn best(&self) -> Option<&Best> {
        self.run_state().best()
    }

    /// Fitness evaluations since `start`.
    fn evaluations(&self) -> u64 {
        self.run_state().evaluations()
    }

    /// `members` starting positions in `bounds` (row-major): uniform draws from `rng`;
    /// ICOA overrides this with its circle chaotic map (ICOA paper eq. 14).
    fn initial_positions(&mut self, bounds: &Bounds, members: usize, rng: &mut SimRng) -> Vec<f64> {
        bounds.sample_uniform(members, rng)
    }

    /// `start`, then `iterations` generations.
    ///
    /// # Errors
    ///
    /// As [`Optimiser::start`].
    fn run(
        &mut self,
        problem: &dyn Problem,
        population: &mut Population,
        iterations: usize,
        rng: &mut SimRng,
    ) -> Result<RunSummary> {
        self.start(problem, population, iterations)?;
        for _ in 0..iterations {
            self.step(problem, population, rng)?;
        }
        let best = self
            .best()
            .cloned()
            .ok_or_else(|| Error::PopulationMismatch {
                reason: "the run saw no member".into(),
            })?;
        Ok(RunSummary {
            best,
            evaluations: self.evaluations(),
            moved: population.moved_count(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::seeded;

    fn sphere(bounds: Bounds) -> FnProblem<impl Fn(usize, &[f64]) -> f64 + Sync> {
        FnProblem::new(bounds, |_, x: &[f64]| x.iter().map(|v| v * v).sum())
    }

    #[test]
    fn every_evaluated_candidate_is_inside_the_bounds() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let outside = AtomicUsize::new(0);
        let bounds = Bounds::new(vec![-1.0, 0.0], vec![1.0, 3.0]).unwrap();
        let inside = bounds.clone();
        // Optimum in a corner, so many raw candidates overshoot the box.
        let problem = FnProblem::new(bounds, |_, x: &[f64]| {
            if !inside.contains(x) {
                outside.fetch_add(1, Ordering::Relaxed);
            }
            (x[0] - 1.0).powi(2) + (x[1] - 3.0).powi(2)
        });
        for kind in OptimiserKind::ALL {
            let config = OptimiserConfig {
                kind,
                ..OptimiserConfig::default()
            };
            let mut rng = seeded(3);
            let Some(mut optimiser) = config.build(&mut rng).unwrap() else {
                continue;
            };
            let start = optimiser.initial_positions(problem.bounds(), 12, &mut rng);
            let mut population = Population::evaluate(&problem, start).unwrap();
            optimiser
                .run(&problem, &mut population, 30, &mut rng)
                .unwrap();
            assert_eq!(
                outside.load(Ordering::Relaxed),
                0,
                "{kind} evaluated outside the box"
            );
            assert!(
                optimiser.evaluations() > 0 || kind == OptimiserKind::Iba,
                "{kind}"
            );
        }
    }

    #[test]
    fn step_without_start_or_with_another_population_is_an_error() {
        let problem = sphere(Bounds::cube(2, -1.0, 1.0).unwrap());
        let mut rng = seeded(1);
        let mut small = Population::evaluate(&problem, vec![0.1, 0.2, 0.3, 0.4]).unwrap();
        let mut optimiser = Coa::new();
        assert!(matches!(
            optimiser.step(&problem, &mut small, &mut rng),
            Err(Error::PopulationMismatch { .. })
        ));
        optimiser.start(&problem, &small, 5).unwrap();
        let mut large = Population::evaluate(&problem, vec![0.5; 6]).unwrap();
        assert!(optimiser.step(&problem, &mut large, &mut rng).is_err());
        let one = Population::evaluate(&problem, vec![0.5; 2]).unwrap();
        assert!(optimiser.start(&problem, &one, 5).is_err());
    }

    #[test]
    fn moved_flags_mark_exactly_the_changed_members() {
        let problem = sphere(Bounds::cube(2, -1.0, 1.0).unwrap());
        let mut rng = seeded(5);
        // Member 0 sits at the optimum: no candidate can be strictly better, so it stays.
        let start = vec![0.0, 0.0, 0.7, -0.4, -0.6, 0.9, 0.3, 0.8];
        let mut population = Population::evaluate(&problem, start.clone()).unwrap();
        let summary = Coa::new()
            .run(&problem, &mut population, 10, &mut rng)
            .unwrap();
        for i in 0..population.len() {
            let changed = population.position(i) != &start[2 * i..2 * i + 2];
            assert_eq!(population.moved()[i], changed);
        }
        assert!(!population.moved()[0]);
        assert_eq!(summary.moved, population.moved_count());
        assert!(summary.moved > 0);
        population.clear_moved();
        assert_eq!(population.moved_count(), 0);
    }

    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        // An evaluation expensive enough that rayon really splits the batch.
        let problem = FnProblem::new(
            Bounds::cube(3, -5.0, 5.0).unwrap(),
            |i: usize, x: &[f64]| {
                let mut s = i as f64 * 1e-3;
                for _ in 0..200 {
                    s = (s + x.iter().map(|v| v * v).sum::<f64>()).sqrt();
                }
                s
            },
        );
        let run_with = |threads: usize, kind: OptimiserKind| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let config = OptimiserConfig {
                    kind,
                    ..OptimiserConfig::default()
                };
                let mut rng = seeded(11);
                let mut optimiser = config.build(&mut rng).unwrap().unwrap();
                let start = optimiser.initial_positions(problem.bounds(), 40, &mut rng);
                let mut population = Population::evaluate(&problem, start).unwrap();
                optimiser
                    .run(&problem, &mut population, 15, &mut rng)
                    .unwrap();
                population
            })
        };
        for kind in OptimiserKind::ALL
            .into_iter()
            .filter(|&k| k != OptimiserKind::None)
        {
            let one = run_with(1, kind);
            let four = run_with(4, kind);
            assert_eq!(one.positions(), four.positions(), "{kind}");
            assert_eq!(one.fitness(), four.fitness(), "{kind}");
        }
    }
}
