//! The pieces every optimiser shares: batch evaluation (clip, evaluate in parallel, count,
//! keep the best), greedy and unconditional acceptance, personal bests, schedules.

use super::{Best, MIN_POPULATION, Population, Problem};
use crate::rng::SimRng;
use crate::{Error, Result};
use rand::RngExt;
use rayon::prelude::*;

/// A fitness with NaN ranked as the worst value, so every comparison is total.
fn rank_nan_last(f: f64) -> f64 {
    if f.is_nan() { f64::INFINITY } else { f }
}

/// Evaluates `positions` (row-major, one row per entry of `members`) into `out`, in order.
///
/// # Performance
///
/// In parallel when [`Problem::parallel`]; the output order is the input order either way,
/// so the result does not depend on the number of threads.
pub(super) fn evaluate_into(
    problem: &dyn Problem,
    members: &[usize],
    positions: &[f64],
    out: &mut Vec<f64>,
) {
    let dim = problem.dim();
    let fitness = |(&member, x): (&usize, &[f64])| rank_nan_last(problem.fitness(member, x));
    if problem.parallel() {
        members
            .par_iter()
            .zip(positions.par_chunks_exact(dim))
            .map(fitness)
            .collect_into_vec(out);
    } else {
        out.clear();
        out.extend(members.iter().zip(positions.chunks_exact(dim)).map(fitness));
    }
}

/// Population updates the optimisers make (crate-private: only accepted candidates move a
/// member).
impl Population {
    /// Lowest fitness in the population.
    pub(super) fn min_fitness(&self) -> f64 {
        self.fitness.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Puts member `i` at `x` with fitness `f`, marking it moved if the position changed.
    fn replace(&mut self, i: usize, x: &[f64], f: f64) {
        let row = &mut self.positions[i * self.dim..(i + 1) * self.dim];
        if row != x {
            row.copy_from_slice(x);
            self.moved[i] = true;
        }
        self.fitness[i] = f;
    }

    /// Greedy acceptance (§3): each candidate replaces its member only if strictly better, so
    /// a tie leaves the particle (and its map) untouched.
    pub(super) fn accept_greedy(&mut self, batch: &Batch) {
        for j in 0..batch.len() {
            let (i, f) = (batch.members[j], batch.fitness[j]);
            if f < self.fitness[i] {
                self.replace(i, batch.position(j), f);
            }
        }
    }

    /// Unconditional acceptance (GWO, QPSO and PSO always move).
    pub(super) fn accept_all(&mut self, batch: &Batch) {
        for j in 0..batch.len() {
            self.replace(batch.members[j], batch.position(j), batch.fitness[j]);
        }
    }
}

/// Book-keeping every optimiser shares: the run's shape, the generation counter `k`, the
/// evaluation count and the best positions seen (one, or GWO's three leaders).
///
/// Opaque outside this module: an optimiser owns one and exposes it through
/// [`Optimiser::run_state`](super::Optimiser::run_state), from which the trait's default
/// methods read the best position and the evaluation count.
#[derive(Debug, Clone, Default)]
pub struct RunState {
    members: usize,
    dim: usize,
    iterations: usize,
    generation: usize,
    evaluations: u64,
    leaders: Vec<Best>,
    capacity: usize,
}

impl RunState {
    /// A run over `population` for `iterations` generations that remembers the `capacity`
    /// best positions seen, starting with the population's own.
    pub(super) fn start(
        problem: &dyn Problem,
        population: &Population,
        iterations: usize,
        capacity: usize,
    ) -> Result<Self> {
        if population.dim() != problem.dim() {
            return Err(Error::PopulationMismatch {
                reason: format!(
                    "members have {} dimensions, the problem {}",
                    population.dim(),
                    problem.dim()
                ),
            });
        }
        if population.len() < MIN_POPULATION {
            return Err(Error::PopulationMismatch {
                reason: format!(
                    "{} members, at least {MIN_POPULATION} needed",
                    population.len()
                ),
            });
        }
        let mut run = Self {
            members: population.len(),
            dim: population.dim(),
            iterations,
            capacity,
            ..Self::default()
        };
        for i in 0..population.len() {
            run.offer(i, population.position(i), population.fitness()[i]);
        }
        Ok(run)
    }

    /// Checks the shape and advances to the next generation; returns its index `k` (1-based).
    pub(super) fn next_generation(
        &mut self,
        problem: &dyn Problem,
        population: &Population,
    ) -> Result<usize> {
        if population.len() != self.members
            || population.dim() != self.dim
            || problem.dim() != self.dim
        {
            return Err(Error::PopulationMismatch {
                reason: format!(
                    "the run was started with {} members of dimension {} (call `start` first); \
                     got {} members of dimension {} on a {}-dimensional problem",
                    self.members,
                    self.dim,
                    population.len(),
                    population.dim(),
                    problem.dim()
                ),
            });
        }
        self.generation += 1;
        Ok(self.generation)
    }

    /// Clips, evaluates and counts a batch of candidates, and keeps the best seen.
    pub(super) fn evaluate(&mut self, problem: &dyn Problem, batch: &mut Batch) {
        let bounds = problem.bounds();
        for row in batch.positions.chunks_exact_mut(batch.dim) {
            bounds.clip(row);
        }
        evaluate_into(
            problem,
            &batch.members,
            &batch.positions,
            &mut batch.fitness,
        );
        self.evaluations += batch.len() as u64;
        for j in 0..batch.len() {
            self.offer(batch.members[j], batch.position(j), batch.fitness[j]);
        }
    }

    /// Keeps `x` if it is among the `capacity` best seen (strictly better than the worst
    /// kept; ties keep the earlier one).
    fn offer(&mut self, member: usize, x: &[f64], fitness: f64) {
        if self.leaders.len() == self.capacity
            && self.leaders.last().is_none_or(|w| fitness >= w.fitness)
        {
            return;
        }
        let at = self.leaders.partition_point(|b| b.fitness <= fitness);
        self.leaders.insert(
            at,
            Best {
                member,
                position: x.to_vec(),
                fitness,
            },
        );
        self.leaders.truncate(self.capacity);
    }

    /// Fitness evaluations since `start`.
    pub(super) fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// `K`, the generations announced to `start`.
    pub(super) fn iterations(&self) -> usize {
        self.iterations
    }

    /// The best positions seen, best first (at most the capacity given to `start`).
    pub(super) fn leaders(&self) -> &[Best] {
        &self.leaders
    }

    /// The best position seen.
    pub(super) fn best(&self) -> Option<&Best> {
        self.leaders.first()
    }

    /// Position of the best seen, copied so the population can change while it is used.
    pub(super) fn best_position(&self) -> Vec<f64> {
        self.best().map(|b| b.position.clone()).unwrap_or_default()
    }
}

/// A generation's candidates: member index and position per row, fitness once evaluated.
/// Kept by each optimiser and reused, so a generation allocates nothing after the first.
#[derive(Debug, Clone, Default)]
pub(super) struct Batch {
    dim: usize,
    members: Vec<usize>,
    positions: Vec<f64>,
    fitness: Vec<f64>,
}

impl Batch {
    /// Empties the batch for candidates of dimension `dim`.
    pub(super) fn reset(&mut self, dim: usize) {
        self.dim = dim;
        self.members.clear();
        self.positions.clear();
        self.fitness.clear();
    }

    /// Appends a candidate for `member`, initialised to `start`; returns it for editing.
    pub(super) fn push(&mut self, member: usize, start: &[f64]) -> &mut [f64] {
        self.members.push(member);
        self.positions.extend_from_slice(start);
        let from = self.positions.len() - self.dim;
        &mut self.positions[from..]
    }

    /// Number of candidates.
    pub(super) fn len(&self) -> usize {
        self.members.len()
    }

    /// Fitness of candidate `j` (after evaluation).
    pub(super) fn fitness(&self, j: usize) -> f64 {
        self.fitness[j]
    }

    /// Position of candidate `j`.
    pub(super) fn position(&self, j: usize) -> &[f64] {
        &self.positions[j * self.dim..(j + 1) * self.dim]
    }
}

/// Personal bests `P_i` (PSO and QPSO): each member's best position, updated greedily.
#[derive(Debug, Clone, Default)]
pub(super) struct PersonalBests {
    dim: usize,
    positions: Vec<f64>,
    fitness: Vec<f64>,
}

impl PersonalBests {
    /// Every member's current position is its personal best.
    pub(super) fn from_population(population: &Population) -> Self {
        Self {
            dim: population.dim(),
            positions: population.positions().to_vec(),
            fitness: population.fitness().to_vec(),
        }
    }

    /// Fitness of each personal best (tests check it never worsens).
    #[cfg(test)]
    pub(super) fn fitness(&self) -> &[f64] {
        &self.fitness
    }

    /// Personal best of member `i`.
    pub(super) fn position(&self, i: usize) -> &[f64] {
        &self.positions[i * self.dim..(i + 1) * self.dim]
    }

    /// Replaces `P_i` by its candidate when strictly better.
    pub(super) fn update(&mut self, batch: &Batch) {
        for j in 0..batch.len() {
            let i = batch.members[j];
            if batch.fitness[j] < self.fitness[i] {
                self.fitness[i] = batch.fitness[j];
                self.positions[i * self.dim..(i + 1) * self.dim].copy_from_slice(batch.position(j));
            }
        }
    }
}

/// Progress `k / K` of generation `k` in a run of `K`, in [0, 1]: held at 1 past the end (the
/// schedules keep their final values) and for `K = 0`.
pub(super) fn progress(k: usize, iterations: usize) -> f64 {
    if iterations == 0 {
        1.0
    } else {
        k.min(iterations) as f64 / iterations as f64
    }
}

/// `start + (end − start) · k/K`: the linear schedules of GWO, QPSO and PSO.
pub(super) fn linear(start: f64, end: f64, k: usize, iterations: usize) -> f64 {
    start + (end - start) * progress(k, iterations)
}

/// A uniform index in `0..n` other than `exclude` (`n ≥ 2`).
pub(super) fn index_other_than(n: usize, exclude: usize, rng: &mut SimRng) -> usize {
    let j = rng.random_range(0..n - 1);
    if j >= exclude { j + 1 } else { j }
}

/// `Ok` when `ok`, else [`Error::InvalidParameter`] for `name` with `reason`.
pub(super) fn ensure(ok: bool, name: &'static str, reason: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            reason: reason.into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_run_from_start_to_end_and_hold() {
        assert_eq!(linear(0.9, 0.4, 0, 200), 0.9);
        assert_eq!(linear(0.9, 0.4, 100, 200), 0.65);
        assert_eq!(linear(0.9, 0.4, 200, 200), 0.4);
        assert_eq!(linear(0.9, 0.4, 500, 200), 0.4);
        assert_eq!(progress(3, 0), 1.0);
    }

    #[test]
    fn leaders_keep_the_best_three_in_order() {
        let mut run = RunState {
            capacity: 3,
            ..RunState::default()
        };
        for (member, f) in [(0, 5.0), (1, 3.0), (2, 4.0), (3, 1.0), (4, 3.0), (5, 9.0)] {
            run.offer(member, &[f], f);
        }
        let kept: Vec<(usize, f64)> = run.leaders.iter().map(|b| (b.member, b.fitness)).collect();
        assert_eq!(kept, [(3, 1.0), (1, 3.0), (4, 3.0)]);
    }
}
