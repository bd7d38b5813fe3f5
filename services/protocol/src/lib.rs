//! The wire contract of the FastSLAM stack: zero-copy message types, service names and
//! the IPC helpers every process shares.
//!
//! A publisher written by a user needs only this crate (or, from another language, the
//! type names, sizes, alignments and field offsets documented in this crate's README and
//! checked by its layout test). Every message is `#[repr(C)]`, carries a [`Header`]
//! with the simulated/sensor clock `stamp_ns` and a per-stream `seq`, and uses SI units
//! and REP-103 frames.
#![doc = include_str!("../README.md")]

pub mod cli;
pub mod grid;
pub mod header;
pub mod ipc;
pub mod landmarks;
pub mod odometry;
pub mod pose;
pub mod scan;
pub mod status;
pub mod stream;
pub mod topics;
pub mod validate;

pub use grid::OccupancyGridHeader;
pub use header::Header;
pub use landmarks::{LandmarkMapHeader, MapLandmark, MapRequest, Observation, ObservationsHeader};
pub use odometry::Odometry;
pub use pose::{GroundTruth, PoseEstimate};
pub use scan::LaserScanHeader;
pub use status::ServiceStatus;
pub use stream::{EndOfStream, StreamId};
