//! Wheel odometry.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Odometry at `header.stamp_ns`: the robot's pose in the `odom` frame (what wheel
/// encoders, `nav_msgs/Odometry` or a log report), with the velocities over the interval
/// since the previous odometry message where the source knows them.
///
/// The service's motion model says what it uses:
/// - `model = "increment"` (recordings, a user's robot): the pose increment between
///   consecutive messages, `(x, y, θ)ₖ₋₁⁻¹ ⊕ (x, y, θ)ₖ`, with noise that grows with the
///   distance and angle travelled — so the publishing rate, bursts of stamps and gaps do
///   not matter; the velocities are not needed (0 when unknown).
/// - `model = "unicycle"` / `"bicycle"` (the simulations, velocity-only sources): `v` and
///   `omega` (differential drive) or `v` and `steering` (car-like; `omega` may be filled
///   with v·sin(steering)/wheelbase), held over the interval; the pose is then the
///   dead-reckoned one, for clients.
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
