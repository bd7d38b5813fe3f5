//! A bag read into a data set ([`Bag`]), where its odometry came from, and the one line
//! that says what was read.

use super::StampRepairs;
use crate::dataset::DataSet;
use std::path::PathBuf;

/// Where the odometry came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OdometrySource {
    /// A `nav_msgs/msg/Odometry` topic.
    Topic(String),
    /// The transform between two frames on `/tf`.
    Tf {
        /// The odometry frame.
        odom_frame: String,
        /// The base frame.
        base_frame: String,
    },
    /// None read: the odometry is made from the scans (`--odometry laser`).
    Laser,
}

impl std::fmt::Display for OdometrySource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Topic(topic) => write!(f, "{topic}"),
            Self::Tf {
                odom_frame,
                base_frame,
            } => write!(f, "tf {odom_frame}→{base_frame}"),
            Self::Laser => write!(f, "the laser (--odometry laser)"),
        }
    }
}

/// A topic and its message count.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicCount {
    /// The topic name.
    pub name: String,
    /// Its message type.
    pub type_name: String,
    /// Its messages in the bag.
    pub count: usize,
}

/// A bag read into a data set, with what a caller reports about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Bag {
    /// The messages to publish.
    pub data: DataSet,
    /// The storage files read, in order.
    pub files: Vec<PathBuf>,
    /// The scan topic used.
    pub scan_topic: String,
    /// Its message type (`sensor_msgs/msg/LaserScan`, …).
    pub scan_type: String,
    /// Where the odometry came from.
    pub odometry: OdometrySource,
    /// The scans' frame (`header.frame_id`).
    pub laser_frame: String,
    /// The robot's base frame.
    pub base_frame: String,
    /// Whether the mounting came from tf (else it is the identity).
    pub mount_from_tf: bool,
    /// The topics not read, with their types and counts.
    pub skipped: Vec<TopicCount>,
    /// How the scans' stamps were put in order.
    pub scan_stamps: StampRepairs,
    /// How the odometry's stamps were put in order.
    pub odometry_stamps: StampRepairs,
    /// Things a user should know (no mounting found, a file without summary…).
    pub warnings: Vec<String>,
}

impl Bag {
    /// One line saying what was read.
    pub fn summary(&self) -> String {
        let m = self.data.laser_mount;
        let mount = if self.mount_from_tf {
            format!(
                "mounted at x {:.3} m, y {:.3} m, yaw {:.2}° in {}",
                m.x,
                m.y,
                m.theta.to_degrees(),
                self.base_frame
            )
        } else {
            format!("mount not in tf: at {}'s origin", self.base_frame)
        };
        let skipped = if self.skipped.is_empty() {
            "none".to_string()
        } else {
            (self.skipped.iter())
                .map(|t| format!("{} ({}, {})", t.name, t.type_name, t.count))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let odometry = match self.odometry {
            OdometrySource::Laser => String::new(),
            ref source => format!(" · {} odometry from {source}", self.data.odometry.len()),
        };
        // A plain scan goes without saying; the others say how they became scans.
        let made_from = match self.scan_type.as_str() {
            super::POINT_CLOUD => format!("{} cut to scans, ", super::POINT_CLOUD),
            super::MULTI_ECHO_LASER_SCAN => format!("{}'s first echoes, ", self.scan_type),
            _ => String::new(),
        };
        let mut line = format!(
            "{} scans from {} ({made_from}frame {}, {mount}){odometry} · epoch {:.6} s · \
             skipped: {skipped}",
            self.data.raw_scans.len(),
            self.scan_topic,
            self.laser_frame,
            self.data.epoch_s,
        );
        for (stream, repairs) in [
            ("scan", self.scan_stamps),
            ("odometry", self.odometry_stamps),
        ] {
            if !repairs.is_clean() {
                line += &format!(" · {stream} stamps: {repairs}");
            }
        }
        if !self.warnings.is_empty() {
            line += &format!(" · {} warning(s)", self.warnings.len());
        }
        line
    }
}
