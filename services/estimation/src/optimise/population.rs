//! What an optimiser works on: the [`Problem`] it minimises and the [`Population`] of
//! candidate positions with their fitness.

use super::Bounds;
use super::shared::evaluate_into;
use crate::{Error, Result};

/// What an optimiser minimises: a fitness per (member, candidate) over a box.
///
/// `Sync` because a batch of candidates may be evaluated on several threads at once.
pub trait Problem: Sync {
    /// The search box; its dimension is the problem's.
    fn bounds(&self) -> &Bounds;

    /// Fitness of candidate `x` for population member `member` (lower is better). In the
    /// filter, member `i` is particle `i` and the fitness is docs/ALGORITHMS.md §3's
    /// `F(x_i)` under particle `i`'s own map. A NaN is ranked as the worst value (+∞), so it
    /// is never accepted over a real value.
    fn fitness(&self, member: usize, x: &[f64]) -> f64;

    /// Number of dimensions `D` (that of the bounds).
    fn dim(&self) -> usize {
        self.bounds().dim()
    }

    /// Whether a batch of evaluations should be spread over rayon's threads.
    ///
    /// # Performance
    ///
    /// Parallel evaluation pays off when one evaluation costs more than rayon's per-task
    /// overhead (a few µs): true for FastSLAM (data association per particle), false for
    /// the test functions (tens of ns). The result is the same either way.
    fn parallel(&self) -> bool {
        true
    }
}

/// A [`Problem`] from bounds and a closure `fitness(member, x)` (lower is better).
pub struct FnProblem<F> {
    bounds: Bounds,
    fitness: F,
}

impl<F: Fn(usize, &[f64]) -> f64 + Sync> FnProblem<F> {
    /// A problem minimising `fitness` over `bounds`.
    pub fn new(bounds: Bounds, fitness: F) -> Self {
        Self { bounds, fitness }
    }
}

impl<F: Fn(usize, &[f64]) -> f64 + Sync> Problem for FnProblem<F> {
    fn bounds(&self) -> &Bounds {
        &self.bounds
    }

    fn fitness(&self, member: usize, x: &[f64]) -> f64 {
        (self.fitness)(member, x)
    }
}

/// `N` members of dimension `D`: positions (row-major `N × D`, one contiguous buffer),
/// the fitness of each, and which members have moved.
#[derive(Debug, Clone, PartialEq)]
pub struct Population {
    pub(super) dim: usize,
    pub(super) positions: Vec<f64>,
    pub(super) fitness: Vec<f64>,
    pub(super) moved: Vec<bool>,
}

impl Population {
    /// A population at `positions` (row-major, `members × problem.dim()`), each member
    /// evaluated once (`members` fitness evaluations, in parallel when the problem allows).
    ///
    /// Positions may lie outside the bounds (a particle of the filter's cloud beyond
    /// `± bound_sigmas σ`): a member stays where it is until an accepted candidate — which is
    /// always inside — replaces it.
    ///
    /// # Errors
    ///
    /// [`Error::PopulationMismatch`] when there are no members, the length is not a
    /// multiple of the dimension, or a coordinate is not finite.
    pub fn evaluate(problem: &dyn Problem, positions: Vec<f64>) -> Result<Self> {
        let dim = problem.dim();
        if positions.is_empty() || !positions.len().is_multiple_of(dim) {
            return Err(Error::PopulationMismatch {
                reason: format!(
                    "{} coordinates do not make whole members of dimension {dim}",
                    positions.len()
                ),
            });
        }
        if let Some(at) = positions.iter().position(|v| !v.is_finite()) {
            return Err(Error::PopulationMismatch {
                reason: format!("member {} has a non-finite coordinate", at / dim),
            });
        }
        let members: Vec<usize> = (0..positions.len() / dim).collect();
        let mut fitness = Vec::with_capacity(members.len());
        evaluate_into(problem, &members, &positions, &mut fitness);
        Ok(Self {
            dim,
            positions,
            moved: vec![false; members.len()],
            fitness,
        })
    }

    /// Number of members `N`.
    pub fn len(&self) -> usize {
        self.fitness.len()
    }

    /// Always false: a population has at least one member.
    pub fn is_empty(&self) -> bool {
        self.fitness.is_empty()
    }

    /// Dimension `D` of each member.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Position of member `i`.
    pub fn position(&self, i: usize) -> &[f64] {
        &self.positions[i * self.dim..(i + 1) * self.dim]
    }

    /// All positions, row-major `N × D` (the filter reads its particles' poses from here).
    pub fn positions(&self) -> &[f64] {
        &self.positions
    }

    /// Fitness of each member at its current position.
    pub fn fitness(&self) -> &[f64] {
        &self.fitness
    }

    /// Per member: whether its position has changed since the population was built or
    /// since [`Population::clear_moved`]. A moved particle needs its weight recomputed.
    pub fn moved(&self) -> &[bool] {
        &self.moved
    }

    /// Number of members that have moved.
    pub fn moved_count(&self) -> usize {
        self.moved.iter().filter(|&&m| m).count()
    }

    /// Forgets which members have moved.
    pub fn clear_moved(&mut self) {
        self.moved.fill(false);
    }
}

#[cfg(test)]
mod tests {
    use super::super::Bounds;
    use super::*;
    #[test]
    fn nan_fitness_ranks_last() {
        let problem = FnProblem::new(Bounds::cube(1, -1.0, 1.0).unwrap(), |i, _: &[f64]| {
            if i == 0 { f64::NAN } else { 1.0 }
        });
        let population = Population::evaluate(&problem, vec![0.0, 0.5]).unwrap();
        assert_eq!(population.fitness(), &[f64::INFINITY, 1.0]);
    }

    #[test]
    fn population_rejects_ragged_empty_and_non_finite_positions() {
        let problem = FnProblem::new(Bounds::cube(2, -1.0, 1.0).unwrap(), |_, x: &[f64]| {
            x.iter().map(|v| v * v).sum()
        });
        for positions in [vec![], vec![0.0, 0.0, 1.0], vec![0.0, f64::NAN]] {
            assert!(matches!(
                Population::evaluate(&problem, positions),
                Err(Error::PopulationMismatch { .. })
            ));
        }
    }
}
