//! Checks every receiver applies before it uses a message: a bad message is reported
//! with its reason and skipped, never allowed to crash the receiver or poison the filter.

mod message;
mod sequence;

pub use message::{
    ground_truth, known_ids, landmark_map, laser_scan, observations, occupancy_grid, odometry,
    particles, trajectory,
};
pub use sequence::{Continuity, MotionLimits, StampOrder, StreamCheck, odometry_motion};

/// Most observations one message may carry.
pub const MAX_OBSERVATIONS: usize = 4096;
/// Most landmarks one map message may carry.
pub const MAX_MAP_LANDMARKS: usize = 1 << 20;
/// Most beams one scan may carry.
pub const MAX_SCAN_BEAMS: usize = 1 << 16;
/// Most poses one trajectory message may carry (a day at 10 Hz).
pub const MAX_TRAJECTORY_POSES: usize = 1 << 20;
/// Most particles one particle cloud may carry.
pub const MAX_PARTICLES: usize = 1 << 20;
/// Most cells one occupancy grid may carry (a 1 km square at 0.25 m).
pub const MAX_GRID_CELLS: usize = 1 << 24;

/// Why a message was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Rejection {
    /// A field that must be a finite number is NaN or infinite.
    #[error("non-finite `{field}`")]
    NonFinite {
        /// The field's name.
        field: &'static str,
    },
    /// A value is outside its allowed range.
    #[error("`{field}` = {value} out of range: {reason}")]
    OutOfRange {
        /// The field's name.
        field: &'static str,
        /// The rejected value.
        value: f64,
        /// The allowed range, in words.
        reason: &'static str,
    },
    /// The header's count disagrees with the slice length, or exceeds the limit.
    #[error("header count {count} but {len} items (limit {limit})")]
    BadCount {
        /// Count the header claims.
        count: u64,
        /// Items actually in the slice.
        len: usize,
        /// The limit for this message type.
        limit: usize,
    },
    /// A count in the header is outside what the message type allows (a scan of no
    /// beams, or of more than [`MAX_SCAN_BEAMS`]).
    #[error("header `{field}` = {count}: must be {min} to {max}")]
    CountOutOfRange {
        /// The count's field.
        field: &'static str,
        /// The count the header claims.
        count: u64,
        /// The fewest allowed.
        min: usize,
        /// The most allowed.
        max: usize,
    },
    /// An observation's landmark id cannot be one under known association: negative
    /// (−1 means "unknown") or beyond [`MAX_MAP_LANDMARKS`].
    #[error("landmark id {id}: known association needs ids 0 to {max}")]
    BadLandmarkId {
        /// The rejected id.
        id: i64,
        /// The largest id allowed.
        max: usize,
    },
    /// The stamp is older than the stream's previous message.
    #[error("stamp {stamp_ns} ns goes back before {previous_ns} ns")]
    StampBackwards {
        /// This message's stamp.
        stamp_ns: u64,
        /// The previous message's stamp.
        previous_ns: u64,
    },
    /// The sequence number repeats (or goes back without the stamp advancing, which a
    /// restarted publisher would do).
    #[error("seq {seq} already seen (newest {newest})")]
    Duplicate {
        /// This message's sequence number.
        seq: u64,
        /// The newest sequence number accepted on the stream.
        newest: u64,
    },
    /// The stamp jumps further ahead of the stream's previous stamp than allowed.
    #[error("stamp {stamp_ns} ns jumps more than {max_ns} ns past {previous_ns} ns")]
    StampJump {
        /// This message's stamp.
        stamp_ns: u64,
        /// The previous message's stamp.
        previous_ns: u64,
        /// The largest allowed step.
        max_ns: u64,
    },
    /// Odometry implies a motion no vehicle makes: a speed or yaw rate over its limit, or
    /// a dead-reckoned pose that jumps further than the speed limit allows.
    #[error("odometry `{field}` = {value} beyond the plausible {limit}")]
    Teleport {
        /// The implausible quantity.
        field: &'static str,
        /// Its value (m/s, rad/s or m).
        value: f64,
        /// The limit it broke.
        limit: f64,
    },
}

impl Rejection {
    /// The counter this rejection belongs to in [`crate::ServiceStatus::rejections`].
    pub fn kind(&self) -> crate::status::RejectionKind {
        use crate::status::RejectionKind as K;
        match self {
            Self::NonFinite { .. } => K::NonFinite,
            Self::OutOfRange { .. } => K::OutOfRange,
            Self::BadCount { .. } | Self::CountOutOfRange { .. } => K::BadCount,
            Self::BadLandmarkId { .. } => K::OutOfRange,
            Self::StampBackwards { .. } => K::StampBackwards,
            Self::Duplicate { .. } => K::Duplicate,
            Self::StampJump { .. } => K::StampJump,
            Self::Teleport { .. } => K::Teleport,
        }
    }
}

fn finite(field: &'static str, v: f64) -> Result<(), Rejection> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Rejection::NonFinite { field })
    }
}

fn count(count: u32, len: usize, limit: usize) -> Result<(), Rejection> {
    if count as usize == len && len <= limit {
        Ok(())
    } else {
        Err(Rejection::BadCount {
            count: count.into(),
            len,
            limit,
        })
    }
}
