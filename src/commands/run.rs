//! `fastslam-stack run`: the whole stack on one scenario, under a fresh stack prefix, with
//! a run folder at the end.

use crate::progress;
use crate::supervisor::{Outcome, Supervisor, stop_flag};
use anyhow::{Context, bail};
use fastslam_client::Metrics;
use fastslam_client::expect::{Expectations, JudgeArgs};
use fastslam_protocol::ipc;
use fastslam_sensors_sim::Scenario;
use fastslam_sensors_sim::scenario::{BUILT_IN, DEFAULT_SCENARIO};
use fastslam_service::config::{EstimatorChoice, Overrides};
use fastslam_stack::settings;
use fastslam_stack::topology;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Flags of `run`.
#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {
    /// Scenario: a built-in name (see `scenarios`) or a scenario TOML file.
    #[arg(long, default_value = DEFAULT_SCENARIO)]
    pub scenario: String,
    /// Seed of the simulation and the filter (default: the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Optimiser, proposal and move correction of the FastSLAM service.
    #[command(flatten)]
    pub choice: EstimatorChoice,
    /// Number of particles (default: the service's config).
    #[arg(long)]
    pub particles: Option<usize>,
    /// Service config file (default: the scenario's [service] table).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Run folder (default: <runs-dir>/<scenario>_<method>_seed<seed>, the method being
    /// the optimiser with +fastslam2, +proposal or +resample-move when they apply).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Where run folders go by default.
    #[arg(long, default_value = "runs")]
    pub runs_dir: PathBuf,
    /// Pace the simulation in real time instead of as fast as the stack can go.
    #[arg(long)]
    pub realtime: bool,
    /// Stop everything after this many seconds (default: no limit).
    #[arg(long)]
    pub timeout_s: Option<f64>,
    /// Stack prefix, to let your own processes join (default: a fresh one per run,
    /// removed with its shared-memory files at the end).
    #[arg(long)]
    pub prefix: Option<String>,
    /// iceoryx2 root directory of the stack (default: $TMPDIR/fsl/<prefix>, removed at the
    /// end; a root you name is kept).
    #[arg(long)]
    pub iox_root: Option<PathBuf>,
    /// Expectations on the metrics and a JUnit report, passed on to the client.
    #[command(flatten)]
    pub judge: JudgeArgs,
    /// An extra flag for the FastSLAM service, passed through as is (repeatable), e.g.
    /// `--service-flag=--save-map=map.csv` or `--service-flag=--checkpoint=run.ckpt`.
    #[arg(long = "service-flag", value_name = "FLAG", allow_hyphen_values = true)]
    pub service_flags: Vec<String>,
    /// The service and the client (the processes between a sensor sample and the pose
    /// that used it) poll their inputs in a busy loop instead of sleeping: a lower latency
    /// tail for one core each at 100 %. See BENCHMARKS.md ("Busy polling").
    #[arg(long)]
    pub busy_poll: bool,
    /// The service and the client go on polling their inputs after each wake-up until
    /// none has arrived for this many microseconds, then sleep again: part of busy
    /// polling's latency gain for a few percent of a core. See BENCHMARKS.md ("Busy
    /// polling").
    #[arg(long, default_value_t = 0, value_name = "US")]
    pub spin_us: u64,
}

/// Runs the stack; returns the process exit code (0 finished, 1 failed, 130 interrupted).
///
/// # Errors
/// When the scenario is invalid or the processes cannot be started.
pub fn run(args: RunArgs) -> anyhow::Result<u8> {
    let expectations = args.judge.expectations()?;
    let scenario = Scenario::load(&args.scenario)?;
    let seed = args.seed.unwrap_or(scenario.seed);
    let place = Place::of(args.prefix.as_deref(), args.iox_root.as_deref());
    let (prefix, root) = (place.prefix.clone(), place.root.clone());
    // The service's settings, checked here so a bad value fails before anything starts.
    let overrides = Overrides {
        particles: args.particles,
        seed: Some(seed),
        choice: args.choice.clone(),
    };
    let method = settings::service_config(&scenario, args.config.as_deref(), &overrides)?.method();
    let out = args.out.clone().unwrap_or_else(|| {
        args.runs_dir
            .join(format!("{}_{method}_seed{seed}", scenario.name))
    });
    let logs = prepare(&out)?;
    let service_config = service_config_file(&args, &scenario, &out)?;
    let exe = std::env::current_exe().context("locating the launcher's own executable")?;

    let stop = stop_flag()?;
    let started = Instant::now();
    let mut stack = Supervisor::default();
    let stack_flags = vec![
        "--prefix".to_string(),
        prefix.clone(),
        "--iox-root".into(),
        root.display().to_string(),
    ];
    let sim_flags = || {
        let mut f = stack_flags.clone();
        f.extend([
            "--scenario".into(),
            scenario_arg(&args.scenario),
            "--seed".into(),
            seed.to_string(),
        ]);
        f
    };
    let mut service = stack_flags.clone();
    service.extend(overrides.flags());
    if let Some(c) = &service_config {
        service.extend(["--config".into(), c.display().to_string()]);
    }
    service.extend(args.service_flags.iter().cloned());
    let mut client = stack_flags.clone();
    client.extend(["--out".into(), out.display().to_string()]);
    if let Some(c) = &service_config {
        client.extend(["--service-config".into(), c.display().to_string()]);
    }
    client.extend(args.judge.flags());
    for flags in [&mut service, &mut client] {
        if args.busy_poll {
            flags.push("--busy-poll".into());
        }
        if args.spin_us > 0 {
            flags.push(format!("--spin-us={}", args.spin_us));
        }
    }
    let mut truth = sim_flags();
    if args.realtime {
        truth.push("--realtime".into());
    }
    let own_flags = |name: &str| match name {
        "client" => client.clone(),
        "service" => service.clone(),
        "truth-sim" => truth.clone(),
        _ => sim_flags(),
    };
    let processes: Vec<(&'static str, Vec<String>)> = topology::SIMULATION
        .iter()
        .map(|role| {
            let mut flags = own_flags(role.name);
            flags.extend(role.wait_flags());
            (role.name, flags)
        })
        .collect();
    eprintln!(
        "stack {prefix}: {method} on {} (seed {seed})",
        scenario.name
    );
    place.announce();
    let total_s = progress::simulated_duration_s(&scenario);
    let mut live_view = None;
    for (name, flags) in &processes {
        let mut argv = vec![name.to_string()];
        argv.extend(flags.iter().cloned());
        let log = logs.join(format!("{name}.log"));
        if *name == "client" {
            // The client's progress lines drive the live view (see `progress`).
            let stdout = stack.spawn_reading_stdout(name, &exe, &argv, &log)?;
            live_view = Some(progress::follow(
                stdout,
                &log,
                progress::bar(total_s),
                total_s,
            )?);
        } else {
            stack.spawn(name, &exe, &argv, &log)?;
        }
    }
    let outcome = stack.wait(&stop, args.timeout_s.map(Duration::from_secs_f64));
    drop(stack);
    if let Some(view) = live_view {
        let _ = view.join();
    }
    place.remove();
    let ended = Ended {
        outcome,
        out: &out,
        logs: &logs,
        wall: started.elapsed(),
    };
    conclude(ended, &args.judge, &expectations)
}

/// Where a launcher's stack lives: its prefix and iceoryx2 root.
pub(crate) struct Place {
    /// The stack prefix.
    pub prefix: String,
    /// The iceoryx2 root.
    pub root: PathBuf,
    /// True when the launcher chose the root (so it removes it at the end).
    own_root: bool,
}

impl Place {
    /// The prefix and root given, else a fresh prefix and a root of its own.
    pub fn of(prefix: Option<&str>, root: Option<&Path>) -> Self {
        let prefix = prefix.map_or_else(fastslam_stack::fresh_prefix, str::to_string);
        Self {
            root: root.map_or_else(|| fastslam_stack::stack_root(&prefix), Path::to_path_buf),
            own_root: root.is_none(),
            prefix,
        }
    }

    /// Prints how a process of yours joins the stack.
    pub fn announce(&self) {
        eprintln!(
            "join it with FASTSLAM_PREFIX={} FASTSLAM_IOX_ROOT={}",
            self.prefix,
            self.root.display()
        );
    }

    /// Removes the stack's shared memory, and its root when the launcher chose it.
    pub fn remove(&self) {
        ipc::remove_stack_files(&self.prefix, self.own_root.then_some(self.root.as_path()));
    }
}

/// Makes the run folder `out` and its `logs/` folder, without the metrics of an earlier
/// run (so metrics.json is this run's or absent); returns the logs folder.
///
/// # Errors
/// When a folder cannot be made or an old metrics.json cannot be removed.
pub(crate) fn prepare(out: &Path) -> anyhow::Result<PathBuf> {
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let metrics = out.join("metrics.json");
    if metrics.is_file() {
        std::fs::remove_file(&metrics)
            .with_context(|| format!("removing {}", metrics.display()))?;
    }
    Ok(logs)
}

/// How a launcher's stack ended and where its run folder and logs are.
pub(crate) struct Ended<'a> {
    /// What the supervisor saw.
    pub outcome: Outcome,
    /// The run folder.
    pub out: &'a Path,
    /// The processes' logs.
    pub logs: &'a Path,
    /// Wall time of the run.
    pub wall: Duration,
}

/// Reports how a stack ended: the summary of its run folder when it finished (with the
/// expectations' lines when it is judged), else what went wrong and where the logs are.
/// Returns the launcher's exit code (0 finished, 1 failed or timed out, 130 interrupted).
///
/// A client that exits 1 because the run failed its expectations (it wrote metrics.json
/// that fail them) is the verdict, not a failure of the stack.
///
/// # Errors
/// When a finished run's metrics cannot be read, or the run failed its expectations.
pub(crate) fn conclude(
    ended: Ended<'_>,
    judge: &JudgeArgs,
    expectations: &Expectations,
) -> anyhow::Result<u8> {
    let Ended {
        outcome,
        out,
        logs,
        wall,
    } = ended;
    let judged = judge.on()
        && out.join("metrics.json").is_file()
        && matches!(
            outcome,
            Outcome::Finished | Outcome::Failed { name: "client", .. }
        );
    if judged {
        let verdict = expectations.judge_folder(out)?;
        if outcome == Outcome::Finished || !verdict.passed() {
            print_summary(out, wall)?;
            for line in verdict.lines() {
                println!("  {line}");
            }
            return verdict.into_result().map(|()| 0);
        }
    }
    match outcome {
        Outcome::Finished => {
            print_summary(out, wall)?;
            Ok(0)
        }
        Outcome::Failed { name, status } => {
            eprintln!(
                "{name} failed ({status}); the other processes were stopped. Its log ends with:"
            );
            eprintln!("{}", tail(&logs.join(format!("{name}.log")), 15));
            Ok(1)
        }
        Outcome::Interrupted => {
            eprintln!(
                "interrupted; processes stopped, shared memory removed. Logs: {}",
                logs.display()
            );
            Ok(130)
        }
        Outcome::TimedOut => {
            eprintln!("timed out; processes stopped. Logs: {}", logs.display());
            Ok(1)
        }
    }
}

/// A built-in scenario is passed by name, a file by absolute path.
fn scenario_arg(scenario: &str) -> String {
    if BUILT_IN.iter().any(|(n, _)| *n == scenario) {
        return scenario.to_string();
    }
    std::fs::canonicalize(scenario)
        .map_or_else(|_| scenario.to_string(), |p| p.display().to_string())
}

/// The service's config file: `--config`, else the scenario's `[service]` table written
/// into the run folder (so the folder records what ran).
fn service_config_file(
    args: &RunArgs,
    scenario: &Scenario,
    out: &Path,
) -> anyhow::Result<Option<PathBuf>> {
    if let Some(c) = &args.config {
        if !c.is_file() {
            bail!("service config {} is not a readable file", c.display());
        }
        return Ok(Some(std::fs::canonicalize(c)?));
    }
    let Some(table) = &scenario.service else {
        return Ok(None);
    };
    let path = out.join("service.toml");
    std::fs::write(&path, toml::to_string_pretty(table)?)?;
    Ok(Some(path))
}

/// A number in at most 8 characters: fixed point, or scientific when huge.
pub(crate) fn short(v: f64) -> String {
    if v.abs() < 1e5 {
        format!("{v:.2}")
    } else {
        format!("{v:.2e}")
    }
}

/// The last `n` lines of a log file.
fn tail(path: &Path, n: usize) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// Prints where the run folder is and its headline metrics.
pub(crate) fn print_summary(out: &Path, wall: Duration) -> anyhow::Result<()> {
    let m = Metrics::read(&out.join("metrics.json"))?;
    println!("run folder: {}", out.display());
    println!(
        "  ATE RMSE       {:8.3} m   (dead reckoning {:.3} m)",
        m.estimate.ate_rmse_m, m.dead_reckoning.ate_rmse_m
    );
    if let Some(r) = &m.reference {
        println!(
            "  achievable ATE {:8.3} m   (full-SLAM MAP over the same data; the estimate is {:.1}× it; \
             χ²/dof {:.2})",
            r.ate_rmse_m,
            m.estimate.ate_rmse_m / r.ate_rmse_m,
            r.chi2_per_dof
        );
    }
    println!("  final error    {:8.3} m", m.estimate.final_error_m);
    println!(
        "  landmark RMSE  {:8.3} m   ({} of {} matched, {} spurious)",
        m.map.rmse_m, m.map.matched, m.map.truth, m.map.spurious
    );
    let c = &m.consistency;
    println!(
        "  NEES mean      {:>8}     ({:.0} % of steps within the 95 % bound; 3 when consistent; \
         {} steps with a singular covariance)",
        short(c.nees_mean),
        100.0 * c.nees_within_95,
        c.singular
    );
    println!("  wall time      {:8.2} s", wall.as_secs_f64());
    Ok(())
}
