//! Replays the Victoria Park data set: odometry of the laser's bicycle, tree detections
//! and GPS as sparse ground truth; ends with an end-of-stream per stream.

use crate::args::ReplayArgs;
use crate::{player, victoria_park};
use std::path::PathBuf;

/// What `--help` says about this process.
pub const ABOUT: &str = "Replays the ACFR Victoria Park data set (odometry, tree detections of \
the laser, GPS as sparse ground truth) with the stack's messages, then an end-of-stream message \
per stream.";

/// Flags of the Victoria Park replay.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack, profile, pacing and start-up flags.
    #[command(flatten)]
    pub replay: ReplayArgs,
    /// Data set folder (odometry.csv, tree_observations.csv, scan_times.csv, gps.csv, each
    /// plain or .gz).
    #[arg(long, default_value = "data/victoria_park")]
    pub data: PathBuf,
}

/// Reads the data set and plays it.
///
/// # Errors
/// Data, profile or IPC errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let profile = args.replay.profile("victoria-park")?;
    let pacing = args.replay.pacing();
    let data = victoria_park::load(&args.data, &profile.sensor)?;
    let ipc = args.replay.join("replay-victoria-park")?;
    player::play(&ipc, &data, pacing, args.replay.wait_subscribers)?;
    Ok(())
}
