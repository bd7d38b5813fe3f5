//! The topics a bridge can carry ([`ROUTES`], from the protocol's topic table), each with
//! its message type, and the two ends of a route: [`Outgoing`] takes a topic's messages
//! out of shared memory as bytes, [`Incoming`] publishes bytes from the peer as messages.
//!
//! Every message type of the contract is plain old data (`bytemuck::Pod`: no padding, any
//! bit pattern valid), so its bytes are the message, on any host of the same byte order.

use crate::frame::Kind;
use anyhow::Result;
use bytemuck::Pod;
use fastslam_protocol::Header;
use fastslam_protocol::ipc::{HoldingSub, Ipc, Pub, PublisherCount, Received, Taken, WakeSource};
use fastslam_protocol::message::{Fixed, FixedMessage, PayloadVisitor, Slice, SliceMessage};
use fastslam_protocol::topics::{self, Topic, TopicRow};
use iceoryx2::prelude::ZeroCopySend;
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};
use std::cell::RefCell;
use std::fmt::Debug;
use std::sync::LazyLock;

/// One topic a bridge can carry.
pub struct Route {
    /// The topic's row in the protocol's table: its settings, and the stream it carries,
    /// whose end the bridge follows (`None` for the end-of-stream topic itself and for
    /// the checkpoint topic, which never ends).
    pub row: &'static TopicRow,
    /// Publish only the newest: a sample that finds a subscriber's buffer full is not
    /// delivered to it (the checkpoint topic; see `Ipc::newest_only_publisher`).
    pub newest_only: bool,
    /// Its message type.
    carrier: &'static dyn Carrier,
}

/// Every topic a bridge can carry, in the order of the protocol's table. The true landmark
/// map (history only, no end) and the map request–response service are not carried.
pub static ROUTES: LazyLock<Vec<Route>> = LazyLock::new(|| {
    (topics::TABLE.iter())
        .filter(|row| row.topic != topics::TRUE_LANDMARKS)
        .map(|row| Route {
            row,
            newest_only: row.topic == topics::CHECKPOINT,
            carrier: row.payload.visit(AsCarrier),
        })
        .collect()
});

/// The route of topic `name`, if a bridge can carry it.
pub fn by_name(name: &str) -> Option<&'static Route> {
    ROUTES.iter().find(|r| r.row.topic.name == name)
}

/// The end-of-stream route, which every bridge carries both ways.
pub fn end_of_stream() -> &'static Route {
    by_name(topics::END_OF_STREAM.name).expect("a route of its own")
}

impl Debug for Route {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Route")
            .field("topic", &self.row.topic.name)
            .field("stream", &self.row.stream)
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
    pub fn publishers(&self, ipc: &Ipc) -> Result<PublisherCount> {
        Ok(ipc.row_publisher_probe(self.row)?)
    }

    /// Subscribes to the topic on this host (it has a publisher by now).
    ///
    /// # Errors
    /// IPC failures.
    pub fn outgoing(&'static self, ipc: &Ipc) -> Result<Box<dyn Outgoing>> {
        self.carrier.outgoing(ipc, &self.row.topic)
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

/// How a message type is read from and written to shared memory: the protocol's
/// payload types ([`Fixed`], [`Slice`]) are the carriers.
trait Carrier: Sync {
    fn kind(&self) -> Kind;
    fn outgoing(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Outgoing>>;
    fn incoming(&self, ipc: &Ipc, route: &Route) -> Result<Box<dyn Incoming>>;
}

/// The carrier of a payload type named at run time.
struct AsCarrier;

impl PayloadVisitor for AsCarrier {
    type Output = &'static dyn Carrier;

    fn fixed<T: FixedMessage>(self, payload: &'static Fixed<T>) -> Self::Output {
        payload
    }

    fn slice<H: SliceMessage>(self, payload: &'static Slice<H>) -> Self::Output {
        payload
    }
}

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

impl<T: FixedMessage> Carrier for Fixed<T> {
    fn kind(&self) -> Kind {
        Kind {
            name: type_name::<T>(),
            fixed_size: size32::<T>(),
            element_size: 0,
        }
    }

    fn outgoing(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Outgoing>> {
        Ok(Box::new(ipc.subscriber::<T>(topic)?.holding()))
    }

    fn incoming(&self, ipc: &Ipc, route: &Route) -> Result<Box<dyn Incoming>> {
        let topic = &route.row.topic;
        Ok(Box::new(if route.newest_only {
            ipc.newest_only_publisher::<T>(topic)?
        } else {
            ipc.publisher::<T>(topic)?
        }))
    }
}

impl<H: SliceMessage> Carrier for Slice<H> {
    fn kind(&self) -> Kind {
        Kind {
            name: format!("{} + [{}]", type_name::<H>(), type_name::<H::Item>()),
            fixed_size: size32::<H>(),
            element_size: size32::<H::Item>(),
        }
    }

    fn outgoing(&self, ipc: &Ipc, topic: &Topic) -> Result<Box<dyn Outgoing>> {
        Ok(Box::new(SliceOut {
            sub: ipc.slice_subscriber::<H, H::Item>(topic)?.holding(),
            bytes: RefCell::default(),
        }))
    }

    fn incoming(&self, ipc: &Ipc, route: &Route) -> Result<Box<dyn Incoming>> {
        Ok(Box::new(
            ipc.slice_publisher::<H, H::Item>(&route.row.topic)?,
        ))
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

impl<T: FixedMessage> Incoming for Pub<T, ()> {
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
    H: SliceMessage<Item = T>,
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
    use fastslam_protocol::{
        Checkpointed, EndOfStream, GroundTruth, LandmarkMapHeader, LaserScanHeader, MapLandmark,
        ObservationsHeader, OccupancyGridHeader, Odometry, ParticlesHeader, PoseEstimate,
        ServiceStatus, TrajectoryHeader,
    };
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
        let sides = [
            "odometry",
            "observations",
            "scan",
            "pose",
            "map",
            "grid",
            "smoothed/trajectory",
            "smoothed/map",
            "particles",
            "status",
            "checkpoint",
        ];
        for name in sides {
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
