//! Replays the Victoria Park data set: odometry of the laser's bicycle, tree detections
//! and GPS as sparse ground truth; ends with an end-of-stream per stream. Also the data
//! set's row of the [`crate::registry`].

use crate::args::ReplayArgs;
use crate::dataset::Association;
use crate::registry::{self, DataSetKind, InProcess, Plan, Process};
use crate::{player, victoria_park};
use clap::FromArgMatches;
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
    let profile = args.replay.profile(DATA_SET.profile)?;
    let pacing = args.replay.pacing();
    let data = victoria_park::load(&args.data, &profile.sensor)?;
    let ipc = args.replay.join(PROCESS.name)?;
    player::play(&ipc, &data, pacing, args.replay.wait_subscribers)?;
    Ok(())
}

/// The Victoria Park replay process.
pub const PROCESS: Process = Process {
    name: "replay-victoria-park",
    about: "The Victoria Park replay process (started by `replay victoria-park`)",
    args: <Args as clap::Args>::augment_args,
    run: |matches| run(Args::from_arg_matches(matches)?),
};

/// ACFR Victoria Park in the registry.
pub const DATA_SET: DataSetKind = DataSetKind {
    name: "victoria-park",
    about: "ACFR Victoria Park: odometry and tree detections, GPS as sparse ground truth \
(unknown association)",
    flags: <Flags as clap::Args>::augment_args,
    plan: |matches| Flags::from_arg_matches(matches)?.plan(),
    profile: "victoria-park",
    process: &PROCESS,
    in_process: Some(InProcess {
        title: "ACFR Victoria Park",
        default_data: "data/victoria_park",
        load: |request| {
            Ok((
                request.folder.to_string(),
                Association::Unknown,
                victoria_park::load(request.dir, &request.profile.sensor)?,
            ))
        },
    }),
};

/// `replay victoria-park`'s own flags.
#[derive(Debug, Clone, clap::Args)]
struct Flags {
    /// Data set folder (odometry.csv, tree_observations.csv, scan_times.csv, gps.csv,
    /// each plain or .gz).
    #[arg(long, default_value = "data/victoria_park")]
    data: PathBuf,
}

impl Flags {
    /// The replay process's flags and the run folder's name.
    fn plan(self) -> anyhow::Result<Plan> {
        Ok(Plan {
            label: registry::folder(&self.data)?,
            association: Association::Unknown,
            flags: vec!["--data".into(), registry::canonical(&self.data)?],
            recording: None,
        })
    }
}
