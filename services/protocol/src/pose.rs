//! Poses: the simulator's ground truth and the service's estimate.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// True vehicle state, published by the simulator (frame `map`).
///
/// Carries the true controls that moved the vehicle to this pose over the interval
/// ending at `header.stamp_ns`, so the odometry simulator can derive noisy odometry.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::GroundTruth")]
#[repr(C)]
pub struct GroundTruth {
    /// Stamp and sequence number.
    pub header: Header,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad, counter-clockwise from +x, in (−π, π]).
    pub theta: f64,
    /// Forward speed over the last interval (m/s).
    pub v: f64,
    /// Yaw rate over the last interval (rad/s).
    pub omega: f64,
    /// Steering angle over the last interval (rad; 0 for a differential-drive robot).
    pub steering: f64,
}

/// The estimated vehicle pose with its covariance (frame `map`), like
/// `geometry_msgs/PoseWithCovarianceStamped` restricted to the plane.
///
/// `header.stamp_ns` is the stamp of the observation that produced the estimate. The
/// FastSLAM service publishes its weighted particle cloud as the step weighed it, before
/// resampling: each particle contributes its component — the Gaussian FastSLAM 2.0 drew
/// its pose from, its motion prior while its pose is not yet drawn, or its pose — and the
/// estimate is the mixture's mean and covariance, `Σ wᵢ (Σᵢ + dᵢ dᵢᵀ)` with `dᵢ = μᵢ − μ`.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::PoseEstimate")]
#[repr(C)]
pub struct PoseEstimate {
    /// Stamp of the input that produced this estimate, and the estimate's sequence number.
    pub header: Header,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad, in (−π, π]).
    pub theta: f64,
    /// Covariance of (x, y, θ), row-major (m², m·rad, rad²).
    pub covariance: [f64; 9],
}
