//! The wire contract of the FastSLAM stack: zero-copy message types, service names and
//! input checks, plus the IPC helpers every process shares.
//!
//! A publisher written by a user needs only this crate with its default features (or,
//! from another language, the type names, sizes, alignments and field offsets documented
//! in this crate's README and checked by its layout test). Every message is `#[repr(C)]`,
//! carries a [`Header`] with the simulated/sensor clock `stamp_ns` and a per-stream
//! `seq`, and uses SI units and REP-103 frames.
//!
//! Cargo features (see "From Rust" below):
//! - `ipc`, on by default: the `ipc` module, the stack's publishers, subscribers, wake
//!   loop and signal handling over iceoryx2. Without it (`default-features = false`) the
//!   message types, `topics` and `validate` remain.
//! - `cli`, off by default, implies `ipc`: the `cli` module, the flags, logging and
//!   `main` of the stack's own processes (clap, tracing-subscriber).
#![doc = include_str!("../README.md")]

#[cfg(feature = "cli")]
pub mod cli;
pub mod client_notice;
pub mod grid;
pub mod header;
#[cfg(feature = "ipc")]
pub mod ipc;
pub mod landmarks;
pub mod message;
pub mod odometry;
pub mod particles;
pub mod pose;
pub mod scan;
pub mod status;
pub mod stream;
pub mod topics;
pub mod trajectory;
pub mod validate;

pub use client_notice::ClientNotice;
pub use grid::OccupancyGridHeader;
pub use header::Header;
pub use landmarks::{LandmarkMapHeader, MapLandmark, MapRequest, Observation, ObservationsHeader};
pub use odometry::Odometry;
pub use particles::{Particle, ParticlesHeader};
pub use pose::{GroundTruth, PoseEstimate};
pub use scan::LaserScanHeader;
pub use status::{Checkpointed, MAX_INPUT_STREAMS, ServiceStatus, StreamCovered, StreamStatus};
pub use stream::{EndOfStream, StreamId};
pub use trajectory::{TrajectoryHeader, TrajectoryPose};

/// The version of the wire contract: the message types' layouts and the topics' meaning.
/// It changes whenever a message type's layout does, so that peers exchanging the bytes
/// of messages between hosts (the Zenoh bridge) refuse a peer of another version instead
/// of misreading it.
pub const CONTRACT_VERSION: u32 = 2;
