//! The header every message starts with.

use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Stamp and sequence number of a message.
///
/// `stamp_ns` is the sensor (or simulated) clock in nanoseconds, never the wall clock of
/// the receiving process; `seq` counts the messages of one stream from 0 and lets a
/// receiver detect gaps and duplicates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
pub struct Header {
    /// Time the data refers to (ns).
    pub stamp_ns: u64,
    /// Position of the message in its stream, from 0.
    pub seq: u64,
}

impl Header {
    /// The stamp in seconds.
    pub fn stamp_s(&self) -> f64 {
        self.stamp_ns as f64 * 1e-9
    }
}

/// Converts seconds to a nanosecond stamp, rounding to the nearest nanosecond.
pub fn stamp_from_secs(t: f64) -> u64 {
    (t * 1e9).round() as u64
}
