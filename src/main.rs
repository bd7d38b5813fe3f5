//! `fastslam-stack`: one command that runs the whole FastSLAM stack — simulated sensors,
//! the FastSLAM service and the metrics client, each its own process talking over
//! iceoryx2 shared memory — and leaves a run folder with the results.
//!
//! The same binary also *is* each process (hidden subcommands), so a single
//! `cargo run --release -- run` builds and starts everything.

mod commands;
mod progress;
mod supervisor;

use clap::{Parser, Subcommand};
use commands::{
    bench, compare, extraction_report, fit_noise, map_get, monte_carlo, replay, run, scenarios,
    test, ungm,
};
use fastslam_protocol::cli::run_process;
use fastslam_sensors_sim::processes::{lidar, odometry, truth};
use std::process::ExitCode;

/// Runs the zero-copy FastSLAM stack.
#[derive(Debug, Parser)]
#[command(name = "fastslam-stack", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the whole stack on a scenario, then print the headline metrics and where the
    /// run folder is (metrics.json, TUM trajectories, maps, logs).
    Run(run::RunArgs),
    /// Run the whole stack for every optimiser × particle count × seed, then write a
    /// comparison table (Markdown, CSV) and a plot of RMSE against CPU time.
    Compare(compare::CompareArgs),
    /// Replay a recorded data set through the stack (replay process, service, client),
    /// then print the headline metrics and where the run folder is.
    Replay {
        /// The data set.
        #[command(subcommand)]
        data_set: replay::DataSet,
    },
    /// Integration-test your own publisher: the service and the client on what it
    /// publishes, judged by expectations on the metrics (exit status 0 pass, 1 fail).
    #[command(long_about = test::LONG_ABOUT)]
    Test(test::TestArgs),
    /// Ask a running stack's FastSLAM service for its current map and write it as CSV
    /// (the format `--save-map` writes and `--load-map` reads); prints the landmark count.
    MapGet(map_get::MapGetArgs),
    /// List the built-in scenarios.
    Scenarios,
    /// Run the pole extraction on the Victoria Park raw laser scans and compare it with
    /// the tree detections released with the data set (matched fraction both ways,
    /// median centre error).
    ExtractionReport(extraction_report::ReportArgs),
    /// The noise settings a recording with dense ground truth supports (MRCLAM): odometry
    /// `sigma_v`, `sigma_omega` from windows of odometry against the truth, and the
    /// sensor's from range and bearing residuals; prints them as a profile snippet.
    FitNoise(fit_noise::FitNoiseArgs),
    /// The UNGM benchmark (ICOA paper Table 1's shape) for every optimiser, with a
    /// 20 000-particle bootstrap filter as the reference: RMSE, 90 % coverage, time.
    Ungm(ungm::UngmArgs),
    /// Offline Monte Carlo comparison in process (no IPC): optimisers × proposals ×
    /// particle counts × seeds on a scenario, scored by the client's metrics.
    MonteCarlo(monte_carlo::MonteCarloArgs),
    /// Solve a 2D pose graph in the g2o format (first pose anchored): prints χ² and time.
    Solve(commands::solve::SolveArgs),
    /// Performance figures, printed with the machine: filter step time over particles ×
    /// landmarks per optimiser with growth ratios, end-to-end latency at the real-time
    /// rate (median, p99, p99.9), multi-process against in-process throughput (the IPC
    /// overhead), CPU time and peak memory per process. See BENCHMARKS.md.
    ///
    /// The full step grid takes minutes; `--quick` runs a subset in well under a minute.
    Bench(bench::BenchArgs),
    /// Serve a running stack live to Foxglove over WebSocket (connect Foxglove to
    /// ws://localhost:8765), for a stack whose processes you start yourself; `run --live`
    /// and `replay --live` start it for you. It exits when the stack's streams end.
    Viewer(fastslam_client::viewer::Args),
    /// Carry a stack's topics between two hosts over Zenoh (TCP): run one bridge on the
    /// host with the sensors (`--side sensors`) and one on the host with the FastSLAM
    /// service (`--side service`); one listens, the other connects. See docs/MULTI_HOST.md.
    Bridge(fastslam_bridge::Args),
    /// The truth simulator process (started by `run`).
    #[command(hide = true)]
    TruthSim(truth::Args),
    /// The odometry sensor process (started by `run`).
    #[command(hide = true)]
    OdometrySim(odometry::Args),
    /// The landmark sensor process (started by `run`).
    #[command(hide = true)]
    LidarSim(lidar::Args),
    /// The replay process of each data set (started by `replay <data set>`).
    #[command(flatten)]
    ReplayProcess(fastslam_replay::registry::ProcessCommand),
    /// The FastSLAM service process (started by `run`).
    #[command(hide = true)]
    Service(fastslam_service::process::Args),
    /// The metrics client process (started by `run`).
    #[command(hide = true)]
    Client(fastslam_client::process::Args),
}

/// Runs the command; a failure prints its reason chain on one line (never a backtrace,
/// whatever `RUST_BACKTRACE` says) and exits 1.
fn main() -> ExitCode {
    match dispatch(Cli::parse().command) {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Runs one command; returns its exit code.
fn dispatch(command: Command) -> anyhow::Result<u8> {
    let done = |result: anyhow::Result<()>| result.map(|()| 0);
    match command {
        Command::Run(args) => {
            fastslam_protocol::cli::init_logging("launcher");
            run::run(args)
        }
        Command::Compare(args) => {
            fastslam_protocol::cli::init_logging("compare");
            compare::compare(args)
        }
        Command::Replay { data_set } => {
            fastslam_protocol::cli::init_logging("launcher");
            replay::replay(data_set)
        }
        Command::Test(args) => {
            fastslam_protocol::cli::init_logging("test");
            test::run(&args)
        }
        Command::Scenarios => {
            scenarios::run();
            Ok(0)
        }
        Command::MapGet(args) => done(map_get::run(&args)),
        Command::ExtractionReport(args) => done(extraction_report::run(&args)),
        Command::FitNoise(args) => done(fit_noise::run(&args)),
        Command::Ungm(a) => done(ungm::run(&a)),
        Command::MonteCarlo(a) => done(monte_carlo::run(&a)),
        Command::Solve(a) => done(commands::solve::run(&a)),
        Command::Bench(a) => {
            fastslam_protocol::cli::init_logging("bench");
            done(bench::run(&a))
        }
        Command::TruthSim(a) => done(run_process("truth-sim", a, truth::run)),
        Command::OdometrySim(a) => done(run_process("odometry-sim", a, odometry::run)),
        Command::LidarSim(a) => done(run_process("lidar-sim", a, lidar::run)),
        Command::ReplayProcess(p) => done(run_process(p.name(), p, |p| p.run())),
        Command::Service(a) => done(run_process("service", a, fastslam_service::process::run)),
        Command::Client(a) => done(run_process("client", a, fastslam_client::process::run)),
        Command::Viewer(a) => done(run_process("viewer", a, fastslam_client::viewer::run)),
        Command::Bridge(a) => done(run_process("bridge", a, fastslam_bridge::run)),
    }
}
