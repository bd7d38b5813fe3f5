//! `fastslam-stack test`: your own publisher through the FastSLAM service and the metrics
//! client, judged by expectations on the metrics — one command for a CI job. The stack is
//! [`fastslam_stack::harness`]'s: the service and the client under a fresh prefix and
//! iceoryx2 root, the publisher a shell command with both in its environment.

use crate::commands::launch::{PassThrough, print_summary};
use crate::supervisor::stop_flag;
use anyhow::Context;
use fastslam_client::expect::JudgeArgs;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::ServiceConfig;
use fastslam_stack::harness::Stack;
use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// What `test --help` says beyond the one-line summary.
pub const LONG_ABOUT: &str = "Integration-test your own publisher: starts the FastSLAM service \
and the metrics client under a fresh stack prefix and iceoryx2 root, runs your publisher \
(`sh -c CMD`) with FASTSLAM_PREFIX and FASTSLAM_IOX_ROOT naming that stack in its environment, \
waits until everything has ended (or --timeout-s), removes the stack's shared memory, prints \
the headline metrics and one line per expectation, and exits 0 when every stream ended and \
every expectation holds, else 1.

The service takes your samples as fast as you send them (--realtime: as a real-time \
sensor's, whose full queue drops inputs). An input the service drops or rejects fails the \
run: `inputs.rejected_total == 0` is expected unless an --expect of yours names \
inputs.rejected_total. A publisher still running at the timeout gets SIGTERM, then SIGKILL \
5 s later.

Your publisher publishes odometry, scans or observations, and — for the client's scoring — \
ground truth and the true landmarks, then an end-of-stream message on each stream; it should \
start publishing once two processes (the service and the client) have subscribed. \
examples/python/publisher.py does all of this:

  fastslam-stack test --config examples/python/service.toml \\
      --publisher \"python3 examples/python/publisher.py\" \\
      --expect \"estimate.ate_rmse_m < 0.5\" --junit report.xml

client/METRICS.md lists the numbers an expectation can name; docs/TESTING.md has a CI job.";

/// Flags of `test`.
#[derive(Debug, Clone, clap::Args)]
pub struct TestArgs {
    /// Your publisher: a shell command, run with `sh -c` in this directory once the service
    /// and the client are up.
    #[arg(long, value_name = "CMD")]
    pub publisher: String,
    /// Service settings of a scenario: a built-in name (see `scenarios`) or a scenario TOML
    /// file, whose [service] table the service runs with.
    #[arg(long, conflicts_with = "config")]
    pub scenario: Option<String>,
    /// Service config file (default: the service's defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Expectations on the metrics and a JUnit report, judged by the client.
    #[command(flatten)]
    pub judge: JudgeArgs,
    /// Stop everything and fail after this many seconds (SIGTERM, then SIGKILL 5 s later
    /// to what ignores it).
    #[arg(long, default_value_t = 600.0)]
    pub timeout_s: f64,
    /// The service takes the publisher's samples as a real-time sensor's: a full input
    /// queue drops its oldest input, a sensor silent beyond the deadline is not waited for
    /// (default: as fast as the publisher sends; a full queue makes the service wait).
    #[arg(long)]
    pub realtime: bool,
    /// Folder for the run folder (`run/`), the service's settings and every process's log.
    #[arg(long, default_value = "runs/test")]
    pub out: PathBuf,
    /// Extra flags for the service and the client.
    #[command(flatten)]
    pub pass: PassThrough,
}

/// What every run is expected to do unless an expectation of the user's names the same
/// number: the service dropped or rejected no input.
pub const NOTHING_DROPPED: &str = "inputs.rejected_total == 0";

/// Runs the test; returns the exit code (0 passed, 130 interrupted).
///
/// # Errors
/// Bad flags or settings (before anything starts), a process that fails or outlives the
/// timeout, or a run that fails its expectations ([`NOTHING_DROPPED`] among them).
pub fn run(args: &TestArgs) -> anyhow::Result<u8> {
    let judge = args.judge.with_default(NOTHING_DROPPED)?;
    let settings = service_settings(args)?;
    let exe = std::env::current_exe().context("locating the launcher's own executable")?;
    let stop = stop_flag()?;
    let mut builder = Stack::builder(exe)
        .dir(&args.out)
        .service_flags(args.pass.service.iter().cloned())
        .client_flags(args.pass.client.iter().cloned())
        .realtime(args.realtime)
        .judge(judge)
        .stop_flag(stop.clone());
    if let Some(toml) = &settings {
        builder = builder.service_config(toml);
    }
    let started = Instant::now();
    let mut stack = builder.start()?;
    let [(_, prefix), (_, root)] = stack.env();
    eprintln!("stack {prefix}: publisher `{}`", args.publisher);
    eprintln!("join it with FASTSLAM_PREFIX={prefix} FASTSLAM_IOX_ROOT={root}");
    let run_folder = stack.run_folder().to_path_buf();
    let mut publisher = Command::new("sh");
    publisher.arg("-c").arg(&args.publisher);
    stack.start_publisher(publisher)?;
    let judged = stack.finish_judged(Duration::from_secs_f64(args.timeout_s));
    if stop.load(Ordering::SeqCst) {
        eprintln!(
            "interrupted; processes stopped, shared memory removed. Logs: {}",
            args.out.display()
        );
        return Ok(130);
    }
    if judged.is_err() {
        eprintln!("logs: {}", args.out.display());
    }
    let (_, verdict) = judged?;
    print_summary(&run_folder, started.elapsed())?;
    for line in verdict.lines() {
        println!("  {line}");
    }
    verdict.into_result().map(|()| 0)
}

/// The service's settings as TOML: the config file, or the scenario's [service] table, or
/// none (the defaults); checked here so bad settings fail before anything starts.
fn service_settings(args: &TestArgs) -> anyhow::Result<Option<String>> {
    let (label, text) = match (&args.config, &args.scenario) {
        (Some(file), _) => (
            format!("service config {}", file.display()),
            std::fs::read_to_string(file)
                .with_context(|| format!("service config {}", file.display()))?,
        ),
        (None, Some(name)) => {
            let scenario = Scenario::load(name)?;
            let Some(table) = &scenario.service else {
                return Ok(None);
            };
            (
                format!("scenario {} [service]", scenario.name),
                toml::to_string(table)?,
            )
        }
        (None, None) => return Ok(None),
    };
    ServiceConfig::parse(&label, &text)?;
    Ok(Some(text))
}
