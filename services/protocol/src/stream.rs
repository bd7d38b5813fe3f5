//! End of a finite stream.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Which stream an [`EndOfStream`] closes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum StreamId {
    /// [`crate::GroundTruth`] on [`crate::topics::GROUND_TRUTH`].
    GroundTruth = 1,
    /// [`crate::Odometry`] on [`crate::topics::ODOMETRY`].
    Odometry = 2,
    /// Observations on [`crate::topics::OBSERVATIONS`].
    Observations = 3,
    /// [`crate::PoseEstimate`] on [`crate::topics::POSE`].
    Pose = 4,
    /// Landmark maps on [`crate::topics::MAP`].
    Map = 5,
    /// [`crate::ServiceStatus`] on [`crate::topics::STATUS`].
    Status = 6,
    /// Raw lidar scans on [`crate::topics::SCAN`].
    Scan = 7,
    /// Occupancy grids on [`crate::topics::GRID`].
    Grid = 8,
    /// Smoothed trajectories on [`crate::topics::SMOOTHED_TRAJECTORY`].
    SmoothedTrajectory = 9,
    /// Smoothed maps on [`crate::topics::SMOOTHED_MAP`].
    SmoothedMap = 10,
    /// Particle clouds on [`crate::topics::PARTICLES`].
    Particles = 11,
}

impl StreamId {
    /// Every stream, in wire-value order.
    pub const ALL: [Self; 11] = [
        Self::GroundTruth,
        Self::Odometry,
        Self::Observations,
        Self::Pose,
        Self::Map,
        Self::Status,
        Self::Scan,
        Self::Grid,
        Self::SmoothedTrajectory,
        Self::SmoothedMap,
        Self::Particles,
    ];

    /// The stream for a wire value, if it is one.
    pub fn from_u32(v: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|s| *s as u32 == v)
    }
}

/// "Stream `stream` is finished; its last message had this header."
///
/// Published on [`crate::topics::END_OF_STREAM`], which every stream shares. A receiver
/// treats the stream as finished once it has processed the message with `header.seq`
/// (messages of different topics are not ordered against each other), or at once when
/// the stream never sent anything (`header.seq == u64::MAX`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::EndOfStream")]
#[repr(C)]
pub struct EndOfStream {
    /// Stamp and sequence number of the stream's last message.
    pub header: Header,
    /// The [`StreamId`] as `u32`.
    pub stream: u32,
    /// Reserved, must be 0.
    pub reserved: u32,
}

impl EndOfStream {
    /// The closing message of `stream` whose last message had `last` as header
    /// (`None`: the stream sent nothing).
    pub fn new(stream: StreamId, last: Option<Header>) -> Self {
        let header = last.unwrap_or(Header {
            stamp_ns: 0,
            seq: u64::MAX,
        });
        Self {
            header,
            stream: stream as u32,
            reserved: 0,
        }
    }

    /// The sequence number of the last message, `None` when the stream sent nothing.
    pub fn last_seq(&self) -> Option<u64> {
        (self.header.seq != u64::MAX).then_some(self.header.seq)
    }
}

/// The newest header taken of each stream, to skip what is sent again: a sensor sends
/// what the service's last checkpoint does not cover again to a service resumed after a
/// crash (or to a bridge restarted after one), and the resumed service publishes again
/// what it had published since that checkpoint (the same messages: a resume repeats the
/// run exactly). A message whose sequence number and stamp are both no newer than the
/// newest taken is such a repeat; a publisher that restarts numbers from 0 again at later
/// stamps, and is taken.
#[derive(Debug, Default, Clone)]
pub struct Repeats(std::collections::HashMap<StreamId, Header>);

impl Repeats {
    /// True when the message with header `h` on stream `id` is not a repeat; it is then
    /// the newest taken.
    pub fn fresh(&mut self, id: StreamId, h: Header) -> bool {
        let repeat = self
            .0
            .get(&id)
            .is_some_and(|last| h.seq <= last.seq && h.stamp_ns <= last.stamp_ns);
        if !repeat {
            self.0.insert(id, h);
        }
        !repeat
    }

    /// The newest header taken of stream `id`.
    pub fn newest(&self, id: StreamId) -> Option<Header> {
        self.0.get(&id).copied()
    }
}

/// Sequence numbers a [`StreamEnd`] remembers, to find the announced last message among
/// the most recent ones.
const RECENT_SEQS: usize = 1024;

/// Whether one stream has finished, from a receiver's point of view: finished once its
/// [`EndOfStream`] arrived *and* the announced last message has been processed.
///
/// It looks for the announced sequence number itself among the recent ones rather than
/// comparing with the largest seen: a restarted publisher numbers from 0 again, and a bad
/// publisher may send any number, so "some seq ≥ last" would end a stream early.
#[derive(Debug, Clone, Default)]
pub struct StreamEnd {
    announced: Option<Option<u64>>,
    recent: std::collections::VecDeque<u64>,
    last_seen: bool,
}

impl StreamEnd {
    /// Records that the message with `seq` was processed.
    pub fn saw(&mut self, seq: u64) {
        if self.recent.len() == RECENT_SEQS {
            self.recent.pop_front();
        }
        self.recent.push_back(seq);
        self.last_seen |= self.announced == Some(Some(seq));
    }

    /// Records the stream's end-of-stream message.
    pub fn announce(&mut self, eos: &EndOfStream) {
        let last = eos.last_seq();
        self.announced = Some(last);
        self.last_seen = last.is_some_and(|last| self.recent.contains(&last));
    }

    /// True once the end was announced and its last message was seen.
    pub fn finished(&self) -> bool {
        match self.announced {
            None => false,
            Some(None) => true,
            Some(Some(_)) => self.last_seen,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_end_waits_for_the_announced_last_message() {
        let mut end = StreamEnd::default();
        end.saw(3);
        assert!(!end.finished());
        end.announce(&EndOfStream::new(
            StreamId::Pose,
            Some(Header {
                stamp_ns: 9,
                seq: 5,
            }),
        ));
        assert!(!end.finished(), "message 5 not seen yet");
        end.saw(5);
        assert!(end.finished());
    }

    #[test]
    fn a_larger_seq_from_before_a_restart_does_not_end_the_stream_early() {
        let mut end = StreamEnd::default();
        for seq in [0, 1, 500, 0, 1] {
            end.saw(seq);
        }
        let last = |seq| EndOfStream::new(StreamId::Odometry, Some(Header { stamp_ns: 9, seq }));
        end.announce(&last(3));
        assert!(
            !end.finished(),
            "message 3 of the new publisher not seen yet"
        );
        end.saw(2);
        assert!(!end.finished());
        end.saw(3);
        assert!(end.finished());
        let mut early = StreamEnd::default();
        early.saw(7);
        early.saw(u64::MAX - 1);
        early.announce(&last(7));
        assert!(
            early.finished(),
            "the last message came before its announcement"
        );
    }

    #[test]
    fn repeats_are_skipped_and_a_restarted_publisher_is_taken() {
        let h = |seq, stamp_ns| Header { stamp_ns, seq };
        let mut seen = Repeats::default();
        assert!(seen.fresh(StreamId::Pose, h(0, 10)));
        assert!(seen.fresh(StreamId::Pose, h(1, 20)));
        assert!(!seen.fresh(StreamId::Pose, h(1, 20)), "sent again");
        assert!(!seen.fresh(StreamId::Pose, h(0, 10)), "sent again");
        assert!(seen.fresh(StreamId::Odometry, h(0, 10)), "another stream");
        assert!(
            seen.fresh(StreamId::Pose, h(0, 30)),
            "a restarted publisher"
        );
        assert!(
            seen.fresh(StreamId::Pose, h(2, 30)),
            "the next after a restart"
        );
        assert_eq!(seen.newest(StreamId::Pose), Some(h(2, 30)));
        assert_eq!(seen.newest(StreamId::Map), None);
    }

    #[test]
    fn stream_end_of_an_empty_stream_is_immediate() {
        let mut end = StreamEnd::default();
        end.announce(&EndOfStream::new(StreamId::Map, None));
        assert!(end.finished());
    }

    #[test]
    fn stream_ids_round_trip() {
        for (k, id) in StreamId::ALL.into_iter().enumerate() {
            assert_eq!(id as usize, k + 1, "wire values in order, from 1");
            assert_eq!(StreamId::from_u32(id as u32), Some(id));
        }
        assert_eq!(StreamId::from_u32(0), None);
        assert_eq!(StreamId::from_u32(StreamId::ALL.len() as u32 + 1), None);
    }
}
