//! Publishing: [`Pub`] sends on a topic and wakes its subscribers (at once, or
//! [coalescing](Pub::coalescing) a burst into one wake-up), and waits rather than lose a
//! sample when a subscriber's buffer is full.

#[cfg(doc)]
use super::Sub;
use super::{Ipc, IpcError, Result, Service, Wire, iox_err, shutdown};
use crate::topics::Topic;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::PortFactory as _;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use std::cell::Cell;
use std::fmt::Debug;
use std::time::{Duration, Instant};

impl Ipc {
    /// Opens a publisher for fixed-size messages `T` on `topic`.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the service cannot be opened with the stack's settings.
    pub fn publisher<T: Debug + ZeroCopySend + 'static>(
        &self,
        topic: &Topic,
    ) -> Result<Pub<T, ()>> {
        Pub::open(self, topic)
    }

    /// Opens a publisher for a header `H` plus a slice of `T` on `topic`.
    ///
    /// # Errors
    /// As [`Ipc::publisher`].
    pub fn slice_publisher<H, T>(&self, topic: &Topic) -> Result<Pub<[T], H>>
    where
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + Copy + 'static,
    {
        Pub::open(self, topic)
    }
}

/// A publisher on one topic, with the notifier that wakes its subscribers.
pub struct Pub<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    service: PortFactory<Service, P, H>,
    publisher: Publisher<Service, P, H>,
    notifier: Notifier<Service>,
    topic: &'static str,
    /// Wake-ups sent at most once per this period ([`Pub::coalescing`]); `None`: one per
    /// sample.
    coalesce: Option<Duration>,
    /// Samples sent since the last wake-up, at most `max_deferred` (a quarter of the
    /// subscribers' buffer).
    deferred: Cell<usize>,
    max_deferred: usize,
    last_notified: Cell<Option<Instant>>,
}

/// The wake-up period of a [`Pub::coalescing`] publisher. As fast as possible a filter
/// step takes ≈ 70 µs: the client then wakes for every few poses instead of each one.
/// In real time samples are milliseconds apart, so each still wakes its subscribers at
/// once.
pub const COALESCING_PERIOD: Duration = Duration::from_micros(100);

impl<P, H> Pub<P, H>
where
    P: Wire + ?Sized,
    H: Debug + ZeroCopySend + 'static,
{
    fn open(ipc: &Ipc, topic: &Topic) -> Result<Self> {
        let service = ipc.pubsub::<P, H>(topic)?;
        let publisher = P::create_publisher(&service, topic)
            .map_err(iox_err(format!("create publisher on {}", topic.name)))?;
        let notifier = ipc
            .event(topic)?
            .notifier_builder()
            .create()
            .map_err(iox_err(format!("create notifier on {}", topic.name)))?;
        Ok(Self {
            service,
            publisher,
            notifier,
            topic: topic.name,
            coalesce: None,
            deferred: Cell::new(0),
            max_deferred: (topic.buffer / 4).max(1),
            last_notified: Cell::new(None),
        })
    }

    /// This publisher, waking its subscribers at most once per [`COALESCING_PERIOD`]
    /// (and at least every quarter of their buffer, so none fills up unwoken): a sample
    /// sent sooner after the last wake-up is published at once but announced with the
    /// next wake-up. The owner must call [`Pub::flush`] before it sleeps or stops
    /// sending. A subscriber that wakes drains every sample there is, so a burst costs
    /// it one wake-up instead of one per sample.
    pub fn coalescing(mut self) -> Self {
        self.coalesce = Some(COALESCING_PERIOD);
        self
    }

    /// Wakes the subscribers for samples sent without a wake-up of their own.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the notification fails.
    pub fn flush(&self) -> Result<()> {
        if self.deferred.get() > 0 {
            self.notify_now()?;
        }
        Ok(())
    }

    /// Number of subscribers connected right now.
    pub fn subscribers(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }

    /// Waits until at least `n` subscribers are connected, so that nothing published
    /// afterwards is lost on a subscriber that was still starting. (A [`Sub`] connects as
    /// it is created, see [`Ipc::subscriber`], so every counted subscriber is ready.)
    ///
    /// # Errors
    /// [`IpcError::Timeout`] after the wait timeout, [`IpcError::Shutdown`] on a signal.
    pub fn wait_for_subscribers(&self, ipc: &Ipc, n: usize) -> Result<()> {
        ipc.wait_until(
            || format!("{n} subscriber(s) on {}", self.topic),
            || self.subscribers() >= n,
        )
    }

    /// Waits until every subscriber has left (bounded by the wait timeout), for a
    /// process about to exit. A slice topic's samples live in the publisher's growable
    /// data segment, which a subscriber maps only when it receives from it: were the
    /// publisher to exit first, samples not yet received would be lost (iceoryx2 logs
    /// "Lost chunk"). Consumers leave once they have everything, so this wait is short;
    /// one that never leaves (a viewer) costs the wait timeout, with a warning.
    ///
    /// # Errors
    /// [`IpcError::Shutdown`] on a signal (a timeout is not an error).
    pub fn wait_until_unsubscribed(&self, ipc: &Ipc) -> Result<()> {
        let left = ipc.wait_until(
            || format!("the subscribers of {} to leave", self.topic),
            || self.subscribers() == 0,
        );
        match left {
            Err(IpcError::Timeout { what, waited }) => {
                tracing::warn!(?waited, "gave up waiting for {what}");
                Ok(())
            }
            other => other,
        }
    }

    /// Wakes the subscribers after a send, unless [coalescing](Pub::coalescing) defers
    /// it.
    fn notify(&self) -> Result<()> {
        if let Some(period) = self.coalesce {
            let deferred = self.deferred.get() + 1;
            let recent = (self.last_notified.get()).is_some_and(|t| t.elapsed() < period);
            if recent && deferred < self.max_deferred {
                self.deferred.set(deferred);
                return Ok(());
            }
        }
        self.notify_now()
    }

    fn notify_now(&self) -> Result<()> {
        self.deferred.set(0);
        if self.coalesce.is_some() {
            self.last_notified.set(Some(Instant::now()));
        }
        self.notifier
            .notify()
            .map(|_| ())
            .map_err(iox_err(format!("notify on {}", self.topic)))
    }
}

/// Retries of a full subscriber buffer made at once, before [`BACKPRESSURE_NAP`]s.
const QUICK_RETRIES: u64 = 16;
/// Sleep between later retries of a full subscriber buffer.
const BACKPRESSURE_NAP: Duration = Duration::from_micros(50);

/// Keeps retrying a full subscriber buffer, unless the process is shutting down. After
/// [`QUICK_RETRIES`] it naps between retries: iceoryx2 would otherwise yield in a loop
/// (up to 10 000 times), which on a machine with fewer cores than processes takes the
/// CPU from the very subscriber it waits for (measured: a fifth of the stack's CPU time
/// in `sched_yield` as fast as possible on 2 cores).
pub(super) fn retry_unless_shutting_down(info: &BackpressureInfo) -> BackpressureAction {
    if shutdown::requested() {
        return BackpressureAction::DiscardData;
    }
    if info.retries >= QUICK_RETRIES {
        std::thread::sleep(BACKPRESSURE_NAP);
    }
    BackpressureAction::Retry
}

impl<T: Debug + ZeroCopySend + 'static> Pub<T, ()> {
    /// Publishes one message and wakes the subscribers.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the sample cannot be loaned or sent.
    pub fn send(&self, value: T) -> Result<()> {
        self.publisher
            .send_copy(value)
            .map_err(iox_err(format!("send on {}", self.topic)))?;
        self.notify()
    }
}

impl<H, T> Pub<[T], H>
where
    H: Debug + ZeroCopySend + Default + 'static,
    T: Debug + ZeroCopySend + Copy + 'static,
{
    /// Publishes `header` with `items` and wakes the subscribers. The items are written
    /// once, straight into shared memory.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the sample cannot be loaned or sent.
    pub fn send(&self, header: H, items: &[T]) -> Result<()> {
        let mut sample = self
            .publisher
            .loan_slice_uninit(items.len())
            .map_err(iox_err(format!("loan on {}", self.topic)))?;
        *sample.user_header_mut() = header;
        let sample = sample.write_from_slice(items);
        sample
            .send()
            .map_err(iox_err(format!("send on {}", self.topic)))?;
        self.notify()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::EndOfStream;
    use crate::ipc::testing::{TestStack, eos_ports, on_thread};
    use crate::topics;

    /// A listener that nothing ever clears (one whose subscriber is never drained or
    /// waited on) never makes its notifier block or fail, however many samples go by:
    /// after the first wake-up its notifiers skip the datagram.
    #[test]
    fn a_listener_never_cleared_never_blocks_its_notifier() {
        let test = TestStack::new("unc");
        let seen = on_thread(test.config(), "a notifier blocked", |ipc| {
            let (out, sub) = eos_ports(ipc)?;
            let _never_cleared = ipc
                .event(&topics::END_OF_STREAM)?
                .listener_builder()
                .create()
                .map_err(iox_err("create listener"))?;
            let mut seen = 0;
            for _ in 0..2000 {
                out.send(EndOfStream::default())?;
                seen += sub.drain(|_| {})?;
            }
            Ok(seen)
        });
        assert_eq!(seen, Ok(2000));
    }

    /// A coalescing publisher may leave samples unannounced, but never more than a
    /// quarter of the subscriber's buffer in a row, and a flush announces them; however
    /// fast or slow the sends are (the period only decides how many share a wake-up).
    #[test]
    fn a_coalescing_publisher_wakes_at_least_every_quarter_buffer_and_on_flush() {
        let test = TestStack::new("coa");
        let most = on_thread(test.config(), "a send hung", |ipc| {
            let (out, sub) = eos_ports(ipc)?;
            let out = out.coalescing();
            let woken = || -> Result<bool> {
                let mut events = 0;
                sub.listener
                    .try_wait(|_| events += 1)
                    .map_err(iox_err("clear"))?;
                Ok(events > 0)
            };
            let mut most = 0;
            for _ in 0..50 {
                woken()?;
                let mut sent = 0;
                while sent < topics::END_OF_STREAM.buffer {
                    out.send(EndOfStream::default())?;
                    sent += 1;
                    if woken()? {
                        break;
                    }
                }
                most = most.max(sent);
                out.send(EndOfStream::default())?;
                out.flush()?;
                assert!(woken()?, "a flush left a sample unannounced");
                assert!(!woken()?, "nothing left to announce");
                out.flush()?;
                assert!(
                    !woken()?,
                    "a flush with nothing deferred woke the subscriber"
                );
                sub.drain(|_| {})?;
            }
            Ok(most)
        });
        let quarter = topics::END_OF_STREAM.buffer / 4;
        assert!(
            most.as_ref().is_ok_and(|&n| (1..=quarter).contains(&n)),
            "most samples sent before a wake-up: {most:?}, at most {quarter} allowed"
        );
    }
}
