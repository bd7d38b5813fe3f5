//! Receiving: [`Sub`] drains a topic and clears its wake-ups, [`HoldingSub`] can leave a
//! sample it cannot use yet in shared memory, and [`Ipc::publisher_probe`] counts a
//! topic's publishers ([`Ipc::row_publisher_probe`]: of a topic of [`crate::topics::TABLE`]).

use super::{Ipc, Result, Service, WakeSource, Wire, iox_err, wake::RECEIVED};
#[cfg(doc)]
use super::{IpcError, LOST_WAKEUP_GUARD};
use crate::message::{Fixed, FixedMessage, PayloadVisitor, Slice, SliceMessage};
use crate::topics::{Topic, TopicRow};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use std::cell::RefCell;
use std::fmt::Debug;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// A sample received on a [`Sub`]: a header `H` and payload `P` in shared memory.
pub type Received<P, H> = Sample<Service, P, H>;

impl Ipc {
    /// Opens a subscriber for fixed-size messages `T` on `topic`.
    ///
    /// It waits until the topic has a publisher and connects to it at once. iceoryx2
    /// connects a subscriber lazily (on its first receive); a publisher that floods a
    /// not-yet-connected subscriber's buffer drops the overflow. Connecting on creation
    /// closes that gap, provided every process creates its publishers before its
    /// subscribers (then no wait can form a cycle).
    ///
    /// # Errors
    /// As [`Ipc::publisher`], and [`IpcError::Timeout`] when no publisher appears.
    pub fn subscriber<T: Debug + ZeroCopySend + 'static>(
        &self,
        topic: &Topic,
    ) -> Result<Sub<T, ()>> {
        Sub::open(self, topic)
    }

    /// Opens a subscriber for fixed-size messages `T` on `topic` without waiting for a
    /// publisher: for a topic that may have none, whose newest sample (its history) is
    /// all that counts (`checkpoint`).
    ///
    /// # Errors
    /// As [`Ipc::publisher`].
    pub fn optional_subscriber<T: Debug + ZeroCopySend + 'static>(
        &self,
        topic: &Topic,
    ) -> Result<Sub<T, ()>> {
        Sub::open_now(self, topic)
    }

    /// Opens a subscriber for a header `H` plus a slice of `T` on `topic` without waiting
    /// for a publisher (see [`Ipc::optional_subscriber`]).
    ///
    /// # Errors
    /// As [`Ipc::publisher`].
    pub fn optional_slice_subscriber<H, T>(&self, topic: &Topic) -> Result<Sub<[T], H>>
    where
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + 'static,
    {
        Sub::open_now(self, topic)
    }

    /// Opens a subscriber for a header `H` plus a slice of `T` on `topic`; see
    /// [`Ipc::subscriber`].
    ///
    /// # Errors
    /// As [`Ipc::subscriber`].
    pub fn slice_subscriber<H, T>(&self, topic: &Topic) -> Result<Sub<[T], H>>
    where
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + 'static,
    {
        Sub::open(self, topic)
    }

    /// A probe counting the publishers `topic` has (payload `P`, user header `H`), for a
    /// process that accepts an input on one topic or another and waits to see which one
    /// is published (see [`Ipc::wait_until`]).
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the service cannot be opened with the stack's settings.
    pub fn publisher_probe<P, H>(&self, topic: &Topic) -> Result<impl Fn() -> usize + use<P, H>>
    where
        P: Wire + ?Sized,
        H: Debug + ZeroCopySend + 'static,
    {
        let service = self.pubsub::<P, H>(topic)?;
        Ok(move || service.dynamic_config().number_of_publishers())
    }

    /// [`Ipc::publisher_probe`] for the topic of `row`, with the payload type it names.
    ///
    /// # Errors
    /// As [`Ipc::publisher_probe`].
    pub fn row_publisher_probe(&self, row: &'static TopicRow) -> Result<PublisherCount> {
        row.payload.visit(Probe {
            ipc: self,
            topic: &row.topic,
        })
    }
}

/// A probe counting a topic's publishers.
pub type PublisherCount = Box<dyn Fn() -> usize>;

/// Opens [`Ipc::publisher_probe`] for a payload type named at run time.
struct Probe<'a> {
    ipc: &'a Ipc,
    topic: &'a Topic,
}

impl PayloadVisitor for Probe<'_> {
    type Output = Result<PublisherCount>;

    fn fixed<T: FixedMessage>(self, _: &'static Fixed<T>) -> Self::Output {
        Ok(Box::new(self.ipc.publisher_probe::<T, ()>(self.topic)?))
    }

    fn slice<H: SliceMessage>(self, _: &'static Slice<H>) -> Self::Output {
        Ok(Box::new(
            self.ipc.publisher_probe::<[H::Item], H>(self.topic)?,
        ))
    }
}

/// A subscriber on one topic, with the listener a `WaitSet` can sleep on.
pub struct Sub<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    subscriber: Subscriber<Service, P, H>,
    pub(super) listener: Listener<Service>,
    /// The listener fired since the last drain (set by [`Ipc::wake_loop`]).
    fired: AtomicBool,
    topic: &'static str,
}

impl<P, H> Sub<P, H>
where
    P: Wire + ?Sized,
    H: Debug + ZeroCopySend + 'static,
{
    fn open(ipc: &Ipc, topic: &Topic) -> Result<Self> {
        let service = ipc.pubsub::<P, H>(topic)?;
        ipc.wait_until(
            || format!("a publisher on {}", topic.name),
            || service.dynamic_config().number_of_publishers() > 0,
        )?;
        Self::connect(ipc, topic, &service)
    }

    /// Opens a subscriber at once, publisher or not.
    fn open_now(ipc: &Ipc, topic: &Topic) -> Result<Self> {
        Self::connect(ipc, topic, &ipc.pubsub::<P, H>(topic)?)
    }

    /// Creates the subscriber on `service`, connects it and its listener.
    fn connect(
        ipc: &Ipc,
        topic: &Topic,
        service: &iceoryx2::service::port_factory::publish_subscribe::PortFactory<Service, P, H>,
    ) -> Result<Self> {
        let subscriber = service
            .subscriber_builder()
            .buffer_size(topic.buffer)
            .create()
            .map_err(iox_err(format!("create subscriber on {}", topic.name)))?;
        subscriber
            .update_connections()
            .map_err(iox_err(format!("connect subscriber on {}", topic.name)))?;
        let listener = ipc
            .event(topic)?
            .listener_builder()
            .create()
            .map_err(iox_err(format!("create listener on {}", topic.name)))?;
        Ok(Self {
            subscriber,
            listener,
            fired: AtomicBool::new(false),
            topic: topic.name,
        })
    }

    /// The topic name (without prefix), for logs.
    pub fn topic(&self) -> &'static str {
        self.topic
    }

    /// Takes every pending sample, in publication order.
    ///
    /// When the listener fired (see [`Ipc::wake_loop`]) or samples are pending, it first
    /// clears the listener's wake-ups: before receiving, so that a sample sent meanwhile
    /// wakes the loop again. A drain that finds neither costs no syscall. Clearing on
    /// pending samples also resets a listener that iceoryx2 left "notified" without a
    /// wake-up on its socket (see [`LOST_WAKEUP_GUARD`]): such a listener never fires
    /// again until cleared, so its samples would otherwise only be seen when another
    /// listener or the interval wakes the loop.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when clearing the listener or receiving fails.
    pub fn drain(&self, mut each: impl FnMut(Received<P, H>)) -> Result<usize> {
        self.drain_while(|sample| {
            each(sample);
            true
        })
    }

    /// As [`Sub::drain`], but stops after a sample for which `each` returns false: the
    /// samples after it wait in the subscriber's buffer (their publisher waits once that
    /// is full) for the next drain. Returns the number taken.
    ///
    /// # Errors
    /// As [`Sub::drain`].
    pub fn drain_while(&self, mut each: impl FnMut(Received<P, H>) -> bool) -> Result<usize> {
        self.take(|sample| {
            if each(sample) {
                ControlFlow::Continue(())
            } else {
                ControlFlow::Break(None)
            }
        })
        .map(|(n, _)| n)
    }

    /// True when samples wait in the subscriber's buffer.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the subscriber cannot be queried.
    pub fn pending(&self) -> Result<bool> {
        self.subscriber
            .has_samples()
            .map_err(iox_err(format!("look for samples on {}", self.topic)))
    }

    /// This subscriber, able to hold samples back ([`HoldingSub`]).
    pub fn holding(self) -> HoldingSub<P, H> {
        HoldingSub {
            sub: self,
            held: RefCell::new(None),
        }
    }

    /// Empties the listener: a listener left with wake-ups makes the `WaitSet` fire again
    /// at once, for ever.
    fn clear_wakeups(&self) -> Result<()> {
        self.listener
            .try_wait(|_| {})
            .map(|_| ())
            .map_err(iox_err(format!("clear the wake-ups on {}", self.topic)))
    }

    /// Receives until `each` breaks, perhaps handing a sample back (returned, with the
    /// count received).
    fn take(
        &self,
        mut each: impl FnMut(Received<P, H>) -> ControlFlow<Option<Received<P, H>>>,
    ) -> Result<(usize, Option<Received<P, H>>)> {
        let fired = self.fired.swap(false, Ordering::Relaxed);
        if !fired && !self.pending()? {
            return Ok((0, None));
        }
        self.clear_wakeups()?;
        let mut n = 0;
        while let Some(sample) =
            P::receive(&self.subscriber).map_err(iox_err(format!("receive on {}", self.topic)))?
        {
            n += 1;
            RECEIVED.fetch_add(1, Ordering::Relaxed);
            if let ControlFlow::Break(held) = each(sample) {
                return Ok((n, held));
            }
        }
        Ok((n, None))
    }
}

/// A [`Sub`] whose consumer can leave a sample it cannot use yet in shared memory: the
/// drain stops at it, and offers it again first on the next drain. The samples after it
/// wait in the subscriber's buffer meanwhile (their publisher waits once that is full).
/// One sample at a time: iceoryx2 lends a subscriber at most two by default.
pub struct HoldingSub<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    sub: Sub<P, H>,
    /// The sample held back, and when it was first held (in a `RefCell`: the wake loop
    /// borrows the subscriber while its callback drains it).
    held: RefCell<Option<(Received<P, H>, Instant)>>,
}

/// What a [`HoldingSub::drain`] callback did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Taken {
    /// Used up: go on to the next sample.
    Done,
    /// Not usable yet: hold it and stop draining.
    Hold,
}

impl<P, H> HoldingSub<P, H>
where
    P: Wire + ?Sized,
    H: Debug + ZeroCopySend + 'static,
{
    /// Offers the held sample again, then the pending ones in publication order, to
    /// `each`, until it holds one. `each` also gets the time the sample was first held
    /// (`None` for a sample it has not seen).
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when clearing the listener or receiving fails.
    pub fn drain(
        &self,
        mut each: impl FnMut(&Received<P, H>, Option<Instant>) -> Taken,
    ) -> Result<()> {
        let held = self.held.take();
        if let Some((sample, since)) = held
            && each(&sample, Some(since)) == Taken::Hold
        {
            self.held.replace(Some((sample, since)));
            // The samples behind it wait; their wake-ups must not (the next sample's
            // notification, or anyone else's, wakes the loop to offer it again).
            if self.sub.fired.swap(false, Ordering::Relaxed) {
                self.sub.clear_wakeups()?;
            }
            return Ok(());
        }
        let (_, held) = self.sub.take(|sample| match each(&sample, None) {
            Taken::Done => ControlFlow::Continue(()),
            Taken::Hold => ControlFlow::Break(Some(sample)),
        })?;
        self.held
            .replace(held.map(|sample| (sample, Instant::now())));
        Ok(())
    }

    /// True while a sample is held back.
    pub fn holds(&self) -> bool {
        self.held.borrow().is_some()
    }

    /// True while a sample is held back or samples wait in the subscriber's buffer.
    ///
    /// # Errors
    /// As [`Sub::pending`].
    pub fn pending(&self) -> Result<bool> {
        Ok(self.holds() || self.sub.pending()?)
    }
}

impl<P, H> WakeSource for HoldingSub<P, H>
where
    P: Wire + ?Sized,
    H: Debug + ZeroCopySend + 'static,
{
    fn listener(&self) -> &Listener<Service> {
        self.sub.listener()
    }

    fn fired(&self) {
        self.sub.fired();
    }
}

impl<P, H> WakeSource for Sub<P, H>
where
    P: Wire + ?Sized,
    H: Debug + ZeroCopySend + 'static,
{
    fn listener(&self) -> &Listener<Service> {
        &self.listener
    }

    fn fired(&self) {
        self.fired.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::EndOfStream;
    use crate::ipc::testing::{TestStack, eos_ports, on_thread};
    use crate::ipc::{Flow, IpcError, LOST_WAKEUP_GUARD};

    /// A held sample is offered again first on the next drain, with the time it was
    /// first held; the samples after it wait in the subscriber until then, in order.
    #[test]
    fn a_held_sample_comes_first_on_the_next_drain_and_the_rest_wait_behind_it() {
        let test = TestStack::new("hld");
        let offers = on_thread(test.config(), "a drain hung", |ipc| {
            let (out, sub) = eos_ports(ipc)?;
            let sub = sub.holding();
            let send = |k: u32| {
                out.send(EndOfStream {
                    stream: k,
                    ..Default::default()
                })
            };
            (0..3).try_for_each(send)?;
            let mut offers = Vec::new();
            for drain in 0..3 {
                sub.drain(|s, held_since| {
                    let k = s.payload().stream;
                    offers.push((drain, k, held_since.is_some()));
                    // 1 waits one drain; 3 waits for ever.
                    if (k == 1 && held_since.is_none()) || k == 3 {
                        Taken::Hold
                    } else {
                        Taken::Done
                    }
                })?;
                if drain == 0 {
                    assert!(sub.holds());
                    (3..5).try_for_each(send)?;
                }
            }
            assert!(sub.holds());
            Ok(offers)
        });
        assert_eq!(
            offers,
            Ok(vec![
                (0, 0, false),
                (0, 1, false),
                (1, 1, true),
                (1, 2, false),
                (1, 3, false),
                (2, 3, true),
            ]),
            "(drain, sample, offered before)"
        );
    }

    /// While a sample is held, the wake-ups of the samples behind it are cleared and the
    /// loop sleeps; before, a wake-up that arrived during a hold kept the `WaitSet`
    /// firing, and the loop was called back about a million times a second.
    #[test]
    fn a_held_sample_lets_the_wake_loop_sleep() {
        let test = TestStack::new("hls");
        let calls = on_thread(test.config(), "the loop hangs", |ipc| {
            let (out, sub) = eos_ports(ipc)?;
            let sub = sub.holding();
            out.send(EndOfStream::default())?;
            let started = Instant::now();
            let mut calls = 0;
            ipc.wake_loop::<IpcError>(&[&sub], None, || {
                calls += 1;
                sub.drain(|_, _| Taken::Hold)?;
                if calls == 1 {
                    out.send(EndOfStream::default())?; // wakes the loop during the hold
                }
                Ok(if started.elapsed() > 3 * LOST_WAKEUP_GUARD {
                    Flow::Stop
                } else {
                    Flow::Continue
                })
            })?;
            Ok(calls)
        })
        .expect("the loop failed");
        assert!(
            calls <= 10,
            "{calls} calls in {:?}: the loop does not sleep while a sample is held",
            3 * LOST_WAKEUP_GUARD
        );
    }
}
