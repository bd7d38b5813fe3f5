//! Raw 2D lidar scans, shaped like ROS 2's `sensor_msgs/LaserScan`: a fixed header plus
//! one slice of `f32`. An iceoryx2 service carries a single slice, so the slice holds the
//! `ranges` first and then, when the sensor reports them, one intensity per range; the
//! header says how many of each there are.
//!
//! Conventions (REP-103, REP-117): beam `i` points at `angle_min + i · angle_increment`
//! (rad, counter-clockwise, 0 = forward = the vehicle's +x; the scanner sits at the
//! vehicle's origin). A range of `+∞` means no return, `−∞` too close, NaN an invalid
//! measurement; a finite range outside `[range_min, range_max]` is discarded as well.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Header of one scan; the slice holds `ranges` ranges (m) then `intensities`
/// intensities (sensor units), all `f32`.
///
/// `header.stamp_ns` is the time of the first beam; beam `i` was measured
/// `i · time_increment` seconds later (0 when the scan is treated as instantaneous).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::LaserScanHeader")]
#[repr(C)]
pub struct LaserScanHeader {
    /// Stamp of the first beam, and sequence number.
    pub header: Header,
    /// Direction of the first beam (rad, 0 = forward, counter-clockwise positive).
    pub angle_min: f32,
    /// Angle between consecutive beams (rad), > 0: beams sweep counter-clockwise.
    pub angle_increment: f32,
    /// Time between consecutive beams (s); 0 for an instantaneous scan.
    pub time_increment: f32,
    /// Time between two scans (s).
    pub scan_time: f32,
    /// Shortest range the sensor measures (m).
    pub range_min: f32,
    /// Longest range the sensor measures (m).
    pub range_max: f32,
    /// Number of ranges at the start of the slice (beams), ≥ 1.
    pub ranges: u32,
    /// Number of intensities after the ranges: 0 (none) or equal to `ranges`.
    pub intensities: u32,
}

impl LaserScanHeader {
    /// Direction of the last beam (rad): `angle_min + (ranges − 1) · angle_increment`.
    pub fn angle_max(&self) -> f64 {
        f64::from(self.angle_min)
            + f64::from(self.ranges.saturating_sub(1)) * f64::from(self.angle_increment)
    }

    /// The ranges part of a scan's slice (shorter if the slice is, so never panics;
    /// validate first with [`crate::validate::laser_scan`]).
    pub fn ranges_of<'a>(&self, data: &'a [f32]) -> &'a [f32] {
        &data[..(self.ranges as usize).min(data.len())]
    }

    /// The intensities part of a scan's slice (empty when the sensor sends none).
    pub fn intensities_of<'a>(&self, data: &'a [f32]) -> &'a [f32] {
        let start = (self.ranges as usize).min(data.len());
        let end = start
            .saturating_add(self.intensities as usize)
            .min(data.len());
        &data[start..end]
    }
}
