//! Replays a user's own recording — a ROS 2 bag or a CARMEN log — as odometry poses and
//! raw laser scans, without ground truth; ends with an end-of-stream per stream. Also the
//! rows of both formats in the [`crate::registry`].

use crate::args::ReplayArgs;
use crate::dataset::{Association, DataSet};
use crate::laser_odometry::OdometryChoice;
use crate::player;
use crate::recording::{Loaded, Recording};
use crate::registry::{self, DataSetKind, Plan, Process};
use crate::rosbag::TopicChoice;
use clap::FromArgMatches;
use std::path::PathBuf;

/// What `--help` says about this process.
pub const ABOUT: &str = "Replays a recording (a rosbag2 bag, MCAP or sqlite3, a ROS 1 bag, \
or a CARMEN log) with the stack's messages: the laser's scans and the odometry's poses, then an \
end-of-stream message per stream. No ground truth.";

/// Which recording, and the bag's topics and frames.
#[derive(Debug, Clone, clap::Args)]
#[group(required = true, multiple = false, id = "recording")]
pub struct Source {
    /// A rosbag2 folder (with metadata.yaml), one .mcap / .db3 file, or a ROS 1 .bag file
    /// (or a folder of the .bag files of one split recording).
    #[arg(long, group = "recording")]
    pub rosbag: Option<PathBuf>,
    /// A CARMEN log (.clf / .log, gzipped or not).
    #[arg(long, group = "recording")]
    pub carmen: Option<PathBuf>,
}

/// The bag's topics and frames, where it leaves a choice.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct TopicArgs {
    /// The `sensor_msgs/msg/LaserScan` or `MultiEchoLaserScan` topic (default: the bag's
    /// only one; a multi-echo beam reads its first echo), or a 3D lidar's
    /// `sensor_msgs/msg/PointCloud2` topic, cut to a scan (points within 0.2 m of the
    /// sensor's plane, 720 beams).
    #[arg(long)]
    pub scan_topic: Option<String>,
    /// The `nav_msgs/msg/Odometry` topic (default: the bag's only one; without any, the
    /// odometry comes from `/tf`).
    #[arg(long)]
    pub odom_topic: Option<String>,
    /// The odometry frame of the tf odometry (default `odom`).
    #[arg(long)]
    pub odom_frame: Option<String>,
    /// The robot's base frame: the pose estimated and where the laser's mounting is
    /// measured from (default: the odometry's child frame, else `base_link`).
    #[arg(long)]
    pub base_frame: Option<String>,
    /// Where the odometry comes from: the bag's own, or the laser (each scan matched
    /// against the scans before it; the bag's odometry is not read).
    #[command(flatten)]
    pub odometry: OdometryArgs,
}

/// Where the odometry comes from, for a bag and a log alike.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct OdometryArgs {
    /// Where the odometry comes from: `recorded` (the recording's own: an Odometry topic or
    /// tf, a log's ODOM lines) or `laser` (each scan matched against the local map of the
    /// scans before it, for a recording without wheel odometry or with odometry not to be
    /// trusted; the recording's own is then not read).
    #[arg(long, value_enum, default_value_t = OdometryChoice::Recorded)]
    pub odometry: OdometryChoice,
}

impl OdometryArgs {
    /// The flags that give this choice to a replay process.
    pub fn flags(&self) -> Vec<String> {
        match self.odometry {
            OdometryChoice::Recorded => Vec::new(),
            OdometryChoice::Laser => vec!["--odometry".into(), "laser".into()],
        }
    }
}

impl TopicArgs {
    /// The reader's topic choice.
    pub fn choice(&self) -> TopicChoice {
        TopicChoice {
            scan_topic: self.scan_topic.clone(),
            odom_topic: self.odom_topic.clone(),
            odom_frame: self.odom_frame.clone(),
            base_frame: self.base_frame.clone(),
            odometry: self.odometry.odometry,
        }
    }

    /// The flags that give this choice to a replay process.
    pub fn flags(&self) -> Vec<String> {
        [
            ("--scan-topic", &self.scan_topic),
            ("--odom-topic", &self.odom_topic),
            ("--odom-frame", &self.odom_frame),
            ("--base-frame", &self.base_frame),
        ]
        .into_iter()
        .filter_map(|(flag, value)| value.as_ref().map(|v| [flag.to_string(), v.clone()]))
        .flatten()
        .chain(self.odometry.flags())
        .collect()
    }
}

/// Flags of the recording replay.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack, profile, pacing and start-up flags.
    #[command(flatten)]
    pub replay: ReplayArgs,
    /// The recording.
    #[command(flatten)]
    pub source: Source,
    /// Topics and frames of a bag.
    #[command(flatten)]
    pub topics: TopicArgs,
}

impl Args {
    /// The recording these flags name.
    pub fn recording(&self) -> Recording {
        recording(&self.source, &self.topics)
    }
}

/// The recording `source` names, with `topics` for a bag.
fn recording(source: &Source, topics: &TopicArgs) -> Recording {
    match (&source.rosbag, &source.carmen) {
        (Some(path), _) => Recording::Rosbag {
            path: path.clone(),
            topics: topics.choice(),
        },
        (None, Some(path)) => Recording::Carmen {
            path: path.clone(),
            odometry: topics.odometry.odometry,
        },
        (None, None) => unreachable!("clap requires one of --rosbag and --carmen"),
    }
}

/// Reads the recording and plays it.
///
/// # Errors
/// Data or IPC errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let pacing = args.replay.pacing();
    let recording = args.recording();
    let Loaded {
        mut data,
        mut summary,
        mut warnings,
    } = recording.read()?;
    let ipc = args.replay.join(PROCESS.name)?;
    let finish = |data: &mut DataSet| {
        recording.finish(data, &mut summary, &mut warnings);
        tracing::info!("{summary}");
        for warning in &warnings {
            tracing::warn!("{warning}");
        }
    };
    player::play_after(
        &ipc,
        &mut data,
        finish,
        pacing,
        args.replay.wait_subscribers,
    )?;
    Ok(())
}

/// The recording replay process, for a bag and a log alike.
pub const PROCESS: Process = Process {
    name: "replay-recording",
    about: "The recording replay process (started by `replay rosbag` and `replay carmen`)",
    args: <Args as clap::Args>::augment_args,
    run: |matches| run(Args::from_arg_matches(matches)?),
};

/// A user's ROS 2 bag in the registry.
pub const ROSBAG: DataSetKind = DataSetKind {
    name: "rosbag",
    about: "Your own bag (rosbag2: MCAP or sqlite3; or a ROS 1 .bag): its laser scans and \
odometry, the laser's mounting from /tf_static; no ground truth needed (docs/REPLAYS.md)",
    flags: <RosbagFlags as clap::Args>::augment_args,
    plan: |matches| RosbagFlags::from_arg_matches(matches)?.plan(),
    profile: "planar-laser",
    process: &PROCESS,
    in_process: None,
};

/// A CARMEN log in the registry.
pub const CARMEN: DataSetKind = DataSetKind {
    name: "carmen",
    about: "A CARMEN log (.clf / .log, gzipped or not: FLASER, ROBOTLASER1, ODOM), such as the \
Freiburg benchmark's; no ground truth needed (docs/REPLAYS.md)",
    flags: <CarmenFlags as clap::Args>::augment_args,
    plan: |matches| CarmenFlags::from_arg_matches(matches)?.plan(),
    profile: "planar-laser",
    process: &PROCESS,
    in_process: None,
};

/// `replay rosbag`'s own flags.
#[derive(Debug, Clone, clap::Args)]
struct RosbagFlags {
    /// A rosbag2 folder (with metadata.yaml), one .mcap / .db3 file, or a ROS 1 .bag file
    /// (or a folder of the .bag files of one split recording).
    path: PathBuf,
    /// Topics and frames, where the bag leaves a choice.
    #[command(flatten)]
    topics: TopicArgs,
}

impl RosbagFlags {
    /// The replay process's flags, the run folder's name and the bag.
    fn plan(self) -> anyhow::Result<Plan> {
        let mut flags = vec!["--rosbag".into(), registry::canonical(&self.path)?];
        flags.extend(self.topics.flags());
        Ok(Plan {
            label: registry::stem(&self.path),
            association: Association::Unknown,
            flags,
            recording: Some(Recording::Rosbag {
                topics: self.topics.choice(),
                path: self.path,
            }),
        })
    }
}

/// `replay carmen`'s own flags.
#[derive(Debug, Clone, clap::Args)]
struct CarmenFlags {
    /// The log file.
    file: PathBuf,
    /// Where the odometry comes from.
    #[command(flatten)]
    odometry: OdometryArgs,
}

impl CarmenFlags {
    /// The replay process's flags, the run folder's name and the log.
    fn plan(self) -> anyhow::Result<Plan> {
        Ok(Plan {
            label: registry::stem(&self.file),
            association: Association::Unknown,
            flags: [
                vec!["--carmen".into(), registry::canonical(&self.file)?],
                self.odometry.flags(),
            ]
            .concat(),
            recording: Some(Recording::Carmen {
                path: self.file,
                odometry: self.odometry.odometry,
            }),
        })
    }
}
