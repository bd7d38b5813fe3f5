//! Flags every replay process shares: which stack, which profile, how fast, whom to wait
//! for.

use crate::player::Pacing;
use crate::profile::Profile;
use fastslam_protocol::cli::{PaceArgs, StackArgs};
use fastslam_protocol::ipc::Ipc;
use std::time::Duration;

/// Stack, profile, pacing and start-up flags of a replay process.
#[derive(Debug, Clone, clap::Args)]
pub struct ReplayArgs {
    /// Stack to join.
    #[command(flatten)]
    pub stack: StackArgs,
    /// Profile: a built-in name (mrclam, victoria-park) or a TOML file. Default: the data
    /// set's own.
    #[arg(long)]
    pub profile: Option<String>,
    /// Real time (at a rate) or as fast as possible.
    #[command(flatten)]
    pub pace: PaceArgs,
    /// Start once this many processes take the sensor streams (the service alone: 1; the
    /// service and the client: 2), so a consumer that starts late loses nothing.
    #[arg(long, default_value_t = 1)]
    pub wait_subscribers: usize,
    /// Give up waiting for subscribers after this many seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
}

impl ReplayArgs {
    /// The profile: `--profile`, else the built-in `default`.
    ///
    /// # Errors
    /// When the profile cannot be loaded.
    pub fn profile(&self, default: &str) -> anyhow::Result<Profile> {
        Ok(Profile::load(self.profile.as_deref().unwrap_or(default))?)
    }

    /// The pacing the flags ask for.
    pub fn pacing(&self) -> Pacing {
        if self.pace.realtime {
            Pacing::RealTime {
                rate: self.pace.rate,
            }
        } else {
            Pacing::AsFastAsPossible
        }
    }

    /// Joins the stack as node `name`.
    ///
    /// # Errors
    /// IPC errors.
    pub fn join(&self, name: &str) -> anyhow::Result<Ipc> {
        let timeout = Duration::from_secs_f64(self.wait_timeout_s.max(0.0));
        Ok(Ipc::open(&self.stack.stack(), name, timeout)?)
    }
}
