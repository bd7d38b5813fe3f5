//! What travels: the iceoryx2 service flavour ([`Service`]), and [`Wire`], which lets one
//! [`Pub`] and one [`Sub`] serve fixed-size payloads and slices alike.

#[cfg(doc)]
use super::{Pub, Sub};
use crate::topics::Topic;
use iceoryx2::port::publisher::{Publisher, PublisherCreateError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::{BackpressureFn, ReceiveError};
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::service::builder::publish_subscribe::{
    Builder as PubSubBuilder, PublishSubscribeOpenOrCreateError,
};
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};
use std::fmt::Debug;

/// The iceoryx2 service flavour the stack uses: inter-process, shared memory.
pub type Service = ipc::Service;

/// Bridges iceoryx2's separate APIs for fixed-size payloads (`T`) and slices (`[T]`), so
/// one [`Pub`] and one [`Sub`] serve both.
pub trait Wire: Debug + IceoryxSend + 'static {
    /// Opens or creates the publish–subscribe service from a configured builder.
    ///
    /// # Errors
    /// iceoryx2's error when the service cannot be opened or created.
    fn open_service<H: Debug + ZeroCopySend + 'static>(
        builder: PubSubBuilder<Self, H, Service>,
    ) -> std::result::Result<PortFactory<Service, Self, H>, PublishSubscribeOpenOrCreateError>;

    /// The payload type as iceoryx2 records it in a service (a slice's: its element).
    fn payload_type() -> TypeDetail;

    /// Creates a publisher (slices: growing by powers of two from the topic's first guess)
    /// that asks `full` what to do when a subscriber's buffer is full.
    ///
    /// # Errors
    /// iceoryx2's error when the publisher cannot be created.
    fn create_publisher<H: Debug + ZeroCopySend + 'static>(
        service: &PortFactory<Service, Self, H>,
        topic: &Topic,
        full: impl BackpressureFn + 'static,
    ) -> std::result::Result<Publisher<Service, Self, H>, PublisherCreateError>;

    /// Receives the next sample, if any.
    ///
    /// # Errors
    /// iceoryx2's error when receiving fails.
    fn receive<H: Debug + ZeroCopySend + 'static>(
        subscriber: &Subscriber<Service, Self, H>,
    ) -> std::result::Result<Option<Sample<Service, Self, H>>, ReceiveError>;
}

impl<T: Debug + ZeroCopySend + 'static> Wire for T {
    fn payload_type() -> TypeDetail {
        TypeDetail::new::<T>(TypeVariant::FixedSize)
    }

    fn open_service<H: Debug + ZeroCopySend + 'static>(
        builder: PubSubBuilder<Self, H, Service>,
    ) -> std::result::Result<PortFactory<Service, Self, H>, PublishSubscribeOpenOrCreateError> {
        builder.open_or_create()
    }

    fn create_publisher<H: Debug + ZeroCopySend + 'static>(
        service: &PortFactory<Service, Self, H>,
        _topic: &Topic,
        full: impl BackpressureFn + 'static,
    ) -> std::result::Result<Publisher<Service, Self, H>, PublisherCreateError> {
        service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
            .set_backpressure_handler(full)
            .create()
    }

    fn receive<H: Debug + ZeroCopySend + 'static>(
        subscriber: &Subscriber<Service, Self, H>,
    ) -> std::result::Result<Option<Sample<Service, Self, H>>, ReceiveError> {
        subscriber.receive()
    }
}

impl<T: Debug + ZeroCopySend + 'static> Wire for [T] {
    fn payload_type() -> TypeDetail {
        TypeDetail::new::<T>(TypeVariant::Dynamic)
    }

    fn open_service<H: Debug + ZeroCopySend + 'static>(
        builder: PubSubBuilder<Self, H, Service>,
    ) -> std::result::Result<PortFactory<Service, Self, H>, PublishSubscribeOpenOrCreateError> {
        builder.open_or_create()
    }

    fn create_publisher<H: Debug + ZeroCopySend + 'static>(
        service: &PortFactory<Service, Self, H>,
        topic: &Topic,
        full: impl BackpressureFn + 'static,
    ) -> std::result::Result<Publisher<Service, Self, H>, PublisherCreateError> {
        service
            .publisher_builder()
            .initial_max_slice_len(topic.initial_slice_len)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
            .set_backpressure_handler(full)
            .create()
    }

    fn receive<H: Debug + ZeroCopySend + 'static>(
        subscriber: &Subscriber<Service, Self, H>,
    ) -> std::result::Result<Option<Sample<Service, Self, H>>, ReceiveError> {
        subscriber.receive()
    }
}
