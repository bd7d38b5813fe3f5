//! Wheel odometry.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Odometry over the interval that ends at `header.stamp_ns` and started at the previous
/// odometry message's stamp (like a wheel-encoder report).
///
/// A differential-drive robot fills `v` and `omega`; a car-like (bicycle) vehicle fills
/// `v` and `steering` (and may fill `omega` = v·sin(steering)/wheelbase). The service's
/// motion model says which it uses. `x`, `y`, `theta` are the dead-reckoned pose in the
/// `odom` frame, for clients; the filter does not use them.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::Odometry")]
#[repr(C)]
pub struct Odometry {
    /// Stamp at the end of the interval, and sequence number.
    pub header: Header,
    /// Measured forward speed (m/s).
    pub v: f64,
    /// Measured yaw rate (rad/s).
    pub omega: f64,
    /// Measured steering angle (rad).
    pub steering: f64,
    /// Dead-reckoned x in the `odom` frame (m).
    pub x: f64,
    /// Dead-reckoned y in the `odom` frame (m).
    pub y: f64,
    /// Dead-reckoned heading in the `odom` frame (rad).
    pub theta: f64,
}
