//! The loop of a sensor that derives its output from ground truth: take every
//! ground-truth sample in order, hand it to the sensor, and finish when the ground-truth
//! stream has ended.

use crate::Scenario;
use crate::args::SimArgs;
use fastslam_protocol::ipc::{Ended, Flow, Ipc, Pub, Sub, Wire};
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::{EndOfStream, GroundTruth, Header, StreamId, topics, validate};
use iceoryx2::prelude::ZeroCopySend;
use std::fmt::Debug;

/// A simulated sensor process fed by ground truth: its scenario and seed, its stack
/// connection, and the end-of-stream it owes its subscribers.
pub struct SensorProcess {
    /// The scenario being simulated.
    pub scenario: Scenario,
    /// The run's seed.
    pub seed: u64,
    /// The process's connection to the stack.
    pub ipc: Ipc,
    eos: Pub<EndOfStream, ()>,
    stream: StreamId,
    wait_subscribers: usize,
}

impl SensorProcess {
    /// Loads the scenario and joins the stack as `name`, publishing stream `stream`.
    /// The caller opens its output publisher next, then calls [`SensorProcess::relay`]
    /// (publishers before subscribers, see `Ipc::subscriber`).
    ///
    /// # Errors
    /// Scenario or IPC errors.
    pub fn open(args: &SimArgs, name: &str, stream: StreamId) -> anyhow::Result<Self> {
        let (scenario, seed) = args.scenario()?;
        let ipc = Ipc::open(&args.stack.stack(), name, args.wait_timeout())?;
        let eos = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
        let wait_subscribers = args.wait_subscribers;
        Ok(Self {
            scenario,
            seed,
            ipc,
            eos,
            stream,
            wait_subscribers,
        })
    }

    /// Subscribes to ground truth, waits for `output`'s subscribers, then calls `each`
    /// with every ground-truth sample and the sequence number its output would get;
    /// `each` returns the header it published, if any. Ends with the end-of-stream.
    ///
    /// # Errors
    /// IPC failures or the first error of `each`.
    pub fn relay<P, H>(
        &self,
        output: &Pub<P, H>,
        mut each: impl FnMut(&GroundTruth, u64) -> anyhow::Result<Option<Header>>,
    ) -> anyhow::Result<()>
    where
        P: Wire + ?Sized,
        H: Debug + ZeroCopySend + 'static,
    {
        let truth = GroundTruthFollower::open(&self.ipc)?;
        output.wait_for_subscribers(&self.ipc, self.wait_subscribers)?;
        let mut last: Option<Header> = None;
        truth.follow(
            &self.ipc,
            |gt| {
                if let Some(sent) = each(gt, last.map_or(0, |h| h.seq + 1))? {
                    last = Some(sent);
                }
                Ok(())
            },
            || Ok(output.flush()?),
        )?;
        self.eos.send(EndOfStream::new(self.stream, last))?;
        tracing::info!(messages = last.map_or(0, |h| h.seq + 1), stream = ?self.stream, "finished");
        output.wait_until_unsubscribed(&self.ipc)?;
        Ok(())
    }
}

/// Subscriptions to ground truth and its end-of-stream.
struct GroundTruthFollower {
    truth: Sub<GroundTruth, ()>,
    eos: Sub<EndOfStream, ()>,
}

impl GroundTruthFollower {
    /// Subscribes (waiting for the truth simulator's publishers to exist).
    ///
    /// # Errors
    /// IPC failures or a timeout.
    fn open(ipc: &Ipc) -> anyhow::Result<Self> {
        // End-of-stream first: the truth simulator starts once this process subscribes to
        // ground truth, and a short route may end before a later subscription exists.
        let eos = ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?;
        let truth = ipc.subscriber::<GroundTruth>(&topics::GROUND_TRUTH)?;
        Ok(Self { truth, eos })
    }

    /// Calls `each` for every valid ground-truth sample, in order, until the ground-truth
    /// stream ends (or a signal arrives), and `flush` after each wake-up's samples (before
    /// the loop sleeps again). Invalid samples are logged and skipped.
    ///
    /// # Errors
    /// IPC failures, or the first error `each` returns.
    fn follow(
        &self,
        ipc: &Ipc,
        mut each: impl FnMut(&GroundTruth) -> anyhow::Result<()>,
        flush: impl Fn() -> anyhow::Result<()>,
    ) -> anyhow::Result<Ended> {
        let mut end = StreamEnd::default();
        let mut order = validate::StampOrder::default();
        ipc.wake_loop(&[&self.truth, &self.eos], None, || {
            let mut failure = None;
            self.truth.drain(|sample| {
                let gt = *sample.payload();
                end.saw(gt.header.seq);
                match validate::ground_truth(&gt).and_then(|()| order.accept(gt.header.stamp_ns)) {
                    Err(reason) => {
                        tracing::warn!(seq = gt.header.seq, %reason, "ground truth skipped")
                    }
                    Ok(()) if failure.is_none() => failure = each(&gt).err(),
                    Ok(()) => {}
                }
            })?;
            self.eos.drain(|sample| {
                if StreamId::from_u32(sample.payload().stream) == Some(StreamId::GroundTruth) {
                    end.announce(sample.payload());
                }
            })?;
            flush()?;
            match failure {
                Some(e) => Err(e),
                None if end.finished() => Ok(Flow::Stop),
                None => Ok(Flow::Continue),
            }
        })
    }
}
