//! What the client tells the stack's publishers: which of their messages it has recorded
//! for good (so they may forget them), and that it was started again after a crash (so
//! they send again what they kept).

use crate::header::Header;
use crate::stream::StreamId;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Slots of [`ClientNotice::recorded`]: one per [`StreamId`] wire value (slot 0 unused).
pub const NOTICE_STREAMS: usize = 12;

/// The client's word to the publishers of what it records, published on
/// [`crate::topics::CLIENT_NOTICE`] a few times a second and when it finishes.
///
/// A publisher of the stack keeps what it sent until a notice says the client recorded
/// it; when a notice's `restarts` exceeds the restarts it has answered, it sends all it
/// keeps again on its topic's resend service (`<topic>/resend`), which only a client
/// subscribes to. Once `finished` is 1 it forgets everything.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::ClientNotice")]
#[repr(C)]
pub struct ClientNotice {
    /// Stamp (the newest message recorded) and sequence number of this notice.
    pub header: Header,
    /// How many times the client recording this run was started again after it died
    /// (0: never).
    pub restarts: u64,
    /// Per stream (index: its wire value), the sequence number below which the client
    /// has recorded every message of the stream it could receive.
    pub recorded: [u64; NOTICE_STREAMS],
    /// Per stream (bit: its wire value), 1 when the client has recorded its end.
    pub ended: u64,
    /// 1 once the client has written its run folder: nothing more will be asked for.
    pub finished: u64,
}

impl ClientNotice {
    /// True when this notice says the message of `stream` numbered `seq` is recorded.
    pub fn records(&self, stream: StreamId, seq: u64) -> bool {
        self.finished != 0 || self.recorded.get(stream as usize).is_some_and(|&r| seq < r)
    }

    /// True when this notice says the end of `stream` is recorded.
    pub fn records_end(&self, stream: StreamId) -> bool {
        self.finished != 0 || self.ended & (1 << stream as u32) != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_notice_records_the_messages_below_its_mark_and_the_ends_it_lists() {
        let mut n = ClientNotice::default();
        n.recorded[StreamId::Pose as usize] = 5;
        n.ended = 1 << StreamId::Odometry as u32;
        assert!(n.records(StreamId::Pose, 4));
        assert!(!n.records(StreamId::Pose, 5));
        assert!(!n.records(StreamId::Status, 0));
        assert!(n.records_end(StreamId::Odometry));
        assert!(!n.records_end(StreamId::Pose));
        n.finished = 1;
        assert!(n.records(StreamId::Status, 1000) && n.records_end(StreamId::Pose));
    }
}
