//! The payload types of the topics as values and as types: [`Message`] is one message of
//! any topic, borrowed, so a receiver of many topics handles them in one `match`;
//! [`Payload`] names a topic's payload type (a fixed `T` or a header `H` plus a slice of
//! `H::Item`) with the check [`crate::validate`] has for it, and [`PayloadVisitor`] runs
//! code generic over that type (open a subscriber, carry the bytes) for a payload named
//! at run time.

use crate::validate::Rejection;
use crate::{
    Checkpointed, ClientNotice, EndOfStream, GroundTruth, Header, LandmarkMapHeader,
    LaserScanHeader, MapLandmark, Observation, ObservationsHeader, OccupancyGridHeader, Odometry,
    Particle, ParticlesHeader, PoseEstimate, ServiceStatus, TrajectoryHeader, TrajectoryPose,
};
use bytemuck::Pod;
use iceoryx2::prelude::ZeroCopySend;
use std::fmt::Debug;

/// One message of a topic, borrowed from where it lies: a variant per payload type.
#[derive(Debug, Clone, Copy)]
pub enum Message<'a> {
    /// A [`GroundTruth`] sample.
    GroundTruth(&'a GroundTruth),
    /// An [`Odometry`] message.
    Odometry(&'a Odometry),
    /// One scan's landmark observations.
    Observations(&'a ObservationsHeader, &'a [Observation]),
    /// A raw scan: its ranges, then its intensities.
    Scan(&'a LaserScanHeader, &'a [f32]),
    /// A [`PoseEstimate`].
    Pose(&'a PoseEstimate),
    /// A landmark map (estimated, smoothed or true).
    LandmarkMap(&'a LandmarkMapHeader, &'a [MapLandmark]),
    /// An occupancy grid and its cells.
    Grid(&'a OccupancyGridHeader, &'a [i8]),
    /// A smoothed trajectory.
    Trajectory(&'a TrajectoryHeader, &'a [TrajectoryPose]),
    /// A particle cloud.
    Particles(&'a ParticlesHeader, &'a [Particle]),
    /// A [`ServiceStatus`].
    Status(&'a ServiceStatus),
    /// A [`Checkpointed`] note.
    Checkpointed(&'a Checkpointed),
    /// A [`ClientNotice`].
    ClientNotice(&'a ClientNotice),
    /// An [`EndOfStream`].
    EndOfStream(&'a EndOfStream),
}

impl Message<'_> {
    /// Its header: stamp and sequence number.
    pub fn header(&self) -> Header {
        match self {
            Self::GroundTruth(m) => m.header,
            Self::Odometry(m) => m.header,
            Self::Observations(h, _) => h.header,
            Self::Scan(h, _) => h.header,
            Self::Pose(m) => m.header,
            Self::LandmarkMap(h, _) => h.header,
            Self::Grid(h, _) => h.header,
            Self::Trajectory(h, _) => h.header,
            Self::Particles(h, _) => h.header,
            Self::Status(m) => m.header,
            Self::Checkpointed(m) => m.header,
            Self::ClientNotice(m) => m.header,
            Self::EndOfStream(m) => m.header,
        }
    }
}

impl Message<'_> {
    /// Appends its bytes to `out`: the message as it lies in shared memory, or the
    /// header followed by the slice (what [`Fixed`]/[`Slice`] payloads read back with
    /// `bytemuck`).
    pub fn write_bytes(&self, out: &mut Vec<u8>) {
        use bytemuck::bytes_of;
        match *self {
            Self::GroundTruth(m) => out.extend_from_slice(bytes_of(m)),
            Self::Odometry(m) => out.extend_from_slice(bytes_of(m)),
            Self::Pose(m) => out.extend_from_slice(bytes_of(m)),
            Self::Status(m) => out.extend_from_slice(bytes_of(m)),
            Self::Checkpointed(m) => out.extend_from_slice(bytes_of(m)),
            Self::ClientNotice(m) => out.extend_from_slice(bytes_of(m)),
            Self::EndOfStream(m) => out.extend_from_slice(bytes_of(m)),
            Self::Observations(h, items) => slice_bytes(h, items, out),
            Self::Scan(h, items) => slice_bytes(h, items, out),
            Self::LandmarkMap(h, items) => slice_bytes(h, items, out),
            Self::Grid(h, items) => slice_bytes(h, items, out),
            Self::Trajectory(h, items) => slice_bytes(h, items, out),
            Self::Particles(h, items) => slice_bytes(h, items, out),
        }
    }
}

/// Appends a slice message's header and then its items to `out`.
fn slice_bytes<H: Pod, T: Pod>(header: &H, items: &[T], out: &mut Vec<u8>) {
    out.extend_from_slice(bytemuck::bytes_of(header));
    out.extend_from_slice(bytemuck::cast_slice(items));
}

/// A message type that travels alone on its topic.
pub trait FixedMessage: Pod + Default + Debug + ZeroCopySend + 'static {
    /// This message as a [`Message`].
    fn message(&self) -> Message<'_>;
}

/// The header of a message that travels as the header and a slice of [`Self::Item`].
pub trait SliceMessage: Pod + Default + Debug + ZeroCopySend + 'static {
    /// The slice's element.
    type Item: Pod + Debug + ZeroCopySend + 'static;
    /// This header and its slice as a [`Message`].
    fn message<'a>(&'a self, items: &'a [Self::Item]) -> Message<'a>;
}

/// A slice message held as owned values: its header and its elements, copied out of
/// shared memory or read from a recording. Every owned scan or observation set of the
/// stack (queued in the service, kept by a sensor for a resend, read from a data set) is
/// one of these.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Owned<H: SliceMessage> {
    /// The user header.
    pub header: H,
    /// The slice.
    pub items: Vec<H::Item>,
}

impl<H: SliceMessage> Owned<H> {
    /// This message as a [`Message`].
    pub fn message(&self) -> Message<'_> {
        self.header.message(&self.items)
    }
}

/// Implements [`FixedMessage`] for each type, wrapping it into its [`Message`] variant.
macro_rules! fixed_messages {
    ($($t:ty => $variant:ident),* $(,)?) => {$(
        impl FixedMessage for $t {
            fn message(&self) -> Message<'_> {
                Message::$variant(self)
            }
        }
    )*};
}

/// Implements [`SliceMessage`] for each header with its element, wrapping both into its
/// [`Message`] variant.
macro_rules! slice_messages {
    ($($h:ty, $item:ty => $variant:ident),* $(,)?) => {$(
        impl SliceMessage for $h {
            type Item = $item;
            fn message<'a>(&'a self, items: &'a [$item]) -> Message<'a> {
                Message::$variant(self, items)
            }
        }
    )*};
}

fixed_messages!(
    GroundTruth => GroundTruth,
    Odometry => Odometry,
    PoseEstimate => Pose,
    ServiceStatus => Status,
    Checkpointed => Checkpointed,
    ClientNotice => ClientNotice,
    EndOfStream => EndOfStream,
);

slice_messages!(
    ObservationsHeader, Observation => Observations,
    LaserScanHeader, f32 => Scan,
    LandmarkMapHeader, MapLandmark => LandmarkMap,
    OccupancyGridHeader, i8 => Grid,
    TrajectoryHeader, TrajectoryPose => Trajectory,
    ParticlesHeader, Particle => Particles,
);

/// What a receiver checks a message `T` with (see [`crate::validate`]).
pub type CheckFixed<T> = fn(&T) -> Result<(), Rejection>;
/// What a receiver checks a header `H` and its slice with (see [`crate::validate`]).
pub type CheckSlice<H> = fn(&H, &[<H as SliceMessage>::Item]) -> Result<(), Rejection>;

/// The payload `T` of a topic, alone, with its check.
pub struct Fixed<T: FixedMessage> {
    /// The check of [`crate::validate`] for `T`, where it has one.
    pub check: Option<CheckFixed<T>>,
}

/// The payload of a topic made of a header `H` and a slice of `H::Item`, with its check.
pub struct Slice<H: SliceMessage> {
    /// The check of [`crate::validate`] for `H` and its slice, where it has one.
    pub check: Option<CheckSlice<H>>,
}

impl<T: FixedMessage> Fixed<T> {
    /// A payload receivers take as it comes.
    pub const UNCHECKED: Self = Self { check: None };

    /// A payload receivers check with `check`.
    pub const fn checked(check: CheckFixed<T>) -> Self {
        Self { check: Some(check) }
    }

    /// `m` as a [`Message`], and whether it passes the check (it does without one).
    pub fn read<'a>(&self, m: &'a T) -> (Message<'a>, Result<(), Rejection>) {
        (m.message(), self.check.map_or(Ok(()), |check| check(m)))
    }
}

impl<H: SliceMessage> Slice<H> {
    /// A payload receivers check with `check`.
    pub const fn checked(check: CheckSlice<H>) -> Self {
        Self { check: Some(check) }
    }

    /// `header` and `items` as a [`Message`], and whether they pass the check (they do
    /// without one).
    pub fn read<'a>(
        &self,
        header: &'a H,
        items: &'a [H::Item],
    ) -> (Message<'a>, Result<(), Rejection>) {
        let checked = self.check.map_or(Ok(()), |check| check(header, items));
        (header.message(items), checked)
    }
}

/// The payload type of a topic: a variant per type, each with the check receivers apply.
pub enum Payload {
    /// [`GroundTruth`].
    GroundTruth(Fixed<GroundTruth>),
    /// [`Odometry`].
    Odometry(Fixed<Odometry>),
    /// [`ObservationsHeader`] + `[Observation]`.
    Observations(Slice<ObservationsHeader>),
    /// [`LaserScanHeader`] + `[f32]`.
    Scan(Slice<LaserScanHeader>),
    /// [`PoseEstimate`].
    Pose(Fixed<PoseEstimate>),
    /// [`LandmarkMapHeader`] + `[MapLandmark]`.
    LandmarkMap(Slice<LandmarkMapHeader>),
    /// [`OccupancyGridHeader`] + `[i8]`.
    Grid(Slice<OccupancyGridHeader>),
    /// [`TrajectoryHeader`] + `[TrajectoryPose]`.
    Trajectory(Slice<TrajectoryHeader>),
    /// [`ParticlesHeader`] + `[Particle]`.
    Particles(Slice<ParticlesHeader>),
    /// [`ServiceStatus`].
    Status(Fixed<ServiceStatus>),
    /// [`Checkpointed`].
    Checkpointed(Fixed<Checkpointed>),
    /// [`EndOfStream`].
    EndOfStream(Fixed<EndOfStream>),
}

/// Code generic over a topic's payload type, run by [`Payload::visit`] with the type the
/// payload names.
pub trait PayloadVisitor {
    /// What the code returns.
    type Output;
    /// Runs for a payload `T` alone.
    fn fixed<T: FixedMessage>(self, payload: &'static Fixed<T>) -> Self::Output;
    /// Runs for a payload of a header `H` and a slice.
    fn slice<H: SliceMessage>(self, payload: &'static Slice<H>) -> Self::Output;
}

impl Payload {
    /// Runs `visitor` with the type this payload names.
    pub fn visit<V: PayloadVisitor>(&'static self, visitor: V) -> V::Output {
        match self {
            Self::GroundTruth(p) => visitor.fixed(p),
            Self::Odometry(p) => visitor.fixed(p),
            Self::Observations(p) => visitor.slice(p),
            Self::Scan(p) => visitor.slice(p),
            Self::Pose(p) => visitor.fixed(p),
            Self::LandmarkMap(p) => visitor.slice(p),
            Self::Grid(p) => visitor.slice(p),
            Self::Trajectory(p) => visitor.slice(p),
            Self::Particles(p) => visitor.slice(p),
            Self::Status(p) => visitor.fixed(p),
            Self::Checkpointed(p) => visitor.fixed(p),
            Self::EndOfStream(p) => visitor.fixed(p),
        }
    }
}
