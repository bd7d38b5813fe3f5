//! The univariate non-stationary growth model (UNGM) benchmark of docs/ALGORITHMS.md §5 (ICOA
//! paper §3.1, eqs. 21–23, Table 1), run by the generic particle filter ([`crate::pf`]) with
//! every optimiser.
//!
//! `x_t = 0.5 x_{t−1} + 25 x_{t−1} / (1 + x_{t−1}²) + 8 cos(1.2 (t−1)) + w_t`,
//! `y_t = x_t² / 20 + v_t`, `w ~ N(0, Q)`, `v ~ N(0, R)`, `x_0 = 0`, `T = 100`; the filters
//! start from `N(0, 1)`. Per run: RMSE of the posterior mean over `t = 1..T` (eq. 23), the
//! fraction of steps whose 90 % interval holds the true state, and the filter's wall time.
//!
//! Every run `r` simulates its own data from the stream `[r, DATA]` of the benchmark's seed,
//! the same data for every method and particle count (common random numbers), and filters
//! it with the stream `[r, FILTER]`. Runs execute in parallel on rayon; each is a pure
//! function of its streams, so the numbers do not depend on the thread count (the wall
//! times do).

use crate::check::positive;
use crate::moves::{MoveConfig, MoveStats, Mover};
use crate::optimise::OptimiserConfig;
use crate::pf::{self, FilterConfig, StateSpaceModel};
use crate::resample::{ResamplingConfig, ResamplingScheme};
use crate::rng::{SimRng, stream};
use crate::stats::Summary;
use crate::{Error, Result};
use rand::RngExt;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use std::time::Instant;

/// Standard deviation of the filters' initial particles, `N(0, 1)` (§5, our measurement).
pub const INITIAL_SIGMA: f64 = 1.0;
/// Time steps of a run, `T` (ICOA paper §3.1).
pub const STEPS: usize = 100;
/// `(Q, R)` of the paper's low-noise setting.
pub const LOW_NOISE: (f64, f64) = (1.0, 0.1);
/// `(Q, R)` of the paper's high-noise setting.
pub const HIGH_NOISE: (f64, f64) = (10.0, 1.0);

/// Stream label of a run's simulated data.
const DATA: u64 = 0;
/// Stream label of a run's filter draws.
const FILTER: u64 = 1;
/// Stream label of a run's optimiser construction (ICOA's chaotic sequence).
const OPTIMISER: u64 = 2;

/// The UNGM with process noise variance `Q` and observation noise variance `R`.
#[derive(Debug, Clone, PartialEq)]
pub struct Ungm {
    q: f64,
    r: f64,
    sigma: [f64; 1],
}

impl Ungm {
    /// The model with variances `q` (process) and `r` (observation).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless both are finite and > 0.
    pub fn new(q: f64, r: f64) -> Result<Self> {
        positive("q", q)?;
        positive("r", r)?;
        Ok(Self {
            q,
            r,
            sigma: [q.sqrt()],
        })
    }

    /// Process noise variance `Q`.
    pub fn q(&self) -> f64 {
        self.q
    }

    /// Observation noise variance `R`.
    pub fn r(&self) -> f64 {
        self.r
    }

    /// The noise-free transition `f(t, x)` of eq. 21.
    pub fn drift(t: usize, x: f64) -> f64 {
        0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * (1.2 * (t as f64 - 1.0)).cos()
    }

    /// Simulates `x_1..x_T` from `x_0 = 0` and their observations `y_1..y_T`.
    pub fn simulate(&self, steps: usize, rng: &mut SimRng) -> (Vec<f64>, Vec<f64>) {
        let mut x = 0.0;
        (1..=steps)
            .map(|t| {
                x = Self::drift(t, x) + self.sigma[0] * rng.sample::<f64, _>(StandardNormal);
                let y = x * x / 20.0 + self.r.sqrt() * rng.sample::<f64, _>(StandardNormal);
                (x, y)
            })
            .unzip()
    }
}

impl StateSpaceModel for Ungm {
    type Observation = f64;

    fn dim(&self) -> usize {
        1
    }

    fn sample_initial(&self, rng: &mut SimRng, x: &mut [f64]) {
        x[0] = INITIAL_SIGMA * rng.sample::<f64, _>(StandardNormal);
    }

    fn transition_mean(&self, t: usize, previous: &[f64], mean: &mut [f64]) {
        mean[0] = Self::drift(t, previous[0]);
    }

    fn transition_sigma(&self) -> &[f64] {
        &self.sigma
    }

    fn log_likelihood(&self, _: usize, x: &[f64], y: &f64) -> f64 {
        -0.5 * (y - x[0] * x[0] / 20.0).powi(2) / self.r
    }

    /// `H = ∂(x²/20)/∂x = x/10`, so `H² / R`.
    fn observation_information(&self, _: usize, x: f64, _: &f64) -> f64 {
        (x / 10.0).powi(2) / self.r
    }
}

/// One filter of the comparison: an optimiser (`none` = the bootstrap filter) with its
/// move settings.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Method {
    /// The optimiser and its constants.
    pub optimiser: OptimiserConfig,
    /// Search box, prior weight and correction of the moves.
    pub moves: MoveConfig,
}

/// How the benchmark runs.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchmarkConfig {
    /// Monte Carlo runs per (method, particle count); the paper's 50.
    pub runs: usize,
    /// Time steps per run, `T`; the paper's 100.
    pub steps: usize,
    /// Seed of the data and the filters.
    pub seed: u64,
    /// When and how the filters resample (IBA switches to partial resampling, §4.4).
    /// Default: systematic at every step, the bootstrap filter of §5's measurements.
    pub resampling: ResamplingConfig,
    /// Mass of the interval whose coverage is reported; §5's 0.9.
    pub interval: f64,
}

impl Default for BenchmarkConfig {
    fn default() -> Self {
        Self {
            runs: 50,
            steps: STEPS,
            seed: 1,
            resampling: FilterConfig::default().resampling,
            interval: 0.9,
        }
    }
}

/// What one method with one particle count did over the runs.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodResult {
    /// Per-run RMSE of the posterior mean (eq. 23).
    pub rmse: Summary,
    /// Per-run fraction of steps whose interval holds the true state (≈ the interval's
    /// mass for a calibrated filter).
    pub coverage: Summary,
    /// Per-run wall time of the filter (s), data simulation excluded.
    pub seconds: Summary,
    /// The optimiser's moves, summed over the runs.
    pub moves: MoveStats,
}

/// One run's numbers.
struct RunResult {
    rmse: f64,
    coverage: f64,
    seconds: f64,
    moves: MoveStats,
}

/// Runs `method` with `particles` particles on `config.runs` simulated runs of `model`.
///
/// # Errors
/// [`Error::InvalidParameter`] for a bad setting, or a run's filter error (degenerate
/// weights).
pub fn evaluate(
    model: &Ungm,
    method: &Method,
    particles: usize,
    config: &BenchmarkConfig,
) -> Result<MethodResult> {
    let mut resampling = config.resampling.clone();
    if method.optimiser.partial_resampling(method.moves.correction) {
        resampling.scheme = ResamplingScheme::PartialEwa;
    }
    let filter = FilterConfig {
        particles,
        resampling,
        interval: config.interval,
    };
    filter.validate()?;
    let runs: Vec<RunResult> = (0..config.runs as u64)
        .into_par_iter()
        .map(|run| {
            let (states, observations) =
                model.simulate(config.steps, &mut stream(config.seed, &[run, DATA]));
            let mut rng = stream(config.seed, &[run, OPTIMISER]);
            let mut mover = Mover::new(&method.optimiser, method.moves.clone(), &mut rng)?;
            let started = Instant::now();
            let mut rng = stream(config.seed, &[run, FILTER]);
            let posteriors = pf::run(model, &observations, &filter, mover.as_mut(), &mut rng)?;
            let seconds = started.elapsed().as_secs_f64();
            let steps = states.len().max(1) as f64;
            let squared: f64 = posteriors
                .iter()
                .zip(&states)
                .map(|(p, x)| (p.mean[0] - x).powi(2))
                .sum();
            let covered = posteriors
                .iter()
                .zip(&states)
                .filter(|(p, x)| (p.lower[0]..=p.upper[0]).contains(*x))
                .count();
            Ok(RunResult {
                rmse: (squared / steps).sqrt(),
                coverage: covered as f64 / steps,
                seconds,
                moves: mover.map(|m| m.stats()).unwrap_or_default(),
            })
        })
        .collect::<Result<_>>()?;
    if runs.is_empty() {
        return Err(Error::InvalidParameter {
            name: "runs",
            reason: "must be >= 1".into(),
        });
    }
    let column = |f: fn(&RunResult) -> f64| Summary::of(&runs.iter().map(f).collect::<Vec<_>>());
    let moves = runs
        .iter()
        .fold(MoveStats::default(), |acc, r| acc + r.moves);
    Ok(MethodResult {
        rmse: column(|r| r.rmse),
        coverage: column(|r| r.coverage),
        seconds: column(|r| r.seconds),
        moves,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moves::MoveCorrection;
    use crate::optimise::OptimiserKind;
    use crate::rng::seeded;

    #[test]
    fn drift_follows_equation_21() {
        assert_eq!(Ungm::drift(1, 0.0), 8.0);
        let x = 2.0;
        let expected = 1.0 + 50.0 / 5.0 + 8.0 * (1.2f64 * 2.0).cos();
        assert!((Ungm::drift(3, x) - expected).abs() < 1e-12);
    }

    #[test]
    fn simulated_data_has_the_configured_noise() {
        let model = Ungm::new(10.0, 1.0).unwrap();
        let (xs, ys) = model.simulate(20_000, &mut seeded(4));
        let residuals: Vec<f64> = xs.iter().zip(&ys).map(|(x, y)| y - x * x / 20.0).collect();
        let var = residuals.iter().map(|v| v * v).sum::<f64>() / residuals.len() as f64;
        assert!((var - 1.0).abs() < 0.05, "{var}");
        let process: Vec<f64> = (1..xs.len())
            .map(|k| xs[k] - Ungm::drift(k + 1, xs[k - 1]))
            .collect();
        let q = process.iter().map(|v| v * v).sum::<f64>() / process.len() as f64;
        assert!((q - 10.0).abs() < 0.5, "{q}");
        assert!(Ungm::new(0.0, 1.0).is_err());
    }

    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let model = Ungm::new(LOW_NOISE.0, LOW_NOISE.1).unwrap();
        let config = BenchmarkConfig {
            runs: 4,
            steps: 30,
            ..BenchmarkConfig::default()
        };
        let method = Method {
            optimiser: OptimiserConfig {
                kind: OptimiserKind::Icoa,
                ..OptimiserConfig::default()
            },
            moves: MoveConfig {
                correction: MoveCorrection::Proposal,
                ..MoveConfig::default()
            },
        };
        let in_pool = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| evaluate(&model, &method, 40, &config).unwrap())
        };
        let (one, two) = (in_pool(1), in_pool(2));
        assert_eq!(one.rmse, two.rmse);
        assert_eq!(one.coverage, two.coverage);
        assert_eq!(one.moves, two.moves);
        assert!(one.moves.proposed > 0);
    }
}
