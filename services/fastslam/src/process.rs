//! The service process: odometry and the lidar (landmark observations or raw scans) in;
//! pose estimates, landmark maps, occupancy grids and status out. Its flags ([`Args`]),
//! and [`run`]: set-up, the wake loop (the `service` module), finish.

use crate::config::{EstimatorChoice, LidarInput, Overrides, ServiceConfig};
use crate::inputs::Inputs;
use crate::outputs::Outputs;
use crate::persist::PersistArgs;
use crate::service::{Pace, Service};
use fastslam_protocol::cli;
use fastslam_protocol::ipc::Ipc;
use std::path::PathBuf;
use std::time::Duration;

/// What `--help` says about this process.
pub const ABOUT: &str = "FastSLAM service: subscribes to odometry and to landmark observations or \
raw lidar scans (poles are extracted from them), runs FastSLAM in stamp order, and publishes the \
pose estimate after every observation, the best particle's landmark map and occupancy grid, and \
the filter's status.";

/// Flags of the service (they override the config file).
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack to join.
    #[command(flatten)]
    pub stack: cli::StackArgs,
    /// Config file (TOML): `[filter]`, `[optimizer]`, `[moves]`, `[output]`. Default: built-in
    /// defaults.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Number of particles.
    #[arg(long)]
    pub particles: Option<usize>,
    /// Seed of the filter's random draws.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Optimiser, proposal and move correction.
    #[command(flatten)]
    pub choice: EstimatorChoice,
    /// Lidar input: auto (whichever of `scan` and `observations` is published), scan or
    /// observations.
    #[arg(long, value_enum)]
    pub lidar: Option<LidarInput>,
    /// Wait for this many subscribers of the pose before starting, so a client that
    /// starts late loses nothing.
    #[arg(long, default_value_t = 0)]
    pub wait_subscribers: usize,
    /// Give up waiting for publishers of the inputs, or for subscribers, after this many
    /// seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
    /// The sensors publish as fast as the stack takes their samples (a launcher's run
    /// without `--realtime`): a full input queue stops the service taking that stream
    /// instead of dropping its oldest input, and no sensor deadline applies. Default:
    /// real-time sensors.
    #[arg(long)]
    pub as_fast_as_possible: bool,
    /// How to wait for the inputs.
    #[command(flatten)]
    pub wait: cli::WaitArgs,
    /// Checkpoints and saved maps.
    #[command(flatten)]
    pub persist: PersistArgs,
}

impl Args {
    /// The configuration: file (or defaults), then flags on top, validated.
    ///
    /// # Errors
    /// When the file cannot be read or a value is invalid.
    pub fn config(&self) -> anyhow::Result<ServiceConfig> {
        let mut config =
            ServiceConfig::load(self.config.as_deref())?.with_overrides(&self.overrides())?;
        if let Some(lidar) = self.lidar {
            config.input.lidar = lidar;
        }
        Ok(config)
    }

    /// The flags that replace values of the config file.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            particles: self.particles,
            seed: self.seed,
            choice: self.choice.clone(),
        }
    }
}

/// Runs the service until both input streams have ended (or a signal arrives).
///
/// # Errors
/// Configuration or IPC errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = args.config()?;
    crate::memory::check(&config, crate::memory::available())?;
    let (slam, resumed) = args.persist.start(&config)?;
    let timeout = Duration::from_secs_f64(args.wait_timeout_s.max(0.0));
    if resumed.is_some() {
        // What the dead service left holds ports the resumed one needs.
        let dead = fastslam_protocol::ipc::remove_dead_nodes(&args.stack.stack())?;
        tracing::info!(dead, "removed what dead processes left");
    }
    let ipc = Ipc::open(&args.stack.stack(), "fastslam-service", timeout)?
        .busy_polling(args.wait.busy_poll)
        .spinning(args.wait.spin());
    // Publishers first, then subscribers (which wait for publishers): no wait cycles.
    let mut out = Outputs::open(&ipc)?;
    if let Some(checkpoint) = &resumed {
        out.resume(checkpoint);
    }
    let inputs = Inputs::open(&ipc, config.input.lidar)?;
    if let Some(checkpoint) = &resumed {
        // Subscribed: the sensors may now send again what the checkpoint does not hold.
        let stamp_ns = checkpoint.processed(inputs.lidar.stream());
        out.checkpointed(stamp_ns, checkpoint.covered(), true)?;
    }
    out.wait_for_subscribers(&ipc, args.wait_subscribers)?;
    tracing::info!(
        particles = config.filter.particles, optimizer = %config.optimizer.kind,
        proposal = %config.filter.proposal, moves = %config.moves.correction,
        resampling = ?config.filter_config().resampling.scheme, seed = config.filter.seed,
        lidar = ?inputs.lidar.stream(), "running"
    );

    let pace = if args.as_fast_as_possible {
        Pace::AsFastAsPossible
    } else {
        Pace::RealTime
    };
    let streams = inputs.streams();
    let (persist, resumed) = (args.persist, resumed.as_ref());
    let mut service = Service::new(pace, &streams, config, persist, slam, resumed, out);
    // The tick: a held scan's limit is checked in time even with no input waking the loop.
    let tick = Some(service.hold_limit());
    ipc.wake_loop::<anyhow::Error>(&inputs.wake_sources(), tick, || service.wake(&inputs))?;
    // Stopped by a signal or finished: the state goes to disk before anyone is told.
    service.finish(&ipc)
}
