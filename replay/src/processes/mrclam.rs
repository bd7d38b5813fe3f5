//! Replays one robot of a UTIAS MRCLAM data set: odometry, landmark observations, Vicon
//! ground truth and the true landmark map; ends with an end-of-stream per stream.

use crate::args::ReplayArgs;
use crate::dataset::Association;
use crate::{mrclam, player};
use std::path::PathBuf;

/// What `--help` says about this process.
pub const ABOUT: &str = "Replays one robot of a UTIAS MRCLAM data set (odometry, barcode \
landmark observations, Vicon ground truth, true landmarks) with the stack's messages, then an \
end-of-stream message per stream.";

/// Flags of the MRCLAM replay.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack, profile, pacing and start-up flags.
    #[command(flatten)]
    pub replay: ReplayArgs,
    /// Data set folder (Barcodes.dat, Landmark_Groundtruth.dat, `Robot<r>_*.dat[.gz]`).
    #[arg(long, default_value = "data/mrclam7")]
    pub data: PathBuf,
    /// Robot number.
    #[arg(long, default_value_t = 1)]
    pub robot: u32,
    /// Known: observations carry the landmark's subject number; unknown: id −1.
    #[arg(long, value_enum, default_value_t = Association::Known)]
    pub association: Association,
}

/// Reads the data set and plays it.
///
/// # Errors
/// Data, profile or IPC errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let profile = args.replay.profile("mrclam")?;
    let pacing = args.replay.pacing();
    let options = mrclam::Options {
        robot: args.robot,
        association: args.association,
        sensor: profile.sensor,
    };
    let data = mrclam::load(&args.data, &options)?;
    let ipc = args.replay.join("replay-mrclam")?;
    player::play(&ipc, &data, pacing, args.replay.wait_subscribers)?;
    Ok(())
}
