//! `fastslam-stack run`: the whole stack on one scenario, under a fresh stack prefix, with
//! a run folder at the end.

use crate::commands::launch::{Ended, LaunchArgs, PassThrough, Place, conclude, prepare};
use crate::progress;
use crate::supervisor::{Supervisor, stop_flag};
use anyhow::{Context, bail};
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
    /// Where the stack runs, how fast, for how long, what is judged, the live view.
    #[command(flatten)]
    pub launch: LaunchArgs,
    /// Extra flags for the service and the client.
    #[command(flatten)]
    pub pass: PassThrough,
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
    let expectations = args.launch.judge.expectations()?;
    args.launch.split.check(args.launch.live.live)?;
    let scenario = Scenario::load(&args.scenario)?;
    let seed = args.seed.unwrap_or(scenario.seed);
    let place = Place::claim(
        args.launch.prefix.as_deref(),
        args.launch.iox_root.as_deref(),
    )?;
    let (prefix, root) = (place.prefix.clone(), place.root.clone());
    // The service's settings, checked here so a bad value fails before anything starts.
    let overrides = Overrides {
        particles: args.particles,
        seed: Some(seed),
        choice: args.choice.clone(),
    };
    let method = settings::service_config(&scenario, args.config.as_deref(), &overrides)?.method();
    let out = args.out.clone().unwrap_or_else(|| {
        args.launch
            .runs_dir
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
    if !args.launch.pace.realtime {
        service.push("--as-fast-as-possible".into());
    }
    service.extend(args.pass.service.iter().cloned());
    let mut client = stack_flags.clone();
    client.extend(["--out".into(), out.display().to_string()]);
    if let Some(c) = &service_config {
        client.extend(["--service-config".into(), c.display().to_string()]);
    }
    client.extend(args.launch.judge.flags());
    client.extend(args.pass.client.iter().cloned());
    for flags in [&mut service, &mut client] {
        if args.busy_poll {
            flags.push("--busy-poll".into());
        }
        if args.spin_us > 0 {
            flags.push(format!("--spin-us={}", args.spin_us));
        }
    }
    let mut truth = sim_flags();
    truth.extend(args.launch.pace.flags());
    let own_flags = |name: &str| match name {
        "client" => client.clone(),
        "service" => service.clone(),
        "truth-sim" => truth.clone(),
        _ => sim_flags(),
    };
    let processes: Vec<(&'static str, Vec<String>)> = topology::SIMULATION
        .iter()
        .filter(|role| args.launch.split.runs_here(role.name))
        .map(|role| {
            let mut flags = own_flags(role.name);
            flags.extend(role.wait_flags(args.launch.live.live));
            (role.name, flags)
        })
        .collect();
    eprintln!(
        "stack {prefix}: {method} on {} (seed {seed})",
        scenario.name
    );
    place.announce();
    let total_s = progress::simulated_duration_s(&scenario);
    args.launch
        .split
        .spawn_bridge(&mut stack, &exe, &stack_flags, &logs)?;
    args.launch
        .live
        .spawn(&mut stack, &exe, &stack_flags, &logs)?;
    let mut live_view = None;
    for (name, flags) in &processes {
        let mut argv = vec![name.to_string()];
        argv.extend(flags.iter().cloned());
        let log = logs.join(format!("{name}.log"));
        if *name == "client" {
            // The client's progress lines drive the live view (see `progress`).
            let stdout = stack.spawn_reading_stdout(name, &exe, &argv, &log)?;
            // A client that dies is started again and resumes the run from its journal.
            stack.restart_when_killed(name, "--resume");
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
    let outcome = stack.wait(&stop, args.launch.timeout_s.map(Duration::from_secs_f64));
    drop(stack);
    if let Some(view) = live_view {
        let _ = view.join();
    }
    place.remove();
    if let Some(code) = args.launch.split.conclusion(&outcome, &logs) {
        return Ok(code);
    }
    let ended = Ended {
        outcome,
        out: &out,
        logs: &logs,
        wall: started.elapsed(),
    };
    conclude(ended, &args.launch.judge, &expectations)
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
