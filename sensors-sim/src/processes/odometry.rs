//! Publishes noisy odometry derived from ground truth; ends with an end-of-stream message.

use crate::args::SimArgs;
use crate::odometry_sensor::OdometrySensor;
use crate::relay::{ResendArgs, SensorProcess};
use fastslam_protocol::{Odometry, StreamId, topics};

/// What `--help` says about this process.
pub const ABOUT: &str = "Simulated wheel odometry: turns each ground-truth sample into noisy odometry (speed, yaw rate, steering) and a dead-reckoned pose, then an end-of-stream message.";

/// Flags of the simulated wheel odometry.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack, scenario, seed and start-up flags.
    #[command(flatten)]
    pub sim: SimArgs,
    /// What it keeps for a resumed service.
    #[command(flatten)]
    pub resend: ResendArgs,
}

/// Runs the process until its stream is finished (or a signal arrives).
///
/// # Errors
/// Scenario, IPC or timeout errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let process = SensorProcess::open(&args.sim, args.resend, "odometry-sim", StreamId::Odometry)?;
    let odometry = process
        .ipc
        .publisher::<Odometry>(&topics::ODOMETRY)?
        .coalescing()
        .kept_for_client(&process.ipc)?;
    let mut sensor = OdometrySensor::for_scenario(&process.scenario, process.seed);
    process.relay(&odometry, |gt, _| Ok(Some(sensor.measure(gt))))
}
