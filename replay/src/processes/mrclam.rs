//! Replays one robot of a UTIAS MRCLAM data set: odometry, landmark observations, Vicon
//! ground truth and the true landmark map; ends with an end-of-stream per stream. Also the
//! data set's row of the [`crate::registry`].

use crate::args::ReplayArgs;
use crate::dataset::Association;
use crate::registry::{self, DataSetKind, InProcess, Plan, Process};
use crate::{mrclam, player};
use clap::FromArgMatches;
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
    let profile = args.replay.profile(DATA_SET.profile)?;
    let pacing = args.replay.pacing();
    let options = mrclam::Options {
        robot: args.robot,
        association: args.association,
        sensor: profile.sensor,
    };
    let data = mrclam::load(&args.data, &options)?;
    let ipc = args.replay.join(PROCESS.name)?;
    player::play(&ipc, &data, pacing, args.replay.wait_subscribers)?;
    Ok(())
}

/// The MRCLAM replay process.
pub const PROCESS: Process = Process {
    name: "replay-mrclam",
    about: "The MRCLAM replay process (started by `replay mrclam`)",
    args: <Args as clap::Args>::augment_args,
    run: |matches| run(Args::from_arg_matches(matches)?),
};

/// UTIAS MRCLAM in the registry.
pub const DATA_SET: DataSetKind = DataSetKind {
    name: "mrclam",
    about: "UTIAS MRCLAM: one robot's odometry and barcode observations, scored against Vicon \
ground truth and the true landmarks",
    flags: <Flags as clap::Args>::augment_args,
    plan: |matches| Flags::from_arg_matches(matches)?.plan(),
    profile: "mrclam",
    process: &PROCESS,
    in_process: Some(InProcess {
        title: "UTIAS MRCLAM",
        default_data: "data/mrclam7",
        load: |request| {
            let options = mrclam::Options {
                robot: request.robot,
                association: request.association,
                sensor: request.profile.sensor,
            };
            Ok((
                label(request.folder, request.robot, request.association),
                request.association,
                mrclam::load(request.dir, &options)?,
            ))
        },
    }),
};

/// `replay mrclam`'s own flags.
#[derive(Debug, Clone, clap::Args)]
struct Flags {
    /// Data set folder (Barcodes.dat, Landmark_Groundtruth.dat, Robot<r>_*.dat[.gz]).
    #[arg(long, default_value = "data/mrclam7")]
    data: PathBuf,
    /// Robot number.
    #[arg(long, default_value_t = 1)]
    robot: u32,
    /// Known: barcodes as landmark ids; unknown: the service associates by itself.
    #[arg(long, value_enum, default_value_t = Association::Known)]
    association: Association,
}

impl Flags {
    /// The replay process's flags and the run folder's name.
    fn plan(self) -> anyhow::Result<Plan> {
        Ok(Plan {
            label: label(&registry::folder(&self.data)?, self.robot, self.association),
            association: self.association,
            flags: vec![
                "--data".into(),
                registry::canonical(&self.data)?,
                "--robot".into(),
                self.robot.to_string(),
                "--association".into(),
                self.association.service_mode().into(),
            ],
            recording: None,
        })
    }
}

/// A run's name for robot `robot` of the data set in `folder`.
fn label(folder: &str, robot: u32, association: Association) -> String {
    format!("{folder}-robot{robot}-{}", association.service_mode())
}
