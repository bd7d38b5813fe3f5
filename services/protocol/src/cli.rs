//! Flags and start-up every process of the stack shares: which stack to join, and logs.
//!
//! Only with the `cli` feature (the stack's processes enable it): a user's publisher
//! needs none of this, nor clap and tracing-subscriber.

use crate::ipc::StackConfig;

/// Default stack name: what a user's own publisher joins when nothing else is said.
pub const DEFAULT_PREFIX: &str = "fastslam";

/// Which stack a process joins.
#[derive(Debug, Clone, clap::Args)]
pub struct StackArgs {
    /// Stack name: iceoryx2 file prefix and service-name prefix ([A-Za-z0-9_-], ≤ 32).
    #[arg(long, env = "FASTSLAM_PREFIX", default_value = DEFAULT_PREFIX)]
    pub prefix: String,
    /// iceoryx2 root directory (keep it short: it holds Unix sockets). Default: iceoryx2's.
    #[arg(long, env = "FASTSLAM_IOX_ROOT")]
    pub iox_root: Option<String>,
}

impl StackArgs {
    /// The stack location these flags name.
    pub fn stack(&self) -> StackConfig {
        StackConfig {
            prefix: self.prefix.clone(),
            root: self.iox_root.clone(),
        }
    }
}

/// How a producer paces what it publishes: as fast as its consumers take it (the
/// default: nothing is lost and the results do not depend on timing), or at the data's
/// own rates.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct PaceArgs {
    /// Publish at the data's own rates instead of as fast as the consumers go.
    #[arg(long)]
    pub realtime: bool,
    /// With `--realtime`: this many times faster than real time (2 = twice as fast, like
    /// `ros2 bag play --rate`).
    #[arg(long, default_value_t = 1.0, requires = "realtime", value_parser = positive_rate)]
    pub rate: f64,
}

impl PaceArgs {
    /// The same flags, for a child process.
    pub fn flags(&self) -> Vec<String> {
        if self.realtime {
            vec!["--realtime".into(), "--rate".into(), self.rate.to_string()]
        } else {
            Vec::new()
        }
    }
}

/// A `--rate`: a finite number above 0.
fn positive_rate(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(rate) if rate.is_finite() && rate > 0.0 => Ok(rate),
        _ => Err(format!("{text:?} is not a rate above 0 (1 = real time)")),
    }
}

/// How a process that consumes topics waits for them.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct WaitArgs {
    /// Poll the inputs in a busy loop instead of sleeping until a publisher's notification
    /// wakes the process. This takes out the time a sleeping process needs to run again
    /// once woken, which dominates the latency tail on virtual machines, and keeps one core
    /// at 100 % for as long as the process runs. See BENCHMARKS.md ("Busy polling").
    #[arg(long)]
    pub busy_poll: bool,
    /// After each wake-up, go on polling the inputs until none has arrived for this many
    /// microseconds, then sleep again: the samples that follow one another closely (a
    /// scan after its odometry, a pose after its scan) are taken without waking up again.
    /// Costs at least this much CPU per wake-up. 0: sleep at once.
    #[arg(long, default_value_t = 0, value_name = "US")]
    pub spin_us: u64,
}

impl WaitArgs {
    /// The spin period after each wake-up.
    pub fn spin(&self) -> std::time::Duration {
        std::time::Duration::from_micros(self.spin_us)
    }
}

/// The log filter without `RUST_LOG`: `info`, but only errors from Zenoh's crates (the
/// bridge's), whose warnings repeat the bridge's own errors with the source locations of
/// the machine that built them, and whose info lines are its internals.
pub const DEFAULT_LOG: &str = "info,zenoh=error";

/// Sends `tracing` output to stderr, filtered by `RUST_LOG` (default [`DEFAULT_LOG`]),
/// each line tagged with the process name so interleaved logs of a stack stay readable.
pub fn init_logging(process: &'static str) {
    use tracing_subscriber::EnvFilter;
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(DEFAULT_LOG));
    // A second call in the same process (tests) keeps the first subscriber.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false)
        .try_init();
    tracing::debug!(process, "logging started");
}

/// Command line of a single process: its own flags, nothing else.
#[derive(Debug, clap::Parser)]
#[command(version)]
struct ProcessCli<A: clap::Args> {
    #[command(flatten)]
    args: A,
}

/// The whole `main` of a process binary: flags (with `about` as the `--help` text),
/// logging, then `run`, inside a span named after the process so interleaved logs stay
/// readable. A failure prints one `error: …` line with its causes (never a backtrace,
/// whatever `RUST_BACKTRACE` says) and exits with status 1.
pub fn main_of<A: clap::Args, E: std::fmt::Display>(
    process: &'static str,
    about: &'static str,
    run: impl FnOnce(A) -> Result<(), E>,
) -> std::process::ExitCode {
    match parsed_and_run(process, about, run) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// [`main_of`] up to the verdict.
fn parsed_and_run<A: clap::Args, E: std::fmt::Display>(
    process: &'static str,
    about: &'static str,
    run: impl FnOnce(A) -> Result<(), E>,
) -> Result<(), E> {
    use clap::{CommandFactory, FromArgMatches};
    let matches = ProcessCli::<A>::command()
        .name(process)
        .about(about)
        .get_matches();
    let cli = ProcessCli::<A>::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    run_process(process, cli.args, run)
}

/// Runs a process whose flags are already parsed: logging, a span named after the
/// process, and [`finish`].
///
/// # Errors
/// `run`'s error unless a shutdown was requested.
pub fn run_process<A, E: std::fmt::Display>(
    process: &'static str,
    args: A,
    run: impl FnOnce(A) -> Result<(), E>,
) -> Result<(), E> {
    init_logging(process);
    in_process_span(process, || finish(run(args)))
}

/// A process stopped by SIGINT/SIGTERM exits 0 whatever it was doing (it was asked to
/// stop); any other error is the process's failure.
///
/// # Errors
/// `result`'s error unless a shutdown was requested.
pub fn finish<E: std::fmt::Display>(result: Result<(), E>) -> Result<(), E> {
    match result {
        Err(e) if crate::ipc::shutdown::requested() => {
            tracing::info!("stopped by signal ({e})");
            Ok(())
        }
        Ok(()) if crate::ipc::shutdown::requested() => {
            tracing::info!("stopped by signal");
            Ok(())
        }
        r => r,
    }
}

/// Runs `f` inside the span that tags every log line with the process name.
pub fn in_process_span<T>(process: &'static str, f: impl FnOnce() -> T) -> T {
    tracing::info_span!("process", name = process).in_scope(f)
}

/// Why [`built_in_or_file`] found nothing: the built-in names (comma-separated, for the
/// user to pick from) and the reason the file could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotBuiltInOrFile {
    /// The built-in names, comma-separated.
    pub built_in: String,
    /// Why reading `name_or_path` as a file failed.
    pub reason: String,
}

/// The text of the built-in `(name, text)` called `name_or_path`, else the file at that
/// path: how scenarios and replay profiles are named on the command line.
///
/// # Errors
/// [`NotBuiltInOrFile`] when it is neither.
pub fn built_in_or_file(
    name_or_path: &str,
    built_in: &[(&str, &str)],
) -> Result<String, NotBuiltInOrFile> {
    match built_in.iter().find(|(n, _)| *n == name_or_path) {
        Some((_, text)) => Ok((*text).to_string()),
        None => std::fs::read_to_string(name_or_path).map_err(|e| NotBuiltInOrFile {
            built_in: (built_in.iter().map(|(n, _)| *n))
                .collect::<Vec<_>>()
                .join(", "),
            reason: e.to_string(),
        }),
    }
}
