//! The topics a bridge can carry ([`ROUTES`]), each with its message type, and the two
//! ends of a route: [`Outgoing`] takes a topic's messages out of shared memory as bytes,
//! [`Incoming`] publishes bytes from the peer as messages.
//!
//! Every message type of the contract is plain old data (`bytemuck::Pod`: no padding, any
//! bit pattern valid), so its bytes are the message, on any host of the same byte order.

use crate::frame::Kind;
use anyhow::Result;
use bytemuck::Pod;
use fastslam_protocol::ipc::{HoldingSub, Ipc, Pub, Received, Taken, WakeSource};
use fastslam_protocol::topics::{self, Topic};
use fastslam_protocol::{
    Checkpointed, EndOfStream, GroundTruth, Header, LandmarkMapHeader, LaserScanHeader,
    MapLandmark, Observation, ObservationsHeader, OccupancyGridHeader, Odometry, Particle,
    ParticlesHeader, PoseEstimate, ServiceStatus, StreamId, TrajectoryHeader, TrajectoryPose,
};
use iceoryx2::prelude::ZeroCopySend;
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};
use std::cell::RefCell;
use std::fmt::Debug;
use std::marker::PhantomData;

/// One topic a bridge can carry.
pub struct Route {
    /// The topic.
    pub topic: Topic,
    /// The stream it carries, whose end the bridge follows; `None` for the end-of-stream
    /// topic itself and for the checkpoint topic, which never ends.
    pub stream: Option<StreamId>,
    /// Publish only the newest: a sample that finds a subscriber's buffer full is not
    /// delivered to it (the checkpoint topic; see `Ipc::newest_only_publisher`).
    pub newest_only: bool,
    /// Its message type.
    carrier: &'static dyn Carrier,
}

/// The topics the sensors publish: what a sensor host sends to the service's host.
pub const SENSOR_TOPICS: [&str; 3] = ["odometry", "observations", "scan"];
/// The topics the service publishes: what the service's host sends back.
pub const SERVICE_TOPICS: [&str; 8] = [
    "pose",
    "map",
    "grid",
    "smoothed/trajectory",
    "smoothed/map",
    "particles",
    "status",
    "checkpoint",
];

/// Every topic a bridge can carry. The true landmark map (history only, no end) and the
/// map request–response service are not carried.
pub static ROUTES: [Route; 13] = [
    route(
        topics::GROUND_TRUTH,
        Some(StreamId::GroundTruth),
        &Fixed::<GroundTruth>(PhantomData),
    ),
    route(
        topics::ODOMETRY,
        Some(StreamId::Odometry),
        &Fixed::<Odometry>(PhantomData),
    ),
    route(
        topics::OBSERVATIONS,
        Some(StreamId::Observations),
        &Slice::<ObservationsHeader, Observation>(PhantomData),
    ),
    route(
        topics::SCAN,
        Some(StreamId::Scan),
        &Slice::<LaserScanHeader, f32>(PhantomData),
    ),
    route(
        topics::POSE,
        Some(StreamId::Pose),
        &Fixed::<PoseEstimate>(PhantomData),
    ),
    route(
        topics::MAP,
        Some(StreamId::Map),
        &Slice::<LandmarkMapHeader, MapLandmark>(PhantomData),
    ),
    route(
        topics::GRID,
        Some(StreamId::Grid),
        &Slice::<OccupancyGridHeader, i8>(PhantomData),
    ),
    route(
        topics::SMOOTHED_TRAJECTORY,
        Some(StreamId::SmoothedTrajectory),
        &Slice::<TrajectoryHeader, TrajectoryPose>(PhantomData),
    ),
    route(
        topics::SMOOTHED_MAP,
        Some(StreamId::SmoothedMap),
        &Slice::<LandmarkMapHeader, MapLandmark>(PhantomData),
    ),
    route(
        topics::PARTICLES,
        Some(StreamId::Particles),
        &Slice::<ParticlesHeader, Particle>(PhantomData),
    ),
    route(
        topics::STATUS,
        Some(StreamId::Status),
        &Fixed::<ServiceStatus>(PhantomData),
    ),
    Route {
        topic: topics::CHECKPOINT,
        stream: None,
        newest_only: true,
        carrier: &Fixed::<Checkpointed>(PhantomData),
    },
    route(
        topics::END_OF_STREAM,
        None,
        &Fixed::<EndOfStream>(PhantomData),
    ),
];

/// A route that waits rather than lose a sample.
const fn route(topic: Topic, stream: Option<StreamId>, carrier: &'static dyn Carrier) -> Route {
    Route {
        topic,
        stream,
        newest_only: false,
        carrier,
    }
}

/// The route of topic `name`, if a bridge can carry it.
pub fn by_name(name: &str) -> Option<&'static Route> {
    ROUTES.iter().find(|r| r.topic.name == name)
}

/// The end-of-stream route, which every bridge carries both ways.
pub fn end_of_stream() -> &'static Route {
    by_name(topics::END_OF_STREAM.name).expect("a route of its own")
}

impl Debug for Route {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Route")
            .field("topic", &self.topic.name)
            .field("stream", &self.stream)
            .finish_non_exhaustive()
    }
}

impl Route {
    /// Its message type as frames name it.
    pub fn kind(&self) -> Kind {
        self.carrier.kind()
    }

    /// A probe counting the topic's publishers on this host.
    ///
    /// # Errors
    /// IPC failures.
    pub fn publishers(&self, ipc: &Ipc) -> Result<Box<dyn Fn() -> usize>> {
        self.carrier.publishers(ipc, &self.topic)
    }

    /// Subscribes to the topic on this host (it has a publisher by now).
    ///
    /// # Errors
    /// IPC failures.
    pub fn outgoing(&'static self, ipc: &Ipc) -> Result<Box<dyn Outgoing>> {
        self.carrier.outgoing(ipc, &self.topic)
    }

    /// Opens a publisher on the topic on this host.
    ///
    /// # Errors
    /// IPC failures.
    pub fn incoming(&'static self, ipc: &Ipc) -> Result<Box<dyn Incoming>> {
        self.carrier.incoming(ipc, self)
    }
}

/// The messages of one topic leaving this host.
pub trait Outgoing {
    /// The subscriber, to wake on.
    fn source(&self) -> &dyn WakeSource;
    /// Offers each pending message, in order, as its header and its bytes, to `send`,
    /// until `send` returns false: that message stays in shared memory (its publisher
    /// waits once the buffer is full) and is offered first next time.
    ///
    /// # Errors
    /// IPC failures.
    fn drain(&self, send: &mut dyn FnMut(Header, &[u8]) -> bool) -> Result<()>;
}

/// The messages of one topic arriving on this host.
pub trait Incoming {
    /// Publishes the message whose bytes are `body` (checked whole by the frame).
    ///
    /// # Errors
    /// IPC failures.
    fn publish(&self, body: &[u8]) -> Result<()>;
    /// Subscribers on this host right now.
    fn subscribers(&self) -> usize;
    /// Waits until this host's subscribers have left (they may still be reading what was
    /// published).
    ///
    /// # Errors
    /// IPC failures.
    fn wait_until_unsubscribed(&self, ipc: &Ipc) -> Result<()>;
}

/// How a message type is read from and written to shared memory.
trait Carrier: Sync {
    fn kind(&self) -> Kind;
    fn publishers(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Fn() -> usize>>;
    fn outgoing(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Outgoing>>;
    fn incoming(&self, ipc: &Ipc, route: &Route) -> Result<Box<dyn Incoming>>;
}

/// A fixed-size message `T`.
struct Fixed<T>(PhantomData<fn() -> T>);
/// A header `H` followed by a slice of `T`.
struct Slice<H, T>(PhantomData<fn() -> (H, T)>);

/// The contract's name of type `T`.
fn type_name<T: ZeroCopySend>() -> String {
    TypeDetail::new::<T>(TypeVariant::FixedSize)
        .type_name()
        .to_string()
}

/// The header every message starts with.
pub(crate) fn header_of(bytes: &[u8]) -> Header {
    bytemuck::pod_read_unaligned(&bytes[..size_of::<Header>()])
}

/// The size of `T` as a frame gives it.
fn size32<T>() -> u32 {
    u32::try_from(size_of::<T>()).expect("messages are small")
}

impl<T: Pod + Debug + ZeroCopySend + Default> Carrier for Fixed<T> {
    fn kind(&self) -> Kind {
        Kind {
            name: type_name::<T>(),
            fixed_size: size32::<T>(),
            element_size: 0,
        }
    }

    fn publishers(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Fn() -> usize>> {
        Ok(Box::new(ipc.publisher_probe::<T, ()>(topic)?))
    }

    fn outgoing(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Outgoing>> {
        Ok(Box::new(ipc.subscriber::<T>(topic)?.holding()))
    }

    fn incoming(&self, ipc: &Ipc, route: &Route) -> Result<Box<dyn Incoming>> {
        Ok(Box::new(if route.newest_only {
            ipc.newest_only_publisher::<T>(&route.topic)?
        } else {
            ipc.publisher::<T>(&route.topic)?
        }))
    }
}

impl<H, T> Carrier for Slice<H, T>
where
    H: Pod + Debug + ZeroCopySend + Default,
    T: Pod + Debug + ZeroCopySend,
{
    fn kind(&self) -> Kind {
        Kind {
            name: format!("{} + [{}]", type_name::<H>(), type_name::<T>()),
            fixed_size: size32::<H>(),
            element_size: size32::<T>(),
        }
    }

    fn publishers(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Fn() -> usize>> {
        Ok(Box::new(ipc.publisher_probe::<[T], H>(topic)?))
    }

    fn outgoing(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Outgoing>> {
        Ok(Box::new(SliceOut {
            sub: ipc.slice_subscriber::<H, T>(topic)?.holding(),
            bytes: RefCell::default(),
        }))
    }

    fn incoming(&self, ipc: &Ipc, route: &Route) -> Result<Box<dyn Incoming>> {
        Ok(Box::new(ipc.slice_publisher::<H, T>(&route.topic)?))
    }
}

impl<T: Pod + Debug + ZeroCopySend> Outgoing for HoldingSub<T, ()> {
    fn source(&self) -> &dyn WakeSource {
        self
    }

    fn drain(&self, send: &mut dyn FnMut(Header, &[u8]) -> bool) -> Result<()> {
        HoldingSub::drain(self, |sample: &Received<T, ()>, _| {
            let bytes = bytemuck::bytes_of(sample.payload());
            taken(send(header_of(bytes), bytes))
        })?;
        Ok(())
    }
}

/// A slice topic leaving: its header and elements are copied into one buffer.
struct SliceOut<H: Debug + ZeroCopySend + 'static, T: Debug + ZeroCopySend + 'static> {
    sub: HoldingSub<[T], H>,
    bytes: RefCell<Vec<u8>>,
}

impl<H, T> Outgoing for SliceOut<H, T>
where
    H: Pod + Debug + ZeroCopySend,
    T: Pod + Debug + ZeroCopySend,
{
    fn source(&self) -> &dyn WakeSource {
        &self.sub
    }

    fn drain(&self, send: &mut dyn FnMut(Header, &[u8]) -> bool) -> Result<()> {
        let mut bytes = self.bytes.borrow_mut();
        self.sub.drain(|sample: &Received<[T], H>, _| {
            bytes.clear();
            bytes.extend_from_slice(bytemuck::bytes_of(sample.user_header()));
            bytes.extend_from_slice(bytemuck::cast_slice(sample.payload()));
            taken(send(header_of(&bytes), &bytes))
        })?;
        Ok(())
    }
}

/// What a drain does after `send` answered `sent`.
fn taken(sent: bool) -> Taken {
    if sent { Taken::Done } else { Taken::Hold }
}

impl<T: Pod + Debug + ZeroCopySend> Incoming for Pub<T, ()> {
    fn publish(&self, body: &[u8]) -> Result<()> {
        Ok(self.send(bytemuck::pod_read_unaligned(body))?)
    }

    fn subscribers(&self) -> usize {
        Pub::subscribers(self)
    }

    fn wait_until_unsubscribed(&self, ipc: &Ipc) -> Result<()> {
        Ok(Pub::wait_until_unsubscribed(self, ipc)?)
    }
}

impl<H, T> Incoming for Pub<[T], H>
where
    H: Pod + Debug + ZeroCopySend + Default,
    T: Pod + Debug + ZeroCopySend,
{
    fn publish(&self, body: &[u8]) -> Result<()> {
        let (head, items) = body.split_at(size_of::<H>());
        let items: Vec<T> = bytemuck::pod_collect_to_vec(items);
        Ok(self.send(bytemuck::pod_read_unaligned(head), &items)?)
    }

    fn subscribers(&self) -> usize {
        Pub::subscribers(self)
    }

    fn wait_until_unsubscribed(&self, ipc: &Ipc) -> Result<()> {
        Ok(Pub::wait_until_unsubscribed(self, ipc)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::offset_of;

    #[test]
    fn every_message_starts_with_its_header() {
        // `header_of` reads the first bytes of each message as its `Header`.
        let offsets = [
            offset_of!(GroundTruth, header),
            offset_of!(Odometry, header),
            offset_of!(ObservationsHeader, header),
            offset_of!(LaserScanHeader, header),
            offset_of!(PoseEstimate, header),
            offset_of!(LandmarkMapHeader, header),
            offset_of!(OccupancyGridHeader, header),
            offset_of!(TrajectoryHeader, header),
            offset_of!(ParticlesHeader, header),
            offset_of!(ServiceStatus, header),
            offset_of!(Checkpointed, header),
            offset_of!(EndOfStream, header),
        ];
        assert!(offsets.iter().all(|&o| o == 0), "{offsets:?}");
    }

    #[test]
    fn every_route_names_its_contract_types() {
        assert_eq!(ROUTES.len(), 13);
        for name in SENSOR_TOPICS.iter().chain(&SERVICE_TOPICS) {
            let route = by_name(name).unwrap_or_else(|| panic!("{name} has a route"));
            assert!(
                route.kind().name.starts_with("fastslam::"),
                "{:?}",
                route.kind()
            );
        }
        let map = by_name("map").unwrap().kind();
        assert_eq!(
            map.name,
            "fastslam::LandmarkMapHeader + [fastslam::MapLandmark]"
        );
        assert_eq!(map.element_size as usize, size_of::<MapLandmark>());
        assert!(by_name(topics::TRUE_LANDMARKS.name).is_none());
        assert!(by_name("nonsense").is_none());
    }
}
