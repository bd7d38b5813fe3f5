//! `fastslam-stack ungm`: the UNGM benchmark of docs/ALGORITHMS.md §5 in the shape of the ICOA
//! paper's Table 1, for every optimiser, with the 20 000-particle bootstrap filter as the
//! reference. The computation lives in `fastslam_estimation::ungm`; this parses flags and
//! prints.

use anyhow::Context;
use fastslam_estimation::moves::MoveConfig;
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::stats::Summary;
use fastslam_estimation::ungm::{
    self, BenchmarkConfig, HIGH_NOISE, LOW_NOISE, Method, MethodResult, Ungm,
};
use fastslam_stack::methods::{Methods, label};

/// Particle counts of the ICOA paper's Table 1.
const PAPER_PARTICLES: [usize; 4] = [50, 100, 150, 200];

/// Flags of `ungm`.
#[derive(Debug, Clone, clap::Args)]
pub struct UngmArgs {
    /// Optimisers (none = the bootstrap particle filter), corrections and particle counts
    /// (default N: the paper's 50, 100, 150, 200).
    #[command(flatten)]
    pub methods: Methods,
    /// Noise settings, comma-separated: low (Q = 1, R = 0.1) and/or high (Q = 10, R = 1).
    #[arg(long, value_delimiter = ',', default_value = "low,high")]
    pub noise: Vec<String>,
    /// Monte Carlo runs per row (the paper's 50).
    #[arg(long, default_value_t = 50)]
    pub runs: usize,
    /// Optimiser generations per filter step, K.
    #[arg(long, default_value_t = OptimiserConfig::default().iterations)]
    pub iterations: usize,
    /// λ, the motion-prior weight of the fitness (0 = the papers' likelihood-only fitness).
    #[arg(long, default_value_t = MoveConfig::default().prior_weight)]
    pub prior_weight: f64,
    /// Half-width of the search box in standard deviations of the predicted cloud.
    #[arg(long, default_value_t = MoveConfig::default().bound_sigmas)]
    pub bound_sigmas: f64,
    /// Particles of the reference bootstrap filter (0 = no reference row).
    #[arg(long, default_value_t = 20_000)]
    pub reference_particles: usize,
    /// Seed of the simulated data and the filters.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Also write the rows to this CSV file, one per method × N × noise setting, with the
    /// columns method,correction,particles,noise,runs,rmse_mean,rmse_std,coverage90,ms_per_run
    /// (method: the optimiser, none for the bootstrap filter; correction: none, proposal,
    /// resample-move, empty for the bootstrap filter; noise: low or high).
    #[arg(long)]
    pub csv: Option<std::path::PathBuf>,
}

/// The header of `ungm --csv`; tools outside the project read these names.
pub const CSV_HEADER: &str =
    "method,correction,particles,noise,runs,rmse_mean,rmse_std,coverage90,ms_per_run";

/// One line of `ungm --csv`.
fn csv_row(
    kind: OptimiserKind,
    moves: &MoveConfig,
    particles: usize,
    noise: &str,
    result: &MethodResult,
) -> String {
    let correction = if kind == OptimiserKind::None {
        ""
    } else {
        moves.correction.name()
    };
    format!(
        "{kind},{correction},{particles},{noise},{},{},{},{},{}",
        result.rmse.n,
        result.rmse.mean,
        result.rmse.std,
        result.coverage.mean,
        1e3 * result.seconds.mean
    )
}

/// Runs the benchmark and prints one table per noise setting.
///
/// # Errors
/// An unknown name, a bad setting, or a filter error.
pub fn run(args: &UngmArgs) -> anyhow::Result<()> {
    let config = BenchmarkConfig {
        runs: args.runs,
        seed: args.seed,
        ..BenchmarkConfig::default()
    };
    let methods = methods(args)?;
    let mut csv = vec![CSV_HEADER.to_owned()];
    for noise in &args.noise {
        let (q, r) = match noise.as_str() {
            "low" => LOW_NOISE,
            "high" => HIGH_NOISE,
            other => anyhow::bail!("unknown noise setting `{other}` (expected one of: low, high)"),
        };
        let model = Ungm::new(q, r)?;
        println!(
            "\nUNGM (docs/ALGORITHMS.md §5), Q = {q}, R = {r}: {} runs of T = {}, K = {} generations, \
             λ = {}, box ±{}σ, seed {}",
            config.runs,
            config.steps,
            args.iterations,
            args.prior_weight,
            args.bound_sigmas,
            config.seed
        );
        println!(
            "  {:<18} {:>6}  {:>15}  {:>16}  {:>8}  {:>10}  moves kept",
            "method", "N", "RMSE mean ± std", "95 % CI of mean", "90 % cov", "time/run",
        );
        if args.reference_particles > 0 {
            let reference = ungm::evaluate(
                &model,
                &Method::default(),
                args.reference_particles,
                &config,
            )?;
            print_row("none", args.reference_particles, &reference);
            let bootstrap = Method::default();
            csv.push(csv_row(
                OptimiserKind::None,
                &bootstrap.moves,
                args.reference_particles,
                noise,
                &reference,
            ));
            println!();
        }
        for n in args.methods.particles_or(&PAPER_PARTICLES) {
            for (label, method) in &methods {
                let result = ungm::evaluate(&model, method, n, &config)
                    .with_context(|| format!("{label} with N = {n}"))?;
                print_row(label, n, &result);
                let kind = method.optimiser.kind;
                csv.push(csv_row(kind, &method.moves, n, noise, &result));
            }
            println!();
        }
    }
    super::write_csv(args.csv.as_deref(), csv)
}

/// The methods of the table with their labels (`coa`, `coa+proposal`), in the order given.
fn methods(args: &UngmArgs) -> anyhow::Result<Vec<(String, Method)>> {
    args.methods
        .methods()
        .into_iter()
        .map(|(kind, correction)| {
            let method = Method {
                optimiser: OptimiserConfig {
                    kind,
                    iterations: args.iterations,
                    ..OptimiserConfig::default()
                },
                moves: MoveConfig {
                    bound_sigmas: args.bound_sigmas,
                    prior_weight: args.prior_weight,
                    correction,
                    ..MoveConfig::default()
                },
            };
            method.optimiser.validate()?;
            method.moves.validate()?;
            Ok((label(kind, correction), method))
        })
        .collect()
}

/// One table row.
fn print_row(label: &str, particles: usize, result: &MethodResult) {
    let Summary {
        mean, std, ci95, ..
    } = result.rmse;
    let moves = result.moves;
    let kept = if moves.proposed > 0 {
        format!(
            "{}/{} ({:.1} %)",
            moves.accepted,
            moves.proposed,
            100.0 * moves.accepted as f64 / moves.proposed as f64
        )
    } else {
        String::new()
    };
    println!(
        "  {label:<18} {particles:>6}  {mean:>7.3} ± {std:<5.3}  [{:>6.3}, {:>6.3}]  {:>8.3}  {:>7.1} ms  {kept}",
        ci95.0,
        ci95.1,
        result.coverage.mean,
        1e3 * result.seconds.mean
    );
}
