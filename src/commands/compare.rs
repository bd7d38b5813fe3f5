//! `fastslam-stack compare`: the whole multi-process stack for every optimiser × proposal
//! × particle count × seed, then a comparison table (Markdown and CSV, the papers' table shape —
//! particles, time, trajectory RMSE, landmark RMSE — plus NEES) and a plot of trajectory
//! RMSE against the service's CPU time.
//!
//! Each configuration is an ordinary `fastslam-stack run` started as a child process
//! under a prefix of its own, so its numbers are by construction those of an individual
//! run with the same flags; `--jobs` runs several stacks side by side. Optimiser names
//! are passed through to the service untouched: a name the service rejects fails that
//! configuration with the service's reason and the others still run. `--shard I/N` runs
//! one slice of the configurations and `--merge` joins slices' folders into the tables the
//! whole sweep writes ([`slices`]).

use crate::commands::launch::short;
use crate::supervisor::stop_flag;
use anyhow::Context;
use fastslam_client::Metrics;
use fastslam_client::plot::{self, CostPlot, CostSeries};
use fastslam_client::stats::{mean, std_dev};
use fastslam_estimation::fastslam::Proposal;
use fastslam_estimation::moves::MoveCorrection;
use fastslam_sensors_sim::scenario::DEFAULT_SCENARIO;
use fastslam_stack::children::dying_with_this_process;
use fastslam_stack::lists::List;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::{Deserialize, Serialize};
use slices::Shard;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

mod slices;

/// Flags of `compare`.
#[derive(Debug, Clone, clap::Args)]
pub struct CompareArgs {
    /// What the sweep runs.
    #[command(flatten)]
    pub sweep: Sweep,
    /// Stacks to run at the same time (each under its own prefix). More than the cores
    /// the machine has slows every run; CPU times stay comparable, wall times do not.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// Output folder (default: <runs-dir>/compare_<scenario name>, with
    /// `_shard<I>of<N>` for a slice).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Where output folders go by default.
    #[arg(long, default_value = "runs")]
    pub runs_dir: PathBuf,
    /// Run only the I-th of N slices of the sweep (`I/N`, 1 ≤ I ≤ N): run k of the full
    /// list goes to slice k mod N + 1. Join the slices' folders with `--merge`.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Join the folders of a sweep's slices (every one of its N slices, once) into the
    /// tables and plot the unsliced sweep writes; runs nothing.
    #[arg(
        long,
        value_name = "DIR",
        num_args = 1..,
        conflicts_with_all = [
            "scenario", "optimizers", "proposals", "move_corrections", "particles", "seeds",
            "timeout_s", "jobs", "shard",
        ]
    )]
    pub merge: Vec<PathBuf>,
}

/// A sweep's definition: the flags that decide its runs and their results.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
pub struct Sweep {
    /// Scenario: a built-in name (see `scenarios`) or a scenario TOML file.
    #[arg(long, default_value = DEFAULT_SCENARIO)]
    pub scenario: String,
    /// Optimisers to compare, comma-separated (passed to the service's --optimizer).
    #[arg(long, value_delimiter = ',', default_value = "none")]
    pub optimizers: Vec<String>,
    /// Proposals, comma-separated: motion (FastSLAM 1.0) and/or fastslam2; every
    /// optimiser runs with each (default: the service config's, as `run` without
    /// `--proposal`).
    #[arg(long, value_delimiter = ',')]
    pub proposals: Vec<Proposal>,
    /// What each optimiser's answer does, comma-separated: none (the papers), proposal,
    /// resample-move; every optimiser but none runs with each (default: the service
    /// config's, as `run` without `--move-correction`).
    #[arg(long, value_delimiter = ',')]
    pub move_corrections: Vec<MoveCorrection>,
    /// Particle counts: `a,b,c` or `a..b`.
    #[arg(long, default_value = "25,50,100")]
    pub particles: List<usize>,
    /// Seeds: `a,b,c` or `a..b`; each configuration runs once per seed.
    #[arg(long, default_value = "1,2,3")]
    pub seeds: List<u64>,
    /// Stop a run after this many seconds, more than 0 (default: no limit).
    #[arg(long, value_parser = crate::commands::launch::timeout_s)]
    pub timeout_s: Option<f64>,
}

impl Sweep {
    /// Every configuration, in the order of the flags: methods, then particle counts,
    /// then seeds.
    fn configs(&self) -> Vec<Config> {
        let mut configs = Vec::new();
        for method in Method::all(self) {
            for &particles in &self.particles {
                for &seed in &self.seeds {
                    configs.push(Config {
                        method: method.clone(),
                        particles,
                        seed,
                    });
                }
            }
        }
        configs
    }
}

/// One configuration of the comparison.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Config {
    method: Method,
    particles: usize,
    seed: u64,
}

impl Config {
    /// The run folder's name.
    fn folder(&self) -> String {
        format!("{}_n{}_seed{}", self.method, self.particles, self.seed)
    }
}

/// An optimiser (its name as given) with a proposal and a move correction (`None`: the
/// config's): one line of the tables.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Method {
    optimizer: String,
    proposal: Option<Proposal>,
    correction: Option<MoveCorrection>,
}

/// `given` as options, or one `None` (the config's) when empty.
fn or_config<T: Copy>(given: &[T]) -> Vec<Option<T>> {
    if given.is_empty() {
        vec![None]
    } else {
        given.iter().copied().map(Some).collect()
    }
}

impl Method {
    /// Every optimiser with every proposal and correction, in the order of the flags; the
    /// optimiser `none` has nothing to correct and comes once per proposal.
    fn all(args: &Sweep) -> Vec<Method> {
        let proposals = or_config(&args.proposals);
        let corrections = or_config(&args.move_corrections);
        let mut out = Vec::new();
        for o in &args.optimizers {
            for &proposal in &proposals {
                let corrections = if o == "none" {
                    &corrections[..1]
                } else {
                    &corrections[..]
                };
                for &correction in corrections {
                    out.push(Method {
                        optimizer: o.clone(),
                        proposal,
                        correction: correction.filter(|_| o != "none"),
                    });
                }
            }
        }
        out
    }

    /// The proposal column of the CSV files: empty for the config's.
    fn proposal_cell(&self) -> String {
        self.proposal.map(|p| p.to_string()).unwrap_or_default()
    }

    /// The correction column of the CSV files: empty for the config's.
    fn correction_cell(&self) -> String {
        self.correction.map(|c| c.to_string()).unwrap_or_default()
    }
}

/// The method's name as `run` writes it: the optimiser, with `+fastslam2` for FastSLAM
/// 2.0's proposal and `+proposal` or `+resample-move` for a corrected mode.
impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.optimizer)?;
        if self.proposal == Some(Proposal::FastSlam2) {
            f.write_str("+fastslam2")?;
        }
        if let Some(c) = self.correction.filter(|c| c.is_valid()) {
            write!(f, "+{c}")?;
        }
        Ok(())
    }
}

/// What one run gave.
#[derive(Debug, Clone)]
struct RunResult {
    /// The run's place in the sweep's full list of configurations.
    index: usize,
    config: Config,
    folder: PathBuf,
    wall_s: f64,
    /// The run's `metrics.json`, or why there is none.
    metrics: Result<Metrics, String>,
}

impl RunResult {
    /// A number of the metrics (NaN when the run failed).
    fn num(&self, field: fn(&Metrics) -> f64) -> f64 {
        self.metrics.as_ref().map_or(f64::NAN, field)
    }
}

/// A number of a run's metrics.
type Field = fn(&Metrics) -> f64;

/// The service's CPU time (s).
const SERVICE_CPU: Field = |m| m.cost.service_cpu_s;
/// The estimate's ATE RMSE (m).
const ATE: Field = |m| m.estimate.ate_rmse_m;

/// The per-run columns of `runs.csv`: (header, field of `metrics.json`).
const RUN_COLUMNS: [(&str, Field); 15] = [
    ("service_cpu_s", SERVICE_CPU),
    ("stack_cpu_s", |m| m.cost.stack_cpu_s),
    ("ate_rmse_m", ATE),
    ("heading_rmse_rad", |m| m.estimate.heading_rmse_rad),
    ("final_error_m", |m| m.estimate.final_error_m),
    ("dead_reckoning_ate_rmse_m", |m| m.dead_reckoning.ate_rmse_m),
    ("reference_ate_rmse_m", Metrics::reference_ate_m),
    ("ate_over_reference", |m| {
        m.estimate.ate_rmse_m / m.reference_ate_m()
    }),
    ("landmark_rmse_m", |m| m.map.rmse_m),
    ("landmarks_matched", |m| m.map.matched as f64),
    ("landmarks_spurious", |m| m.map.spurious as f64),
    ("nees_mean", |m| m.consistency.nees_mean),
    ("nees_within_95", |m| m.consistency.nees_within_95),
    ("latency_median_ms", |m| m.cost.latency_ms.median),
    ("latency_p99_ms", |m| m.cost.latency_ms.p99),
];

/// The relation columns of `runs.csv`, after `run_folder` (empty for a run without
/// relations): the estimate's mean and standard deviation of the translational relation
/// error (m) and its mean rotational error (°).
const RELATION_COLUMNS: [(&str, Field); 3] = [
    ("relations_trans_mean_m", |m| {
        m.estimate.relations.map_or(f64::NAN, |r| r.trans_mean_m)
    }),
    ("relations_trans_std_m", |m| {
        m.estimate.relations.map_or(f64::NAN, |r| r.trans_std_m)
    }),
    ("relations_rot_mean_deg", |m| {
        m.estimate.relations.map_or(f64::NAN, |r| r.rot_mean_deg)
    }),
];

/// Runs the comparison, or the slice of it `--shard` names, or joins slices
/// (`--merge`); returns the exit code (0 all runs finished, 1 some failed, 130
/// interrupted).
///
/// # Errors
/// When the output folder cannot be written, the launcher cannot find itself, or the
/// folders to merge are not every slice of one sweep.
pub fn compare(args: CompareArgs) -> anyhow::Result<u8> {
    if !args.merge.is_empty() {
        let merged = slices::merge(&args.merge)?;
        let out = args.out.clone().unwrap_or_else(|| {
            args.runs_dir
                .join(format!("compare_{}", merged.scenario_name))
        });
        std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
        eprintln!(
            "merged {} slices: {} runs",
            args.merge.len(),
            merged.results.len()
        );
        return finish(&out, &merged.sweep, &merged.results, false);
    }
    let sweep = &args.sweep;
    let scenario = fastslam_sensors_sim::Scenario::load(&sweep.scenario)?;
    let shard = args.shard.unwrap_or_default();
    let out = args.out.clone().unwrap_or_else(|| {
        args.runs_dir
            .join(format!("compare_{}{}", scenario.name, shard.suffix()))
    });
    std::fs::create_dir_all(out.join("runs"))
        .with_context(|| format!("creating {}", out.display()))?;
    let all = sweep.configs();
    anyhow::ensure!(
        !all.is_empty(),
        "nothing to compare: give optimizers, proposals, particles and seeds"
    );
    let fingerprint = slices::fingerprint(sweep)?;
    let configs: Vec<(usize, &Config)> = all
        .iter()
        .enumerate()
        .filter(|(k, _)| shard.holds(*k))
        .collect();
    let exe = std::env::current_exe().context("locating the launcher's own executable")?;
    let stop = stop_flag()?;
    let slice = if shard.is_whole() {
        String::new()
    } else {
        format!(", slice {shard}: {} of them", configs.len())
    };
    eprintln!(
        "compare on {}: {} runs ({} methods × {} particle counts × {} seeds){slice}, {} at a time",
        scenario.name,
        all.len(),
        Method::all(sweep).len(),
        sweep.particles.len(),
        sweep.seeds.len(),
        args.jobs.max(1)
    );

    let bar =
        ProgressBar::with_draw_target(Some(configs.len() as u64), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed_precise} [{bar:32}] {pos}/{len} runs {msg}")
    {
        bar.set_style(style);
    }
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<RunResult>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..args.jobs.max(1) {
            scope.spawn(|| {
                while !stop.load(Ordering::SeqCst) {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    let Some(&(index, config)) = configs.get(i) else {
                        break;
                    };
                    let result = run_one(&exe, sweep, &out, config, index, &stop);
                    bar.inc(1);
                    bar.set_message(summary_line(&result));
                    if let Ok(mut r) = results.lock() {
                        r.push(result);
                    }
                }
            });
        }
    });
    bar.finish_and_clear();
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    // Table order is the order of the flags, whatever order the runs finished in.
    results.sort_by_key(|r| r.index);
    slices::write_record(&out, &scenario.name, sweep, shard, &fingerprint, &results)?;
    finish(&out, sweep, &results, stop.load(Ordering::SeqCst))
}

/// Writes the tables and the plot of `results` into `out` and prints the Markdown;
/// returns the exit code.
///
/// # Errors
/// When a file cannot be written.
fn finish(
    out: &Path,
    sweep: &Sweep,
    results: &[RunResult],
    interrupted: bool,
) -> anyhow::Result<u8> {
    let methods = Method::all(sweep);
    let markdown = write_tables(out, sweep, &methods, results)?;
    plot::save(&cost_plot(sweep, &methods, results), out, "rmse_vs_cpu")?;
    println!("comparison folder: {}", out.display());
    print!("{markdown}");
    Ok(if interrupted {
        130
    } else if results.iter().all(|r| r.metrics.is_ok()) {
        0
    } else {
        1
    })
}

/// Runs one configuration as `fastslam-stack run` under its own prefix.
fn run_one(
    exe: &Path,
    args: &Sweep,
    out: &Path,
    config: &Config,
    index: usize,
    stop: &AtomicBool,
) -> RunResult {
    let folder = out.join("runs").join(config.folder());
    let prefix = format!("fc{}j{index}x", std::process::id());
    let mut cmd = Command::new(exe);
    dying_with_this_process(&mut cmd)
        .args([
            "run",
            "--scenario",
            &args.scenario,
            "--optimizer",
            &config.method.optimizer,
        ])
        .args(["--particles", &config.particles.to_string()])
        .args([
            "--seed",
            &config.seed.to_string(),
            "--prefix",
            &prefix,
            "--out",
        ])
        .arg(&folder)
        .stdin(Stdio::null());
    if let Some(proposal) = config.method.proposal {
        cmd.args(["--proposal", &proposal.to_string()]);
    }
    if let Some(correction) = config.method.correction {
        cmd.args(["--move-correction", &correction.to_string()]);
    }
    if let Some(t) = args.timeout_s {
        cmd.args(["--timeout-s", &t.to_string()]);
    }
    let started = Instant::now();
    let output = cmd.output();
    let wall_s = started.elapsed().as_secs_f64();
    let metrics = match output {
        Err(e) => Err(format!("could not start: {e}")),
        Ok(o) if o.status.success() => read_metrics(&folder),
        Ok(o) if stop.load(Ordering::SeqCst) => Err(format!("interrupted ({})", o.status)),
        Ok(o) => Err(reason(
            &String::from_utf8_lossy(&o.stderr),
            &o.status.to_string(),
        )),
    };
    RunResult {
        index,
        config: config.clone(),
        folder,
        wall_s,
        metrics,
    }
}

/// The run folder's `metrics.json`.
fn read_metrics(folder: &Path) -> Result<Metrics, String> {
    Metrics::read(&folder.join("metrics.json")).map_err(|e| format!("{e:#}"))
}

/// Why a run failed, in one line: the last `error:` line of its error output (where the
/// launcher prints its error with the cause chain, or the flag parser its refusal, e.g.
/// of an optimiser name, with the list of choices on the next line), else its last line.
fn reason(stderr: &str, status: &str) -> String {
    let lines: Vec<&str> = stderr.lines().map(str::trim).collect();
    let message = match lines.iter().rposition(|l| l.starts_with("error: ")) {
        Some(i) => {
            let error = &lines[i]["error: ".len()..];
            match lines.get(i + 1).filter(|l| l.starts_with('[')) {
                Some(choices) => format!("{error} {choices}"),
                None => error.to_string(),
            }
        }
        None => lines
            .iter()
            .rfind(|l| !l.is_empty())
            .map_or_else(String::new, |l| l.to_string()),
    };
    if message.is_empty() {
        format!("failed ({status})")
    } else {
        format!("failed ({status}): {message}")
    }
}

/// One line about a finished run, for the progress bar.
fn summary_line(r: &RunResult) -> String {
    match &r.metrics {
        Ok(_) => format!("{}: ATE {:.3} m", r.config.folder(), r.num(ATE)),
        Err(e) => format!("{}: {e}", r.config.folder()),
    }
}

/// Mean ± sample standard deviation of a column over runs, as text.
fn mean_std(xs: &[f64], digits: usize) -> String {
    match xs.len() {
        0 => "—".into(),
        1 => format!("{:.digits$}", xs[0]),
        _ => format!("{:.digits$} ± {:.digits$}", mean(xs), std_dev(xs)),
    }
}

/// Writes `runs.csv`, `summary.csv` and `summary.md`; returns the Markdown.
fn write_tables(
    out: &Path,
    args: &Sweep,
    methods: &[Method],
    results: &[RunResult],
) -> std::io::Result<String> {
    // One row per run.
    let mut csv = String::from("optimizer,proposal,correction,particles,seed,status,wall_s");
    for (name, _) in RUN_COLUMNS {
        write!(csv, ",{name}").ok();
    }
    csv.push_str(",run_folder");
    for (name, _) in RELATION_COLUMNS {
        write!(csv, ",{name}").ok();
    }
    csv.push('\n');
    for r in results {
        let status = r
            .metrics
            .as_ref()
            .err()
            .map_or("ok".into(), |e| e.replace(',', ";"));
        write!(
            csv,
            "{},{},{},{},{},{status},{:.3}",
            r.config.method.optimizer,
            r.config.method.proposal_cell(),
            r.config.method.correction_cell(),
            r.config.particles,
            r.config.seed,
            r.wall_s
        )
        .ok();
        for (_, field) in RUN_COLUMNS {
            write!(csv, ",{}", cell(r.num(field))).ok();
        }
        write!(csv, ",{}", r.folder.display()).ok();
        for (_, field) in RELATION_COLUMNS {
            write!(csv, ",{}", cell(r.num(field))).ok();
        }
        csv.push('\n');
    }
    std::fs::write(out.join("runs.csv"), csv)?;

    // One row per method × particle count, over the seeds that finished.
    let mut summary = String::from(
        "optimizer,proposal,correction,particles,runs,failed,service_cpu_s_mean,service_cpu_s_std,wall_s_mean,\
         ate_rmse_m_mean,ate_rmse_m_std,landmark_rmse_m_mean,landmark_rmse_m_std,\
         nees_mean_mean,nees_within_95_mean,relations_trans_mean_m_mean,\
         relations_trans_std_m_mean,relations_rot_mean_deg_mean\n",
    );
    let mut md = String::from(
        "| method | particles | runs | time (s, service CPU) | trajectory RMSE (m) | \
         landmark RMSE (m) | NEES mean | NEES within 95 % |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut failures = String::new();
    for o in methods {
        for &n in &args.particles {
            let group: Vec<&RunResult> = results
                .iter()
                .filter(|r| r.config.method == *o && r.config.particles == n)
                .collect();
            let ok: Vec<&RunResult> = group
                .iter()
                .copied()
                .filter(|r| r.metrics.is_ok())
                .collect();
            if group.is_empty() {
                continue;
            }
            let col = |f: Field| ok.iter().map(|r| r.num(f)).collect::<Vec<f64>>();
            let (cpu, wall) = (
                col(SERVICE_CPU),
                ok.iter().map(|r| r.wall_s).collect::<Vec<_>>(),
            );
            let (ate, lm) = (col(ATE), col(|m| m.map.rmse_m));
            let (nees, within) = (
                col(|m| m.consistency.nees_mean),
                col(|m| m.consistency.nees_within_95),
            );
            let relations = RELATION_COLUMNS.map(|(_, f)| cell(mean(&col(f))));
            writeln!(
                summary,
                "{},{},{},{n},{},{},{},{},{},{},{},{},{},{},{},{}",
                o.optimizer,
                o.proposal_cell(),
                o.correction_cell(),
                ok.len(),
                group.len() - ok.len(),
                cell(mean(&cpu)),
                cell(std_dev(&cpu)),
                cell(mean(&wall)),
                cell(mean(&ate)),
                cell(std_dev(&ate)),
                cell(mean(&lm)),
                cell(std_dev(&lm)),
                cell(mean(&nees)),
                cell(mean(&within)),
                relations.join(","),
            )
            .ok();
            let nees_text = if ok.is_empty() {
                "—".into()
            } else {
                short(mean(&nees))
            };
            let within_text = if ok.is_empty() {
                "—".into()
            } else {
                format!("{:.0} %", 100.0 * mean(&within))
            };
            writeln!(
                md,
                "| {o} | {n} | {} | {} | {} | {} | {nees_text} | {within_text} |",
                ok.len(),
                mean_std(&cpu, 2),
                mean_std(&ate, 3),
                mean_std(&lm, 3),
            )
            .ok();
        }
    }
    // Failures, one line per method and reason (a rejected name fails every run alike).
    let mut reasons: Vec<(&Method, &str, Vec<String>)> = Vec::new();
    for r in results {
        if let Err(e) = &r.metrics {
            match reasons
                .iter_mut()
                .find(|x| *x.0 == r.config.method && x.1 == e)
            {
                Some(x) => x.2.push(r.config.folder()),
                None => reasons.push((&r.config.method, e, vec![r.config.folder()])),
            }
        }
    }
    for (method, e, runs) in &reasons {
        let which = if runs.len() == 1 {
            format!("`{}`", runs[0])
        } else {
            format!("{} runs", runs.len())
        };
        writeln!(failures, "- `{method}` ({which}): {e}").ok();
    }
    std::fs::write(out.join("summary.csv"), summary)?;
    let mut text = format!(
        "# Comparison on `{}` (seeds {})\n\nMean ± standard deviation over the seeds; time is the \
         FastSLAM service's CPU time per run. Run folders: `runs/`, every run: `runs.csv`.\n\n{md}",
        args.scenario,
        args.seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    );
    if !failures.is_empty() {
        write!(text, "\nRuns that failed:\n\n{failures}").ok();
    }
    std::fs::write(out.join("summary.md"), &text)?;
    Ok(text)
}

/// A CSV cell: the shortest exact text of a number, empty when unknown.
fn cell(v: f64) -> String {
    if v.is_finite() {
        v.to_string()
    } else {
        String::new()
    }
}

/// RMSE against service CPU time: every run, and the per-particle-count means joined.
fn cost_plot(args: &Sweep, methods: &[Method], results: &[RunResult]) -> CostPlot {
    let point = |r: &RunResult| (r.num(SERVICE_CPU), r.num(ATE));
    let series = methods
        .iter()
        .map(|o| {
            let mine: Vec<&RunResult> = results
                .iter()
                .filter(|r| r.config.method == *o && r.metrics.is_ok())
                .collect();
            let means = args
                .particles
                .iter()
                .filter_map(|&n| {
                    let pts: Vec<(f64, f64)> = mine
                        .iter()
                        .filter(|r| r.config.particles == n)
                        .map(|r| point(r))
                        .collect();
                    (!pts.is_empty()).then(|| {
                        let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
                        (mean(&x), mean(&y))
                    })
                })
                .collect();
            CostSeries {
                name: o.to_string(),
                runs: mine.iter().map(|r| point(r)).collect(),
                means,
            }
        })
        .filter(|s| !s.runs.is_empty())
        .collect();
    CostPlot { series }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reason_is_the_last_line_of_the_error_output() {
        let stderr =
            "stack x: magic on s (seed 1)\nerror: service settings: unknown optimizer `magic`\n\n";
        assert_eq!(
            reason(stderr, "exit status: 1"),
            "failed (exit status: 1): service settings: unknown optimizer `magic`"
        );
        assert_eq!(reason("", "signal: 9"), "failed (signal: 9)");
        let refused = "error: invalid value 'magic' for '--optimizer <OPTIMIZER>'\n  [possible values: none, coa]\n\nFor more information, try '--help'.\n";
        assert_eq!(
            reason(refused, "exit status: 2"),
            "failed (exit status: 2): invalid value 'magic' for '--optimizer <OPTIMIZER>' [possible values: none, coa]"
        );
    }

    #[test]
    fn mean_std_cells_say_how_many_runs_they_hold() {
        assert_eq!(mean_std(&[], 2), "—");
        assert_eq!(mean_std(&[1.234], 2), "1.23");
        assert_eq!(mean_std(&[1.0, 3.0], 1), "2.0 ± 1.4");
        assert_eq!(cell(f64::NAN), "");
        assert_eq!(cell(0.5), "0.5");
    }
}
