//! The service's account of itself: filter health, timing and input bookkeeping, for
//! monitoring and metrics. Clients judge accuracy from poses and ground truth, never from
//! this message; it says how the filter is doing, not how well.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Number of rejection counters in [`ServiceStatus::rejections`].
pub const REJECTION_KINDS: usize = 16;

/// Why an input was rejected; the index into [`ServiceStatus::rejections`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum RejectionKind {
    /// A number is NaN or infinite.
    NonFinite = 0,
    /// A value is outside its allowed range (negative or over-range range, …).
    OutOfRange = 1,
    /// The header's count disagrees with the payload, or exceeds the limit.
    BadCount = 2,
    /// The stamp goes back before the stream's previous one.
    StampBackwards = 3,
    /// The filter refused the input (degenerate weights, a control it cannot apply).
    Filter = 4,
    /// The sequence number repeats.
    Duplicate = 5,
    /// The stamp jumps too far ahead of the stream's previous one.
    StampJump = 6,
    /// Odometry with an implausible speed, yaw rate or pose step.
    Teleport = 7,
    /// A queue was full: its oldest input was dropped to keep memory bounded.
    Overflow = 8,
    /// The input arrived after the other stream had been released past its stamp
    /// (possible only while a stream was quiet beyond its deadline).
    Late = 9,
    /// Sent while the service was down and no longer kept by its sensor when the resumed
    /// service asked for it (the sensor's history bound).
    Lost = 10,
}

impl RejectionKind {
    /// Every kind, in index order.
    pub const ALL: [Self; 11] = [
        Self::NonFinite,
        Self::OutOfRange,
        Self::BadCount,
        Self::StampBackwards,
        Self::Filter,
        Self::Duplicate,
        Self::StampJump,
        Self::Teleport,
        Self::Overflow,
        Self::Late,
        Self::Lost,
    ];

    /// A short snake_case name, for logs and metrics.
    pub fn name(self) -> &'static str {
        match self {
            Self::NonFinite => "non_finite",
            Self::OutOfRange => "out_of_range",
            Self::BadCount => "bad_count",
            Self::StampBackwards => "stamp_backwards",
            Self::Filter => "filter",
            Self::Duplicate => "duplicate",
            Self::StampJump => "stamp_jump",
            Self::Teleport => "teleport",
            Self::Overflow => "overflow",
            Self::Late => "late",
            Self::Lost => "lost",
        }
    }
}

/// Bit flags of [`ServiceStatus::flags`].
pub mod flags {
    /// The last observation step resampled the particles.
    pub const RESAMPLED: u32 = 1;
    /// An input stream is quiet beyond its deadline: the service runs on what it has.
    pub const DEGRADED: u32 = 2;
    /// The odometry stream is quiet beyond its deadline (scans are processed without
    /// prediction).
    pub const ODOMETRY_QUIET: u32 = 4;
    /// The lidar stream is quiet beyond its deadline (odometry keeps predicting).
    pub const LIDAR_QUIET: u32 = 8;
    /// The service's last status, sent at shutdown just before its end-of-stream: not
    /// an observation step (the step's fields repeat the last step's), but the final
    /// counters, landmark count, queues and stamps.
    pub const FINAL: u32 = 16;
    /// The noise check: the innovations' NIS has been above its χ² band for a whole
    /// window of scans — the noise model is too small for this data.
    pub const NIS_HIGH: u32 = 32;
    /// With [`NIS_HIGH`]: the pose term dominates the innovation covariance, so the
    /// odometry noise (`sigma_v`, `sigma_omega`) is the likelier culprit; without it, the
    /// sensor's (`sigma_range`, `sigma_bearing`).
    pub const NIS_POSE: u32 = 64;
}

/// Published by the service after every observation step, and whenever an input stream
/// goes quiet or comes back (then `steps` and the filter fields repeat the last step's).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::ServiceStatus")]
#[repr(C)]
pub struct ServiceStatus {
    /// Stamp of the last observation step, and sequence number.
    pub header: Header,
    /// Observation steps done.
    pub steps: u64,
    /// Times the particles were resampled.
    pub resamplings: u64,
    /// Effective sample size of the last step, before resampling (1..N).
    pub n_eff: f64,
    /// Number of particles.
    pub particles: u32,
    /// Distinct particles after the last step (N when it did not resample).
    pub distinct_particles: u32,
    /// Landmarks in the best particle's map.
    pub landmarks: u64,
    /// Wall-clock time of the last observation step's filter update, sending its pose
    /// included (ns). The pose goes out before the maps are updated, so it is seen
    /// earlier than this.
    pub step_time_ns: u64,
    /// Inputs waiting in the service's queues (odometry, observations).
    pub queued: [u32; 2],
    /// Newest accepted stamp per input stream (odometry, observations), ns.
    pub last_input_ns: [u64; 2],
    /// Bit set of [`flags`].
    pub flags: u32,
    /// Degrees of freedom of the noise check's window (2 per matched observation).
    pub nis_dof: u32,
    /// Rejected inputs so far, indexed by [`RejectionKind`].
    pub rejections: [u64; REJECTION_KINDS],
    /// The noise check: normalised innovation squared per degree of freedom over the
    /// last scans (1 when the noise model fits; NaN before any match).
    pub nis: f64,
}

/// What the service's last checkpoint covers, published on
/// [`crate::topics::CHECKPOINT`] each time it writes one: a service resumed from that
/// checkpoint skips every input stamped at or before `covered_ns` of its stream, so a
/// sensor may forget what it sent up to there. A sensor keeps what it sent since; a
/// service resumed after a crash asks for it with `resume` set.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::Checkpointed")]
#[repr(C)]
pub struct Checkpointed {
    /// Stamp of the last observation step the checkpoint holds, and sequence number.
    pub header: Header,
    /// Stamp of the last input the checkpoint holds per stream (odometry, lidar), ns.
    pub covered_ns: [u64; 2],
    /// 1: sent once by a service that has just resumed from this checkpoint and
    /// subscribed to its inputs: send again everything after `covered_ns`, then go on.
    /// 0: a checkpoint was written.
    pub resume: u32,
    /// Reserved, 0.
    pub reserved: u32,
}
