//! The service's account of itself: filter health, timing and input bookkeeping, for
//! monitoring and metrics. Clients judge accuracy from poses and ground truth, never from
//! this message; it says how the filter is doing, not how well.

use crate::header::Header;
use crate::stream::StreamId;
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
    /// Skipped by a service resumed from a checkpoint that already holds it, other than
    /// the input that marks the start of its sensor's resend (not an error: counted so
    /// that a run whose sensors started over under a resumed service says what it left
    /// out).
    Covered = 11,
}

impl RejectionKind {
    /// Every kind, in index order.
    pub const ALL: [Self; 12] = [
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
        Self::Covered,
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
            Self::Covered => "covered",
        }
    }
}

/// Bit flags of [`ServiceStatus::flags`].
pub mod flags {
    /// The last observation step resampled the particles.
    pub const RESAMPLED: u32 = 1;
    /// An input stream is quiet beyond its deadline: the service runs on what it has
    /// (which one: [`super::StreamStatus::quiet`]).
    pub const DEGRADED: u32 = 2;
    /// The service's last status, sent at shutdown just before its end-of-stream: not
    /// an observation step (the step's fields repeat the last step's), but the final
    /// counters, landmark count, queues and stamps.
    pub const FINAL: u32 = 16;
    /// The noise check: the innovations' NIS has been above its χ² band for a whole
    /// window of scans — the noise model is too small for this data.
    pub const NIS_HIGH: u32 = 32;
    /// With [`NIS_HIGH`]: the odometry noise (`sigma_v`, `sigma_omega`) is the likelier
    /// culprit; without it, the sensor's (`sigma_range`, `sigma_bearing`). The noise fit
    /// decides once it has warmed up; before, whether the pose term dominates the
    /// innovation covariance.
    pub const NIS_POSE: u32 = 64;
    /// The smoothing back-end's newest solve was torn and withheld: `smoothed/*` holds an
    /// older solution, or none ([`super::ServiceStatus::torn_solves`]).
    pub const SMOOTHED_TORN: u32 = 128;
    /// The landmark filter associates observations without their ids (unknown
    /// association): a wrong match is possible, and bends the noise fit too.
    pub const UNKNOWN_ASSOCIATION: u32 = 256;
}

/// Most input streams a [`ServiceStatus`] or a [`Checkpointed`] lists.
pub const MAX_INPUT_STREAMS: usize = 4;

/// One input stream's state, an entry of [`ServiceStatus::streams`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::StreamStatus")]
#[repr(C)]
pub struct StreamStatus {
    /// The stream's [`StreamId`] as `u32` (0 in an unused entry).
    pub stream: u32,
    /// Inputs of the stream waiting in the service's queue.
    pub queued: u32,
    /// Newest accepted stamp of the stream, ns (0 before the first).
    pub last_input_ns: u64,
    /// 1: the stream is quiet beyond its deadline and not waited for (odometry: scans
    /// are processed without prediction; the lidar: odometry keeps predicting); 0: heard
    /// from in time.
    pub quiet: u32,
    /// Reserved, 0.
    pub reserved: u32,
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
    /// Bit set of [`flags`].
    pub flags: u32,
    /// Degrees of freedom of the noise check's window (2 per matched observation).
    pub nis_dof: u32,
    /// Rejected inputs so far, indexed by [`RejectionKind`].
    pub rejections: [u64; REJECTION_KINDS],
    /// The noise check: normalised innovation squared per degree of freedom over the
    /// last scans (1 when the noise model fits; NaN before any match).
    pub nis: f64,
    /// Entries of `streams` in use.
    pub stream_count: u32,
    /// Solves of the smoothing back-end withheld as torn so far (docs/ALGORITHMS.md
    /// §8.3); 0 without a back-end.
    pub torn_solves: u32,
    /// The service's input streams, in the order it registered them (odometry first):
    /// the first `stream_count` entries ([`ServiceStatus::streams`]).
    pub streams: [StreamStatus; MAX_INPUT_STREAMS],
    /// The configured noise profile as standard deviations: the motion model's two
    /// (`sigma_v` and `sigma_omega` or `sigma_steering`; the increment model's
    /// `translation_per_m` and `rotation_per_rad`), `sigma_range`, `sigma_bearing`
    /// (0 for an estimator without a noise fit).
    pub noise_profile: [f64; 4],
    /// The same four as fitted: by the smoothing back-end's variance components once it
    /// has solved the whole graph, else from the innovations (the profile's until the fit
    /// has warmed up); 0 without a noise fit. [`ServiceStatus::noise_fit`] says which.
    pub noise_fitted: [f64; 4],
    /// Where `noise_fitted` comes from: one of [`noise_fit`].
    pub noise_fit: u32,
    /// The noise source the check blames: one of [`noise_suspect`].
    pub noise_suspect: u32,
}

/// The values of [`ServiceStatus::noise_fit`].
pub mod noise_fit {
    /// No noise fit (an estimator without one).
    pub const NONE: u32 = 0;
    /// The filter's fit to its innovations.
    pub const INNOVATIONS: u32 = 1;
    /// The smoothing back-end's variance components of its newest whole solve.
    pub const SMOOTHER: u32 = 2;
}

/// The values of [`ServiceStatus::noise_suspect`].
pub mod noise_suspect {
    /// None: the noise check has not failed, or the back-end's components find no source
    /// above its threshold.
    pub const NONE: u32 = 0;
    /// The odometry (`sigma_v`, `sigma_omega` or `sigma_steering` too small).
    pub const ODOMETRY: u32 = 1;
    /// The sensor (`sigma_range`, `sigma_bearing` too small).
    pub const SENSOR: u32 = 2;
}

impl ServiceStatus {
    /// The input streams listed.
    pub fn streams(&self) -> &[StreamStatus] {
        &self.streams[..(self.stream_count as usize).min(MAX_INPUT_STREAMS)]
    }

    /// The entry of input stream `id`, if listed.
    pub fn stream(&self, id: StreamId) -> Option<&StreamStatus> {
        self.streams().iter().find(|s| s.stream == id as u32)
    }

    /// Lists `streams` (the first [`MAX_INPUT_STREAMS`]; any entries beyond are dropped).
    pub fn set_streams(&mut self, streams: impl IntoIterator<Item = StreamStatus>) {
        self.streams = [StreamStatus::default(); MAX_INPUT_STREAMS];
        let mut count = 0;
        for (slot, s) in self.streams.iter_mut().zip(streams) {
            *slot = s;
            count += 1;
        }
        self.stream_count = count;
    }
}

/// One input stream's entry of [`Checkpointed::covered`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::StreamCovered")]
#[repr(C)]
pub struct StreamCovered {
    /// The stream's [`StreamId`] as `u32` (0 in an unused entry).
    pub stream: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Stamp of the stream's last input the checkpoint holds, ns.
    pub covered_ns: u64,
}

/// What the service's last checkpoint covers, published on
/// [`crate::topics::CHECKPOINT`] each time it writes one: a service resumed from that
/// checkpoint skips every input stamped at or before its stream's `covered_ns`, so a
/// sensor may forget what it sent up to there. A sensor keeps what it sent since; a
/// service resumed after a crash asks for it with `resume` set.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::Checkpointed")]
#[repr(C)]
pub struct Checkpointed {
    /// Stamp of the last observation step the checkpoint holds, and sequence number.
    pub header: Header,
    /// Entries of `covered` in use.
    pub stream_count: u32,
    /// 1: sent once by a service that has just resumed from this checkpoint and
    /// subscribed to its inputs: send again everything after `covered_ns`, then go on.
    /// 0: a checkpoint was written.
    pub resume: u32,
    /// What the checkpoint holds of each input stream: the first `stream_count` entries
    /// ([`Checkpointed::covered`]).
    pub covered: [StreamCovered; MAX_INPUT_STREAMS],
}

impl Checkpointed {
    /// The notice for a checkpoint stamped by `header` holding each stream up to its
    /// stamp in `covered` (the first [`MAX_INPUT_STREAMS`]); with `resume`, the request
    /// of a service that has just resumed from it.
    pub fn new(
        header: Header,
        covered: impl IntoIterator<Item = (StreamId, u64)>,
        resume: bool,
    ) -> Self {
        let mut notice = Self {
            header,
            resume: u32::from(resume),
            ..Self::default()
        };
        for (slot, (stream, covered_ns)) in notice.covered.iter_mut().zip(covered) {
            *slot = StreamCovered {
                stream: stream as u32,
                reserved: 0,
                covered_ns,
            };
            notice.stream_count += 1;
        }
        notice
    }

    /// The streams listed.
    pub fn covered(&self) -> &[StreamCovered] {
        &self.covered[..(self.stream_count as usize).min(MAX_INPUT_STREAMS)]
    }

    /// Stamp of stream `id`'s last input the checkpoint holds, if listed.
    pub fn covered_ns(&self, id: StreamId) -> Option<u64> {
        (self.covered().iter())
            .find(|c| c.stream == id as u32)
            .map(|c| c.covered_ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_lists_hold_what_was_set_and_are_found_by_id() {
        let mut status = ServiceStatus::default();
        let entry = |id: StreamId, queued| StreamStatus {
            stream: id as u32,
            queued,
            ..StreamStatus::default()
        };
        status.set_streams([entry(StreamId::Odometry, 3), entry(StreamId::Scan, 1)]);
        assert_eq!(status.streams().len(), 2);
        assert_eq!(status.stream(StreamId::Scan).map(|s| s.queued), Some(1));
        assert_eq!(status.stream(StreamId::Observations), None);
        let h = Header {
            stamp_ns: 5,
            seq: 1,
        };
        let notice = Checkpointed::new(h, [(StreamId::Odometry, 7), (StreamId::Scan, 9)], true);
        assert_eq!(notice.covered_ns(StreamId::Scan), Some(9));
        assert_eq!(notice.covered_ns(StreamId::Pose), None);
        assert_eq!((notice.resume, notice.covered().len()), (1, 2));
        let many = (0..9).map(|k| (StreamId::Odometry, k));
        assert_eq!(
            Checkpointed::new(h, many, false).covered().len(),
            MAX_INPUT_STREAMS
        );
    }
}
