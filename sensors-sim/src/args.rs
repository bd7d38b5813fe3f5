//! Flags the simulator processes share.

use crate::scenario::{DEFAULT_SCENARIO, Scenario};
use fastslam_protocol::cli::StackArgs;
use std::time::Duration;

/// Which stack, which scenario, which seed, and whom to wait for.
#[derive(Debug, Clone, clap::Args)]
pub struct SimArgs {
    /// Stack to join.
    #[command(flatten)]
    pub stack: StackArgs,
    /// Scenario: a built-in name (see `fastslam-stack scenarios`) or a TOML file.
    #[arg(long, default_value = DEFAULT_SCENARIO)]
    pub scenario: String,
    /// Seed of the simulation's noise (default: the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Wait for this many subscribers of the output before publishing, so a consumer
    /// that starts late loses nothing.
    #[arg(long, default_value_t = 1)]
    pub wait_subscribers: usize,
    /// Give up waiting for subscribers after this many seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
}

impl SimArgs {
    /// The scenario, and the seed to use (flag over file).
    ///
    /// # Errors
    /// When the scenario cannot be loaded.
    pub fn scenario(&self) -> anyhow::Result<(Scenario, u64)> {
        let scenario = Scenario::load(&self.scenario)?;
        let seed = self.seed.unwrap_or(scenario.seed);
        Ok((scenario, seed))
    }

    /// How long to wait for subscribers.
    pub fn wait_timeout(&self) -> Duration {
        Duration::from_secs_f64(self.wait_timeout_s.max(0.0))
    }
}

/// Labels that give each simulated sensor its own random stream under one seed.
pub mod streams {
    /// The odometry sensor's noise.
    pub const ODOMETRY: u64 = 1;
    /// The landmark sensor's noise.
    pub const LANDMARKS: u64 = 2;
    /// The lidar's noise and clutter.
    pub const LIDAR: u64 = 3;
}
