//! Odometry made from a recording's scans (`--odometry laser`): each scan matched against
//! the local map of the scans before it ([`fastslam_estimation::laser_odometry`]), one
//! odometry message per scan at the scan's stamp. For a recording without wheel odometry,
//! or with odometry not to be trusted.

use crate::dataset::{self, DataSet};
use fastslam_estimation::Pose2;
use fastslam_estimation::laser_odometry::{LaserOdometry, LaserOdometryConfig, TrackingCounts};
use fastslam_estimation::scan::RangeScan;
use fastslam_protocol::{Header, Odometry};

/// Where the odometry the filter predicts with comes from (`--odometry`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum OdometryChoice {
    /// The recording's own: a bag's `nav_msgs/msg/Odometry` topic or tf, a log's `ODOM`
    /// lines.
    #[default]
    Recorded,
    /// Made from the scans: each matched against the local map of the scans before it
    /// ([`crate::laser_odometry`]). For a recording without wheel odometry (a hand-held
    /// laser), or whose odometry is not to be trusted; the recording's own is not read.
    Laser,
}

/// The odometry of `data`'s scans (their stamps, the laser at `data.laser_mount`), beams
/// used up to `max_range` (m), and how many scans matched.
pub fn from_scans(data: &DataSet, max_range: f64) -> (Vec<Odometry>, TrackingCounts) {
    let config = LaserOdometryConfig {
        max_range,
        ..LaserOdometryConfig::default()
    };
    let mut tracker = LaserOdometry::new(config, data.laser_mount);
    let mut odometry: Vec<Odometry> = Vec::with_capacity(data.raw_scans.len());
    for scan in &data.raw_scans {
        let h = &scan.header;
        let stamp_ns = h.header.stamp_ns;
        let range_scan = RangeScan {
            angle_min: h.angle_min.into(),
            angle_increment: h.angle_increment.into(),
            range_min: h.range_min.into(),
            range_max: h.range_max.into(),
            ranges: h.ranges_of(&scan.items),
        };
        let pose = tracker.track(stamp_ns as f64 * 1e-9, &range_scan);
        let (v, omega) = (odometry.last()).map_or((0.0, 0.0), |last| {
            let from = Pose2 {
                x: last.x,
                y: last.y,
                theta: last.theta,
            };
            dataset::rates(last.header.stamp_ns, &from, stamp_ns, &pose)
        });
        odometry.push(Odometry {
            header: Header {
                stamp_ns,
                seq: odometry.len() as u64,
            },
            v,
            omega,
            steering: 0.0,
            x: pose.x,
            y: pose.y,
            theta: pose.theta,
        });
    }
    (odometry, tracker.counts())
}
