//! Trajectories (service → clients): the smoothing back-end's solution, a fixed user
//! header plus a slice of poses.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Header of a trajectory; the slice holds [`TrajectoryPose`]s in time order.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::TrajectoryHeader")]
#[repr(C)]
pub struct TrajectoryHeader {
    /// Stamp of the newest data the solution used, and sequence number.
    pub header: Header,
    /// Number of poses in the slice (must equal the slice length).
    pub count: u32,
    /// Solves the back-end has run, this one included.
    pub solves: u32,
    /// χ² per degree of freedom at the solution (about 1 when the noise model and the
    /// associations are right).
    pub chi2_per_dof: f64,
}

/// One pose of a trajectory (frame `map`).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::TrajectoryPose")]
#[repr(C)]
pub struct TrajectoryPose {
    /// Stamp of the pose (ns).
    pub stamp_ns: u64,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad).
    pub theta: f64,
}
