//! Particle optimisers behind one interface (ALGORITHMS.md §3–§4): COA, ICOA, BA, IBA, GWO,
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
pub mod chaos;
mod coa;
mod gwo;
mod iba;
mod icoa;
pub mod levy;
mod pso;
mod qpso;
mod shared;
pub mod test_functions;

pub use ba::{Ba, BaConfig, FragranceConfig};
pub use coa::Coa;
pub use gwo::{Gwo, GwoConfig};
pub use iba::{Iba, IbaConfig};
pub use icoa::{Icoa, IcoaConfig};
pub use pso::{Pso, PsoConfig};
pub use qpso::{Qpso, QpsoConfig};
pub use shared::RunState;

use crate::rng::SimRng;
use crate::{Error, Result};
use chaos::CircleMap;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use shared::{Batch, PersonalBests, ensure, evaluate_into, index_other_than, linear, progress};
use std::fmt;
use std::str::FromStr;

/// Fewest members a run accepts: the butterflies need two distinct partners `j ≠ k`, and a
/// population of one has nothing to learn from.
pub const MIN_POPULATION: usize = 2;

// ---------------------------------------------------------------------------------------
// Bounds
// ---------------------------------------------------------------------------------------

/// The search box: a finite interval `[lower_d, upper_d]` with `lower_d < upper_d` per
/// dimension, checked when built so no optimiser has to.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Bounds {
    /// Bounds from per-dimension lower and upper limits.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidBounds`] when the lengths differ, there are no dimensions, a limit is
    /// not finite (NaN, ±∞), or `lower_d ≥ upper_d`.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self> {
        if lower.len() != upper.len() {
            return Err(Error::InvalidBounds {
                reason: format!(
                    "{} lower limits but {} upper limits",
                    lower.len(),
                    upper.len()
                ),
            });
        }
        if lower.is_empty() {
            return Err(Error::InvalidBounds {
                reason: "no dimensions".into(),
            });
        }
        for (d, (&lo, &hi)) in lower.iter().zip(&upper).enumerate() {
            if !lo.is_finite() || !hi.is_finite() {
                return Err(Error::InvalidBounds {
                    reason: format!("dimension {d}: [{lo}, {hi}] is not finite"),
                });
            }
            if lo >= hi {
                return Err(Error::InvalidBounds {
                    reason: format!("dimension {d}: lower {lo} is not below upper {hi}"),
                });
            }
        }
        Ok(Self { lower, upper })
    }

    /// `±half_width_d` per dimension: the §3 search box of pose offsets (`± bound_sigmas × σ`).
    ///
    /// # Errors
    ///
    /// As [`Bounds::new`]; a half-width must be finite and positive.
    pub fn symmetric(half_widths: &[f64]) -> Result<Self> {
        Self::new(
            half_widths.iter().map(|h| -h).collect(),
            half_widths.to_vec(),
        )
    }

    /// The same interval `[lower, upper]` in each of `dim` dimensions (test functions).
    ///
    /// # Errors
    ///
    /// As [`Bounds::new`].
    pub fn cube(dim: usize, lower: f64, upper: f64) -> Result<Self> {
        Self::new(vec![lower; dim], vec![upper; dim])
    }

    /// Number of dimensions `D`.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// Lower limits, one per dimension.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    /// Upper limits, one per dimension.
    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    /// `upper_d − lower_d`.
    pub fn width(&self, d: usize) -> f64 {
        self.upper[d] - self.lower[d]
    }

    /// Half of [`Bounds::width`]: the unit of the butterflies' positions (§4.3).
    pub fn half_width(&self, d: usize) -> f64 {
        0.5 * self.width(d)
    }

    /// Midpoint of dimension `d`.
    pub fn centre(&self, d: usize) -> f64 {
        0.5 * (self.lower[d] + self.upper[d])
    }

    /// True when `x` has `dim()` coordinates, each inside its interval.
    pub fn contains(&self, x: &[f64]) -> bool {
        x.len() == self.dim()
            && x.iter()
                .zip(self.lower.iter().zip(&self.upper))
                .all(|(v, (lo, hi))| lo <= v && v <= hi)
    }

    /// Clips every coordinate of `x` into its interval (ALGORITHMS.md §3: every candidate is
    /// clipped). ±∞ goes to the nearer limit; a NaN coordinate (from degenerate arithmetic
    /// such as `0 × ∞` in a Lévy step) goes to the centre, so a candidate is always a point
    /// of the box.
    pub fn clip(&self, x: &mut [f64]) {
        for (d, v) in x.iter_mut().enumerate() {
            *v = if v.is_nan() {
                self.centre(d)
            } else {
                v.clamp(self.lower[d], self.upper[d])
            };
        }
    }

    /// `members` points drawn uniformly in the box, row-major (`members × dim`), drawn in
    /// member order then dimension order.
    pub fn sample_uniform(&self, members: usize, rng: &mut SimRng) -> Vec<f64> {
        let mut positions = vec![0.0; members * self.dim()];
        for row in positions.chunks_exact_mut(self.dim()) {
            self.sample_into(row, rng);
        }
        positions
    }

    /// Overwrites `x` with a uniform point of the box: `lower + r (upper − lower)` (COA eq. 8).
    fn sample_into(&self, x: &mut [f64], rng: &mut SimRng) {
        for (d, v) in x.iter_mut().enumerate() {
            *v = self.lower[d] + rng.random::<f64>() * self.width(d);
        }
    }
}

// ---------------------------------------------------------------------------------------
// Problem
// ---------------------------------------------------------------------------------------

/// What an optimiser minimises: a fitness per (member, candidate) over a box.
///
/// `Sync` because a batch of candidates may be evaluated on several threads at once.
pub trait Problem: Sync {
    /// The search box; its dimension is the problem's.
    fn bounds(&self) -> &Bounds;

    /// Fitness of candidate `x` for population member `member` (lower is better). In the
    /// filter, member `i` is particle `i` and the fitness is ALGORITHMS.md §3's
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

// ---------------------------------------------------------------------------------------
// Population
// ---------------------------------------------------------------------------------------

/// `N` members of dimension `D`: positions (row-major `N × D`, one contiguous buffer),
/// the fitness of each, and which members have moved.
#[derive(Debug, Clone, PartialEq)]
pub struct Population {
    dim: usize,
    positions: Vec<f64>,
    fitness: Vec<f64>,
    moved: Vec<bool>,
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

// ---------------------------------------------------------------------------------------
// Optimiser
// ---------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------
// Configuration
// ---------------------------------------------------------------------------------------

/// The optimiser choices, by the names used in config files and on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OptimiserKind {
    /// No optimiser: plain FastSLAM 1.0 (§1 step 2 is skipped).
    #[default]
    None,
    /// Coati optimisation (§4.1).
    Coa,
    /// Improved coati optimisation (§4.2).
    Icoa,
    /// Butterfly optimisation (§4.3).
    Ba,
    /// Improved butterfly optimisation (§4.4).
    Iba,
    /// Grey wolf optimisation (§4.5).
    Gwo,
    /// Quantum-behaved particle swarm (§4.5).
    Qpso,
    /// Canonical particle swarm (§4.5).
    Pso,
}

impl OptimiserKind {
    /// Every choice, in the order of ALGORITHMS.md.
    pub const ALL: [Self; 8] = [
        Self::None,
        Self::Coa,
        Self::Icoa,
        Self::Ba,
        Self::Iba,
        Self::Gwo,
        Self::Qpso,
        Self::Pso,
    ];

    /// The lower-case name (`"icoa"`), as in config files.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Coa => "coa",
            Self::Icoa => "icoa",
            Self::Ba => "ba",
            Self::Iba => "iba",
            Self::Gwo => "gwo",
            Self::Qpso => "qpso",
            Self::Pso => "pso",
        }
    }
}

impl fmt::Display for OptimiserKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for OptimiserKind {
    type Err = Error;

    /// Parses a lower-case name, exactly as [`fmt::Display`] writes it.
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| Error::UnknownOptimiser {
                name: s.to_owned(),
                expected: Self::ALL.map(Self::name).join(", "),
            })
    }
}

/// The optimiser section of the service's config: which optimiser, how many generations per
/// filter step, and each optimiser's constants in its own table (all present, so switching
/// `kind` from the command line needs nothing else; COA has no constants, so no table).
///
/// ```toml
/// kind = "icoa"
/// iterations = 10
/// [icoa]
/// omega_max = 0.9
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OptimiserConfig {
    /// Which optimiser runs after the prediction step; `none` = plain FastSLAM.
    pub kind: OptimiserKind,
    /// Generations per filter step, `K` of §4 (count). 10 as in the UNGM measurements of §5.
    pub iterations: usize,
    /// ICOA constants (§4.2).
    pub icoa: IcoaConfig,
    /// BA constants (§4.3).
    pub ba: BaConfig,
    /// IBA constants (§4.4).
    pub iba: IbaConfig,
    /// GWO constants (§4.5).
    pub gwo: GwoConfig,
    /// QPSO constants (§4.5).
    pub qpso: QpsoConfig,
    /// PSO constants (§4.5).
    pub pso: PsoConfig,
}

impl Default for OptimiserConfig {
    fn default() -> Self {
        Self {
            kind: OptimiserKind::None,
            iterations: 10,
            icoa: IcoaConfig::default(),
            ba: BaConfig::default(),
            iba: IbaConfig::default(),
            gwo: GwoConfig::default(),
            qpso: QpsoConfig::default(),
            pso: PsoConfig::default(),
        }
    }
}

impl OptimiserConfig {
    /// Checks every section (also those of optimisers not selected, so a bad value is found
    /// when the file is loaded, not when someone switches `kind`).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] naming the first bad constant.
    pub fn validate(&self) -> Result<()> {
        self.icoa.validate()?;
        self.ba.validate()?;
        self.iba.validate()?;
        self.gwo.validate()?;
        self.qpso.validate()?;
        self.pso.validate()
    }

    /// Whether the filter must resample with IBA's partial EWA scheme (ALGORITHMS.md §4.4):
    /// IBA is selected and [`IbaConfig::partial_resampling`] is on.
    pub fn partial_resampling(&self) -> bool {
        self.kind == OptimiserKind::Iba && self.iba.partial_resampling
    }

    /// The selected optimiser, or `None` for [`OptimiserKind::None`]. ICOA seeds its
    /// persistent chaotic sequence from `rng` (one draw); the others draw nothing here.
    ///
    /// # Errors
    ///
    /// As [`OptimiserConfig::validate`].
    pub fn build(&self, rng: &mut SimRng) -> Result<Option<Box<dyn Optimiser>>> {
        self.validate()?;
        Ok(match self.kind {
            OptimiserKind::None => None,
            OptimiserKind::Coa => Some(Box::new(Coa::new())),
            OptimiserKind::Icoa => Some(Box::new(Icoa::new(
                self.icoa.clone(),
                CircleMap::from_rng(rng),
            )?)),
            OptimiserKind::Ba => Some(Box::new(Ba::new(self.ba.clone())?)),
            OptimiserKind::Iba => Some(Box::new(Iba::new(self.iba.clone())?)),
            OptimiserKind::Gwo => Some(Box::new(Gwo::new(self.gwo.clone())?)),
            OptimiserKind::Qpso => Some(Box::new(Qpso::new(self.qpso.clone())?)),
            OptimiserKind::Pso => Some(Box::new(Pso::new(self.pso.clone())?)),
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
    fn bounds_reject_nan_infinite_inverted_and_mismatched() {
        let bad = [
            (vec![f64::NAN], vec![1.0]),
            (vec![0.0], vec![f64::NAN]),
            (vec![f64::NEG_INFINITY], vec![1.0]),
            (vec![0.0], vec![f64::INFINITY]),
            (vec![1.0], vec![1.0]),
            (vec![2.0], vec![1.0]),
            (vec![0.0, 0.0], vec![1.0]),
            (vec![], vec![]),
        ];
        for (lower, upper) in bad {
            let result = Bounds::new(lower.clone(), upper.clone());
            assert!(
                matches!(result, Err(Error::InvalidBounds { .. })),
                "accepted [{lower:?}, {upper:?}]"
            );
        }
        assert!(Bounds::symmetric(&[0.0]).is_err());
        assert!(Bounds::symmetric(&[1.0, 2.0]).is_ok());
    }

    #[test]
    fn clip_moves_outside_points_to_the_nearest_limit_and_nan_to_the_centre() {
        let bounds = Bounds::new(vec![-1.0, 0.0, 2.0, -5.0], vec![1.0, 10.0, 4.0, 5.0]).unwrap();
        let mut x = [-3.0, 5.0, f64::INFINITY, f64::NAN];
        bounds.clip(&mut x);
        assert_eq!(x, [-1.0, 5.0, 4.0, 0.0]);
        assert!(bounds.contains(&x));
        assert!(!bounds.contains(&[0.0, 0.0, 1.9, 0.0]));
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
    fn nan_fitness_ranks_last() {
        let problem = FnProblem::new(Bounds::cube(1, -1.0, 1.0).unwrap(), |i, _: &[f64]| {
            if i == 0 { f64::NAN } else { 1.0 }
        });
        let population = Population::evaluate(&problem, vec![0.0, 0.5]).unwrap();
        assert_eq!(population.fitness(), &[f64::INFINITY, 1.0]);
    }

    #[test]
    fn population_rejects_ragged_empty_and_non_finite_positions() {
        let problem = sphere(Bounds::cube(2, -1.0, 1.0).unwrap());
        for positions in [vec![], vec![0.0, 0.0, 1.0], vec![0.0, f64::NAN]] {
            assert!(matches!(
                Population::evaluate(&problem, positions),
                Err(Error::PopulationMismatch { .. })
            ));
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

    #[test]
    fn names_round_trip_through_from_str_display_and_serde() {
        for kind in OptimiserKind::ALL {
            assert_eq!(kind.to_string().parse::<OptimiserKind>().unwrap(), kind);
            let json = serde_json::to_string(&kind).unwrap();
            assert_eq!(json, format!("\"{kind}\""));
            assert_eq!(serde_json::from_str::<OptimiserKind>(&json).unwrap(), kind);
        }
        assert!(matches!(
            "COA".parse::<OptimiserKind>(),
            Err(Error::UnknownOptimiser { .. })
        ));
        assert!("sa".parse::<OptimiserKind>().is_err());
    }

    #[test]
    fn config_round_trips_through_toml_fills_defaults_and_rejects_unknown_fields() {
        let config = OptimiserConfig {
            kind: OptimiserKind::Icoa,
            iterations: 7,
            ..OptimiserConfig::default()
        };
        let text = toml::to_string(&config).unwrap();
        assert_eq!(toml::from_str::<OptimiserConfig>(&text).unwrap(), config);

        let partial: OptimiserConfig =
            toml::from_str("kind = \"gwo\"\n[pso]\ncognitive = 1.5\n").unwrap();
        assert_eq!(partial.kind, OptimiserKind::Gwo);
        assert_eq!(partial.pso.cognitive, 1.5);
        assert_eq!(
            partial.pso,
            PsoConfig {
                cognitive: 1.5,
                ..PsoConfig::default()
            }
        );
        assert_eq!(partial.iterations, OptimiserConfig::default().iterations);

        for bad in [
            "kind = \"sa\"",
            "omega = 1.0",
            "[icoa]\nomega_maximum = 1.0",
            "[coa]\n",
        ] {
            assert!(
                toml::from_str::<OptimiserConfig>(bad).is_err(),
                "accepted {bad:?}"
            );
        }
    }

    #[test]
    fn defaults_validate_and_out_of_range_constants_are_rejected() {
        assert!(OptimiserConfig::default().validate().is_ok());
        let mut rng = seeded(0);
        let mut config = OptimiserConfig {
            kind: OptimiserKind::Ba,
            ..OptimiserConfig::default()
        };
        config.ba.switch_probability = 1.5;
        assert!(matches!(
            config.build(&mut rng),
            Err(Error::InvalidParameter { .. })
        ));
        // A bad section is reported even when another optimiser is selected.
        let mut config = OptimiserConfig::default();
        config.icoa.omega_min = 2.0;
        assert!(config.validate().is_err());
    }

    #[test]
    fn none_builds_no_optimiser_and_the_others_report_their_kind() {
        let mut rng = seeded(0);
        for kind in OptimiserKind::ALL {
            let config = OptimiserConfig {
                kind,
                ..OptimiserConfig::default()
            };
            match config.build(&mut rng).unwrap() {
                None => assert_eq!(kind, OptimiserKind::None),
                Some(optimiser) => assert_eq!(optimiser.kind(), kind),
            }
        }
    }
}
