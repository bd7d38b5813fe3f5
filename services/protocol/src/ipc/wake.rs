//! The wake loop: how a process sleeps until one of its subscribers has samples
//! ([`Ipc::wake_loop`], [`WakeSource`]), or busy-polls or spins instead, and how it
//! guards against a lost wake-up.

#[cfg(doc)]
use super::Sub;
use super::{Ipc, IpcError, Service, iox_err, shutdown};
use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

impl Ipc {
    /// Sleeps until the listener of any of `sources` fires (or `tick` elapses, if given)
    /// and calls `on_wake` once per wake-up, until it returns [`Flow::Stop`] or a signal
    /// arrives.
    ///
    /// `on_wake` must drain every source on every call: wake-ups are not per sample, one
    /// wake-up may stand for several sources, and `on_wake` is also called at least every
    /// [`LOST_WAKEUP_GUARD`]. The loop only marks the sources whose listener fired
    /// ([`WakeSource::fired`]); their next [`Sub::drain`] clears the listener before it
    /// receives, so a wake-up costs one clearing per source that fired or has samples,
    /// not one per source.
    ///
    /// A connection that is [busy polling](Ipc::busy_polling) calls `on_wake` over and
    /// over instead, without sleeping; `tick` is then moot.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the WaitSet fails, or whatever `on_wake` returns.
    pub fn wake_loop<E: From<IpcError>>(
        &self,
        sources: &[&dyn WakeSource],
        tick: Option<Duration>,
        mut on_wake: impl FnMut() -> std::result::Result<Flow, E>,
    ) -> std::result::Result<Ended, E> {
        if self.busy_poll {
            return Ok(Self::poll(&mut on_wake, None)?.unwrap_or(Ended::Done));
        }
        let waitset = WaitSetBuilder::new()
            .create::<Service>()
            .map_err(iox_err("create waitset"))?;
        let mut guards = Vec::with_capacity(sources.len());
        for s in sources {
            guards.push(
                waitset
                    .attach_notification(s.listener())
                    .map_err(iox_err("attach listener"))?,
            );
        }
        let period = tick.map_or(LOST_WAKEUP_GUARD, |t| t.min(LOST_WAKEUP_GUARD));
        let _tick_guard = waitset
            .attach_interval(period)
            .map_err(iox_err("attach interval"))?;
        // Samples published before this loop started may raise no new event: look once
        // first (a drain that finds samples clears its listener).
        if on_wake()? == Flow::Stop {
            return Ok(Ended::Done);
        }
        let mut woke = true;
        loop {
            if woke
                && !self.spin.is_zero()
                && let Some(ended) = Self::poll(&mut on_wake, Some(self.spin))?
            {
                return Ok(ended);
            }
            let mut fired = false;
            let result = waitset
                .wait_and_process_once(|id| {
                    fired = true;
                    if let Some((_, s)) = guards
                        .iter()
                        .zip(sources)
                        .find(|(g, _)| id.has_event_from(g))
                    {
                        s.fired();
                    } // otherwise the interval
                    CallbackProgression::Continue
                })
                .map_err(iox_err("wait"))?;
            match result {
                WaitSetRunResult::TerminationRequest => {
                    shutdown::request();
                    return Ok(Ended::Signal);
                }
                // EINTR: SIGINT or SIGTERM, or another signal iceoryx2 catches, which only
                // interrupted the wait (see `shutdown`).
                WaitSetRunResult::Interrupt if shutdown::requested() => {
                    return Ok(Ended::Signal);
                }
                // `StopRequest` cannot happen: the callback never stops.
                WaitSetRunResult::Interrupt
                | WaitSetRunResult::StopRequest
                | WaitSetRunResult::AllEventsHandled => {}
            }
            // A timed wait can end before the interval's deadline is due: nothing fired.
            // Spin again only after a wake-up that brought samples: not after the interval,
            // nor after a notification whose sample the last spin already took.
            let received = RECEIVED.load(Ordering::Relaxed);
            if fired && on_wake()? == Flow::Stop {
                return Ok(Ended::Done);
            }
            woke = RECEIVED.load(Ordering::Relaxed) != received;
        }
    }

    /// Calls `on_wake` over and over without sleeping: for ever when `quiet` is `None`,
    /// else until no sample has arrived for `quiet` (each sample received restarts that
    /// period). `Some` when the loop has to end. No listener is attached, so a drain
    /// clears a listener only when it finds samples (see [`Sub::drain`]).
    ///
    /// Between two looks the thread yields: a sensor process woken on the same core runs
    /// at once instead of waiting for the poller's time slice to end. With a bare spin,
    /// two pollers on a 2-core machine delayed the sensors' samples, and the latency's
    /// p99 got worse rather than better (BENCHMARKS.md, "Busy polling").
    fn poll<E>(
        on_wake: &mut impl FnMut() -> std::result::Result<Flow, E>,
        quiet: Option<Duration>,
    ) -> std::result::Result<Option<Ended>, E> {
        let mut last_sample = Instant::now();
        while quiet.is_none_or(|q| last_sample.elapsed() < q) {
            std::thread::yield_now();
            let received = RECEIVED.load(Ordering::Relaxed);
            if on_wake()? == Flow::Stop {
                return Ok(Some(Ended::Done));
            }
            if shutdown::requested() {
                return Ok(Some(Ended::Signal));
            }
            if RECEIVED.load(Ordering::Relaxed) != received {
                last_sample = Instant::now();
            }
        }
        Ok(None)
    }
}

/// Samples this process has received on any [`Sub`]: a [spinning](Ipc::spinning) wake
/// loop polls on while it grows.
pub(super) static RECEIVED: AtomicU64 = AtomicU64::new(0);

/// What an [`Ipc::wake_loop`] sleeps on: a [`Sub`], whose listener the loop attaches to
/// its `WaitSet`. A trait so that subscribers of different types share one loop.
pub trait WakeSource {
    /// The listener the loop attaches.
    fn listener(&self) -> &Listener<Service>;
    /// Called by the loop when the listener fired; the next drain clears its wake-ups
    /// (otherwise the `WaitSet` keeps firing).
    fn fired(&self);
}

/// The longest [`Ipc::wake_loop`] sleeps without looking at its subscribers.
///
/// iceoryx2 0.10 can swallow a notification: when a notifier's `notify` runs while the
/// listener is draining (between the listener resetting its state from "notified" to
/// "idle" and emptying its socket), the listener consumes the new datagram but the state
/// is left "notified", so the next `notify` sends no datagram and the `WaitSet` does not
/// wake (iceoryx2-cal `event/common.rs`, `notify` and `drain_events`). A stack whose
/// loops only slept on listeners hung once (in some hundreds of runs) with the odometry
/// sensor asleep and the truth's end of stream unprocessed, which fits this. Looking
/// again after this period turns a lost wake-up into a short delay; the extra wake-ups
/// cost nothing measurable.
pub const LOST_WAKEUP_GUARD: Duration = Duration::from_millis(100);

/// What a [`Ipc::wake_loop`] callback wants next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Keep sleeping and waking.
    Continue,
    /// The work is done: leave the loop.
    Stop,
}

/// Why a [`Ipc::wake_loop`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The callback said it was done.
    Done,
    /// SIGINT or SIGTERM arrived.
    Signal,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::EndOfStream;
    use crate::ipc::Result;
    use crate::ipc::testing::{TestStack, eos_ports, on_thread};
    use crate::topics;

    /// Two listeners that both fired make one call of `on_wake` (which sees both
    /// samples), and the loop then sleeps until the next tick instead of calling again
    /// at once (both drains cleared their listeners). Samples sent before the loop are
    /// seen by its first look, and leave no wake-up behind.
    #[test]
    fn wake_loop_calls_back_once_per_wake_up_and_then_sleeps() {
        let test = TestStack::new("wlo");
        let calls = on_thread(test.config(), "the loop hangs", |ipc| {
            let eos_out = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
            let status_out = ipc.publisher::<crate::ServiceStatus>(&topics::STATUS)?;
            let eos = ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?;
            let status = ipc.subscriber::<crate::ServiceStatus>(&topics::STATUS)?;
            let send_both = || -> Result<()> {
                eos_out.send(EndOfStream::default())?;
                status_out.send(crate::ServiceStatus::default())
            };
            send_both()?;
            let started = Instant::now();
            let mut calls = Vec::new();
            ipc.wake_loop::<IpcError>(&[&eos, &status], None, || {
                let seen = eos.drain(|_| {})? + status.drain(|_| {})?;
                calls.push((started.elapsed(), seen));
                if calls.len() == 1 {
                    send_both()?; // both listeners fire during the next wait
                }
                Ok(if calls.len() == 3 {
                    Flow::Stop
                } else {
                    Flow::Continue
                })
            })?;
            Ok(calls)
        })
        .expect("the loop failed");
        let seen: Vec<usize> = calls.iter().map(|c| c.1).collect();
        assert_eq!(seen, [2, 2, 0], "samples seen per call: {calls:?}");
        // The third call can only be the interval's (the first is due a guard period
        // after the loop started); one right after the second would be a wasted wake-up.
        assert!(
            calls[2].0 >= LOST_WAKEUP_GUARD / 2,
            "on_wake called again without a new sample: {calls:?}"
        );
    }

    /// A spinning poll takes a burst of samples as they come and ends once no sample has
    /// arrived for its period: by then it has seen every sample of the burst, although
    /// the burst lasts longer than the period (each sample starts the period again).
    #[test]
    fn a_spinning_poll_lasts_until_the_inputs_go_quiet() {
        let test = TestStack::new("spn");
        let stack = test.config();
        let (burst, gap, quiet) = (15, Duration::from_millis(100), Duration::from_secs(1));
        let sender = std::thread::spawn(move || -> std::result::Result<(), String> {
            let run = || -> Result<()> {
                let ipc = Ipc::open(&stack, "sender", Duration::from_secs(5))?;
                let out = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
                out.wait_for_subscribers(&ipc, 1)?;
                for _ in 0..burst {
                    out.send(EndOfStream::default())?;
                    std::thread::sleep(gap);
                }
                Ok(())
            };
            run().map_err(|e| e.to_string())
        });
        let seen = on_thread(test.config(), "the poll never ended", move |ipc| {
            let sub = ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?;
            let mut seen = 0;
            let ended = Ipc::poll(
                &mut || -> Result<Flow> {
                    seen += sub.drain(|_| {})?;
                    Ok(Flow::Continue)
                },
                Some(quiet),
            )?;
            assert_eq!(ended, None, "the poll ended on its own");
            Ok(seen)
        });
        assert_eq!(sender.join().expect("the sender panicked"), Ok(()));
        assert_eq!(seen, Ok(burst), "samples seen when the poll stopped");
    }

    /// Without notifications a wake loop still looks again (see [`LOST_WAKEUP_GUARD`]);
    /// before the guard this loop slept forever.
    #[test]
    fn wake_loop_looks_again_when_no_notification_arrives() {
        let test = TestStack::new("wlg");
        let ended = on_thread(
            test.config(),
            "the loop never woke up without a notification",
            |ipc| {
                let (_publisher, sub) = eos_ports(ipc)?;
                let mut calls = 0;
                ipc.wake_loop::<IpcError>(&[&sub], None, || {
                    calls += 1;
                    Ok(if calls == 3 {
                        Flow::Stop
                    } else {
                        Flow::Continue
                    })
                })
            },
        );
        assert_eq!(ended, Ok(Ended::Done));
    }
}
