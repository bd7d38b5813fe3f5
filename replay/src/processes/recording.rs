//! Replays a user's own recording — a ROS 2 bag or a CARMEN log — as odometry poses and
//! raw laser scans, without ground truth; ends with an end-of-stream per stream.

use crate::args::ReplayArgs;
use crate::player;
use crate::recording::Recording;
use crate::rosbag::TopicChoice;
use std::path::PathBuf;

/// What `--help` says about this process.
pub const ABOUT: &str = "Replays a recording (a rosbag2 bag, MCAP or sqlite3, or a CARMEN \
log) with the stack's messages: the laser's scans and the odometry's poses, then an \
end-of-stream message per stream. No ground truth.";

/// Which recording, and the bag's topics and frames.
#[derive(Debug, Clone, clap::Args)]
#[group(required = true, multiple = false, id = "recording")]
pub struct Source {
    /// A rosbag2 folder (with metadata.yaml) or one .mcap / .db3 file.
    #[arg(long, group = "recording")]
    pub rosbag: Option<PathBuf>,
    /// A CARMEN log (.clf / .log, gzipped or not).
    #[arg(long, group = "recording")]
    pub carmen: Option<PathBuf>,
}

/// The bag's topics and frames, where it leaves a choice.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct TopicArgs {
    /// The `sensor_msgs/msg/LaserScan` topic (default: the bag's only one).
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
}

impl TopicArgs {
    /// The reader's topic choice.
    pub fn choice(&self) -> TopicChoice {
        TopicChoice {
            scan_topic: self.scan_topic.clone(),
            odom_topic: self.odom_topic.clone(),
            odom_frame: self.odom_frame.clone(),
            base_frame: self.base_frame.clone(),
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
pub fn recording(source: &Source, topics: &TopicArgs) -> Recording {
    match (&source.rosbag, &source.carmen) {
        (Some(path), _) => Recording::Rosbag {
            path: path.clone(),
            topics: topics.choice(),
        },
        (None, Some(path)) => Recording::Carmen { path: path.clone() },
        (None, None) => unreachable!("clap requires one of --rosbag and --carmen"),
    }
}

/// Reads the recording and plays it.
///
/// # Errors
/// Data or IPC errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let pacing = args.replay.pacing();
    let loaded = args.recording().load()?;
    tracing::info!("{}", loaded.summary);
    for warning in &loaded.warnings {
        tracing::warn!("{warning}");
    }
    let ipc = args.replay.join("replay-recording")?;
    player::play(&ipc, &loaded.data, pacing, args.replay.wait_subscribers)?;
    Ok(())
}
