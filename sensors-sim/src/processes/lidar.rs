//! Publishes, every `observe_every` ground-truth samples, either a raw scan ray-cast
//! against the world (scenarios with a `[lidar]`) or noisy range–bearing observations of
//! the landmarks in view (feature-level sensor); ends with an end-of-stream message.

use crate::args::{SimArgs, streams};
use crate::ground_truth::observation_due;
use crate::landmark_sensor::LandmarkSensor;
use crate::lidar_sensor::Lidar;
use crate::relay::{ObservationsMessage, ResendArgs, ScanMessage, SensorProcess};
use crate::scenario::LidarSpec;
use crate::vehicle::State;
use fastslam_estimation::rng::stream;
use fastslam_protocol::{LaserScanHeader, Observation, ObservationsHeader, StreamId, topics};

/// What `--help` says about this process.
pub const ABOUT: &str = "Simulated lidar: every few ground-truth samples, publishes a raw scan ray-cast against the scenario's walls and poles (scenarios with a [lidar]) or noisy range–bearing observations of the landmarks in range and field of view, then an end-of-stream message.";

/// Flags of the simulated lidar.
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
    let (scenario, _) = args.sim.scenario()?;
    match scenario.lidar {
        Some(spec) => run_scans(&args, spec),
        None => run_features(&args),
    }
}

/// Raw scans on `scan`.
fn run_scans(args: &Args, spec: LidarSpec) -> anyhow::Result<()> {
    let process = SensorProcess::open(&args.sim, args.resend, "lidar-sim", StreamId::Scan)?;
    let scans = process
        .ipc
        .slice_publisher::<LaserScanHeader, f32>(&topics::SCAN)?
        .kept_for_client(&process.ipc)?
        .coalescing();
    let scenario = &process.scenario;
    let rng = stream(process.seed, &[streams::LIDAR]);
    let mut lidar = Lidar::new(spec, &scenario.world, rng);
    let (every, period) = (scenario.timing.observe_every, scenario.observe_period_s());
    process.relay(&scans, |gt, seq| {
        let Some(header) = observation_due(gt, every, seq) else {
            return Ok(None);
        };
        let scan = lidar.scan(State::from(gt));
        Ok(Some(ScanMessage {
            header: lidar.header(header, period),
            items: scan.data,
        }))
    })
}

/// Landmark observations on `observations`.
fn run_features(args: &Args) -> anyhow::Result<()> {
    let process = SensorProcess::open(&args.sim, args.resend, "lidar-sim", StreamId::Observations)?;
    let observations = process
        .ipc
        .slice_publisher::<ObservationsHeader, Observation>(&topics::OBSERVATIONS)?
        .kept_for_client(&process.ipc)?
        .coalescing();
    let mut sensor = LandmarkSensor::for_scenario(&process.scenario, process.seed);
    process.relay(&observations, |gt, seq| {
        Ok(sensor
            .scan(gt, seq)
            .map(|(header, items)| ObservationsMessage { header, items }))
    })
}
