//! `fastslam-stack monte-carlo`: the offline comparison — every estimator × particle count
//! × seed in process (no IPC), on a simulated scenario or a recorded data set, scored by
//! the client's metrics, summarised per row. The pipeline is `fastslam_stack::offline`;
//! this parses flags and prints.

use anyhow::Context;
use fastslam_client::relations::RelationsFrame;
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_estimation::stats::Summary;
use fastslam_replay::dataset::Association;
use fastslam_replay::registry::DataSetKind;
use fastslam_sensors_sim::Scenario;
use fastslam_sensors_sim::scenario::DEFAULT_SCENARIO;
use fastslam_stack::offline::{self, Comparison, Row, Source};
use std::path::PathBuf;

/// Flags of `monte-carlo`.
#[derive(Debug, Clone, clap::Args)]
pub struct MonteCarloArgs {
    /// Scenario: a built-in name (see `scenarios`) or a scenario TOML file.
    #[arg(long, default_value = DEFAULT_SCENARIO, conflicts_with = "replay")]
    pub scenario: String,
    /// Replay a recorded data set instead of simulating a scenario; the seeds then only
    /// seed the filter.
    #[arg(long, value_parser = offline::in_process_data_sets())]
    pub replay: Option<&'static DataSetKind>,
    /// Data set folder of `--replay` (default: data/mrclam7 or data/victoria_park).
    #[arg(long, requires = "replay")]
    pub data: Option<PathBuf>,
    /// MRCLAM robot number.
    #[arg(long, default_value_t = 1)]
    pub robot: u32,
    /// MRCLAM association: known (barcodes as ids) or unknown.
    #[arg(long, value_enum, default_value_t = Association::Known)]
    pub association: Association,
    /// Replay profile: a built-in name or a TOML file (default: the data set's own).
    #[arg(long, requires = "replay")]
    pub profile: Option<String>,
    /// Service config file (default: the scenario's or the profile's [service] table).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// A relations file for the data set of `--replay` (`t1 t2 x y z roll pitch yaw` per
    /// line, times on the data set's clock): each run's estimate is also scored by its
    /// relative motions against it (the relation columns).
    #[arg(long, value_name = "FILE", requires = "replay")]
    pub relations: Option<PathBuf>,
    /// Whose motions the relations are: the data set's laser (relations measured by
    /// aligning scans, as the Freiburg benchmark's; each trajectory is moved onto the
    /// laser's mount before scoring) or its base.
    #[arg(long, value_enum, default_value_t, requires = "relations")]
    pub relations_frame: RelationsFrame,
    /// Estimators, particle counts and seeds.
    #[command(flatten)]
    pub comparison: Comparison,
    /// Also write the rows to this CSV file, one per method, with the columns
    /// scenario,optimizer,correction,proposal,particles,seeds,ate_mean_m,ate_std_m,
    /// nees_within_95,singular_fraction,cpu_s_per_run,smoothed_ate_mean_m,smoothed_ate_std_m,
    /// ate_max_m,landmarks_mean,true_landmarks,map,grid_precision,grid_recall,
    /// relations_trans_mean_m,relations_trans_std_m,relations_rot_mean_deg (docs/CSV.md;
    /// correction: none, proposal or resample-move, empty without an optimiser; proposal:
    /// motion or fastslam2; map: landmarks or grid; the relation columns NaN without
    /// `--relations`).
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// The header of `monte-carlo --csv`; tools outside the project read these names.
pub const CSV_HEADER: &str = "scenario,optimizer,correction,proposal,particles,seeds,\
ate_mean_m,ate_std_m,nees_within_95,singular_fraction,cpu_s_per_run,\
smoothed_ate_mean_m,smoothed_ate_std_m,ate_max_m,landmarks_mean,true_landmarks,\
map,grid_precision,grid_recall,relations_trans_mean_m,relations_trans_std_m,relations_rot_mean_deg";

/// One line of `monte-carlo --csv`.
fn csv_row(scenario: &str, row: &Row) -> String {
    let correction = if row.optimizer == OptimiserKind::None {
        ""
    } else {
        row.correction.name()
    };
    format!(
        "{scenario},{},{correction},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
        row.optimizer,
        row.proposal,
        row.particles,
        row.ate.n,
        row.ate.mean,
        row.ate.std,
        row.nees_within.mean,
        row.singular.mean,
        row.cpu.mean,
        row.smoothed.mean,
        row.smoothed.std,
        row.ate.max,
        row.landmarks.mean,
        row.true_landmarks,
        row.map.name(),
        row.grid_precision.mean,
        row.grid_recall.mean,
        row.relations_trans.mean,
        row.relations_trans_std.mean,
        row.relations_rot.mean
    )
}

/// Runs the comparison and prints its table, one row as soon as it is done.
///
/// # Errors
/// A bad setting, or a filter that cannot be built.
pub fn run(args: &MonteCarloArgs) -> anyhow::Result<()> {
    let source = source(args)?;
    let seeds = &args.comparison.seeds.0;
    println!(
        "Monte Carlo on {} ({} seeds, {}..{}), in process; per run: mean ± std [95 % CI of the mean]",
        source.name(),
        seeds.len(),
        seeds[0],
        seeds[seeds.len() - 1]
    );
    println!(
        "  {:<28} {:>5}  {:>30}  {:>30}  {:>30}  {:>10}  {:>8}  {:>12}  {:>8}  DR / achievable ATE (m)  × achievable · worst ATE · landmarks mapped / true · moves kept",
        "method",
        "N",
        "ATE RMSE (m)",
        "landmark RMSE (m)",
        "NEES mean (3 = consistent)",
        "NEES ≤ χ²₉₅",
        "singular",
        "filter s/run",
        "CPU s/run",
    );
    let mut csv = vec![CSV_HEADER.to_owned()];
    offline::compare(&source, args.config.as_deref(), &args.comparison, |row| {
        print_row(row);
        csv.push(csv_row(source.name(), row));
    })
    .context("monte carlo")?;
    super::write_csv(args.csv.as_deref(), csv)
}

/// The scenario, or the data set `--replay` names, loaded (with the relations of
/// `--relations`).
fn source(args: &MonteCarloArgs) -> anyhow::Result<Source> {
    let source = match args.replay {
        None => Source::Simulation(Box::new(Scenario::load(&args.scenario)?)),
        Some(set) => Source::replay(
            set,
            args.data.as_deref(),
            args.robot,
            args.association,
            args.profile.as_deref(),
        )?,
    };
    match &args.relations {
        Some(path) => source.with_relations(path, args.relations_frame),
        None => Ok(source),
    }
}

/// `mean ± std [lo, hi]`, switching to scientific notation for huge values (NEES).
fn cell(s: &Summary) -> String {
    let huge = s.mean.abs() >= 1e4 || s.std >= 1e4;
    let text = if huge {
        format!(
            "{:.2e} ± {:.1e} [{:.1e}, {:.1e}]",
            s.mean, s.std, s.ci95.0, s.ci95.1
        )
    } else {
        format!(
            "{:.3} ± {:.3} [{:.3}, {:.3}]",
            s.mean, s.std, s.ci95.0, s.ci95.1
        )
    };
    if s.non_finite > 0 {
        format!("{text} ({} n/a)", s.non_finite)
    } else {
        text
    }
}

/// One table row.
fn print_row(row: &Row) {
    let smoothed = if row.smoothed.n > 0 {
        format!(
            " · smoothed ATE {} (final < 1 m: {}/{})",
            cell(&row.smoothed),
            row.smoothed_final_under_1m,
            row.smoothed.n + row.smoothed.non_finite
        )
    } else {
        String::new()
    };
    let grid = if row.grid_precision.n > 0 {
        format!(
            " · grid precision {:.3} ± {:.3}, recall {:.3} ± {:.3}",
            row.grid_precision.mean,
            row.grid_precision.std,
            row.grid_recall.mean,
            row.grid_recall.std
        )
    } else {
        String::new()
    };
    let relations = if row.relations_trans.n > 0 {
        format!(
            " · relations {:.3} ± {:.3} m, {:.2}°",
            row.relations_trans.mean, row.relations_trans_std.mean, row.relations_rot.mean
        )
    } else {
        String::new()
    };
    let moves = row.moves.map_or(String::new(), |m| {
        format!(
            " · {}/{} ({:.1} %)",
            m.accepted,
            m.proposed,
            100.0 * m.accepted as f64 / m.proposed.max(1) as f64
        )
    });
    println!(
        "  {:<28} {:>5}  {:>30}  {:>30}  {:>30}  {:>10.3}  {:>8.3}  {:>7.2} ± {:<4.2}  {:>8.2}  {:.3} / {:.3}  {:.1} ± {:.1} · {:.3} · {:.1} ± {:.1} / {}{moves}{smoothed}{grid}{relations}",
        row.method,
        row.particles,
        cell(&row.ate),
        cell(&row.landmark),
        cell(&row.nees),
        row.nees_within.mean,
        row.singular.mean,
        row.seconds.mean,
        row.seconds.std,
        row.cpu.mean,
        row.dead_reckoning.mean,
        row.reference.mean,
        row.over_reference.mean,
        row.over_reference.std,
        row.ate.max,
        row.landmarks.mean,
        row.landmarks.std,
        row.true_landmarks
    );
}
