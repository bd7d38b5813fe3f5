//! The loop of a sensor that derives its output from ground truth: take every
//! ground-truth sample in order, hand it to the sensor, send what it makes, and finish
//! when the ground-truth stream has ended and every subscriber has left.
//!
//! A sensor keeps what it sent since the service's last checkpoint (the `checkpoint`
//! topic says what that covers): when a resumed service asks, the sensor sends it all
//! again, and its end-of-stream if it had ended, so a service resumed from its checkpoint
//! loses nothing. When a subscriber dies (its node is dead: killed, crashed; one that
//! leaves is simply gone) the sensor holds new messages back until a resumed service has
//! asked, so that what it keeps stays short. What it keeps is bounded ([`ResendArgs`]);
//! beyond the bound the oldest is forgotten but for the first, the last input the
//! checkpoint holds, with which a resend starts: the resumed service counts what is
//! missing after it as lost.

use crate::Scenario;
use crate::args::SimArgs;
use fastslam_protocol::ipc::{Ended, Flow, Ipc, IpcError, Pub, Sub, Subscribers, Wire};
use fastslam_protocol::message::{Owned, SliceMessage};
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::{
    Checkpointed, EndOfStream, GroundTruth, Header, LaserScanHeader, ObservationsHeader, Odometry,
    StreamId, topics, validate,
};
use iceoryx2::prelude::ZeroCopySend;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::fmt::Debug;
use std::time::{Duration, Instant};

/// How much a sensor keeps to send again to a resumed service.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct ResendArgs {
    /// The most this sensor keeps of what it sent since the service's last checkpoint,
    /// to send again to a service resumed from it, in KiB of payload (64 MiB: a million
    /// odometry messages, some 20,000 raw scans of 720 beams; at most 16 GiB). Beyond it
    /// the oldest is forgotten; if a resumed service needs it, it is lost: logged here and
    /// counted by the service.
    #[arg(long, default_value_t = 64 << 10, value_name = "KIB",
          value_parser = clap::value_parser!(u64).range(1..=16 << 20))]
    pub history_kib: u64,
}

impl ResendArgs {
    /// The bound in bytes.
    fn bytes(self) -> usize {
        usize::try_from(self.history_kib << 10).unwrap_or(usize::MAX)
    }
}

/// How often a sensor looks whether a subscriber died (listing the stack's nodes reads
/// the file system).
const WATCH_EVERY: Duration = Duration::from_millis(50);

/// A message a sensor sends, kept until a checkpoint covers it.
pub trait Message {
    /// The topic's payload.
    type Payload: Wire + ?Sized;
    /// The topic's user header.
    type UserHeader: Debug + ZeroCopySend + 'static;
    /// Its stamp and sequence number.
    fn header(&self) -> Header;
    /// Publishes it on `out`.
    ///
    /// # Errors
    /// IPC failures.
    fn send(&self, out: &Pub<Self::Payload, Self::UserHeader>) -> Result<(), IpcError>;
    /// Its size in bytes, for the history's bound.
    fn bytes(&self) -> usize;
}

impl Message for Odometry {
    type Payload = Odometry;
    type UserHeader = ();

    fn header(&self) -> Header {
        self.header
    }

    fn send(&self, out: &Pub<Odometry, ()>) -> Result<(), IpcError> {
        out.send(*self)
    }

    fn bytes(&self) -> usize {
        size_of::<Self>()
    }
}

/// A user header that holds the message's [`Header`].
pub trait Headed {
    /// The message's stamp and sequence number.
    fn header(&self) -> Header;
}

impl Headed for ObservationsHeader {
    fn header(&self) -> Header {
        self.header
    }
}

impl Headed for LaserScanHeader {
    fn header(&self) -> Header {
        self.header
    }
}

impl<H> Message for Owned<H>
where
    H: SliceMessage + Headed,
    H::Item: Copy,
{
    type Payload = [H::Item];
    type UserHeader = H;

    fn header(&self) -> Header {
        self.header.header()
    }

    fn send(&self, out: &Pub<[H::Item], H>) -> Result<(), IpcError> {
        out.send(self.header, &self.items)
    }

    fn bytes(&self) -> usize {
        size_of::<H>() + self.items.len() * size_of::<H::Item>()
    }
}

/// Landmark observations, as the landmark sensor sends them.
pub type ObservationsMessage = Owned<ObservationsHeader>;
/// A raw scan, as the lidar sends it (`items`: the ranges, then the intensities).
pub type ScanMessage = Owned<LaserScanHeader>;

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
    history_bytes: usize,
}

impl SensorProcess {
    /// Loads the scenario and joins the stack as `name`, publishing stream `stream`.
    /// The caller opens its output publisher next, then calls [`SensorProcess::relay`]
    /// (publishers before subscribers, see `Ipc::subscriber`).
    ///
    /// # Errors
    /// Scenario or IPC errors.
    pub fn open(
        args: &SimArgs,
        resend: ResendArgs,
        name: &str,
        stream: StreamId,
    ) -> anyhow::Result<Self> {
        let (scenario, seed) = args.scenario()?;
        let ipc = Ipc::open(&args.stack.stack(), name, args.wait_timeout())?;
        let eos = (ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?).kept_for_client(&ipc)?;
        let wait_subscribers = args.wait_subscribers;
        Ok(Self {
            scenario,
            seed,
            ipc,
            eos,
            stream,
            wait_subscribers,
            history_bytes: resend.bytes(),
        })
    }

    /// Subscribes to ground truth, waits for `output`'s subscribers, then calls `each`
    /// with every ground-truth sample and the sequence number its output would get, and
    /// sends the message it returns, if any. Ends with the end-of-stream, then stays
    /// until every subscriber has left; meanwhile a subscriber that died gets what the
    /// last checkpoint does not cover once a new one is there.
    ///
    /// # Errors
    /// IPC failures or the first error of `each`.
    pub fn relay<M: Message>(
        &self,
        output: &Pub<M::Payload, M::UserHeader>,
        mut each: impl FnMut(&GroundTruth, u64) -> anyhow::Result<Option<M>>,
    ) -> anyhow::Result<()> {
        let truth = GroundTruthFollower::open(&self.ipc)?;
        let checkpoints = self
            .ipc
            .optional_subscriber::<Checkpointed>(&topics::CHECKPOINT)?;
        output.wait_for_subscribers(&self.ipc, self.wait_subscribers)?;
        let wanted = self.wait_subscribers.max(1);
        let bound = self.history_bytes;
        let outbox = Outbox::new(
            &self.ipc,
            output,
            &checkpoints,
            &self.eos,
            self.stream,
            wanted,
            bound,
        );
        let outbox = RefCell::new(outbox);
        let next_seq = || outbox.borrow().newest.map_or(0, |h| h.seq + 1);
        truth.follow(
            &self.ipc,
            |gt| {
                if let Some(m) = each(gt, next_seq())? {
                    outbox.borrow_mut().send(m)?;
                }
                Ok(())
            },
            || {
                output.flush()?;
                outbox.borrow_mut().tend()?;
                Ok(())
            },
        )?;
        let end = EndOfStream::new(self.stream, outbox.borrow().newest);
        self.eos.send(end)?;
        outbox.borrow_mut().end = Some(end);
        tracing::info!(messages = next_seq(), stream = ?self.stream, "finished");
        // Samples of a slice topic live in this process: stay until every subscriber has
        // them, sending again to a service that died and resumed.
        output.wait_until_left(&self.ipc, || {
            let mut outbox = outbox.borrow_mut();
            let seen = outbox.tend()?;
            Ok((!outbox.paused()).then_some(seen))
        })?;
        Ok(())
    }
}

/// A sensor's output: its publisher, what it sent since the last checkpoint that covers
/// it, and whether it holds new messages back for a service that died.
struct Outbox<'a, M: Message> {
    ipc: &'a Ipc,
    out: &'a Pub<M::Payload, M::UserHeader>,
    checkpoints: &'a Sub<Checkpointed, ()>,
    eos: &'a Pub<EndOfStream, ()>,
    /// The stream, as checkpoint notices list it ([`Checkpointed::covered_ns`]).
    stream: StreamId,
    /// What was sent and no checkpoint covers yet, oldest first.
    kept: VecDeque<M>,
    /// Their bytes, and the most kept.
    bytes: usize,
    bound: usize,
    /// The header of the newest message sent.
    newest: Option<Header>,
    /// Services (and bridges) seen dead, and requests of resumed services answered.
    /// While more died than asked, new messages wait: a service that died is replaced by
    /// one that asks. The death and the request may be seen in either order (the
    /// resumed service can ask before this sensor's next look finds its predecessor
    /// dead).
    deaths: u64,
    resumes: u64,
    /// Subscribers the stream waited for before it started, less consumers that died
    /// (more when more are alive).
    wanted: usize,
    /// Subscribers at the last look, and when that was.
    seen: Subscribers,
    looked: Option<Instant>,
    /// The end-of-stream, once sent.
    end: Option<EndOfStream>,
}

impl<'a, M: Message> Outbox<'a, M> {
    /// An empty history of `out`, whose stream `stream` the checkpoint notices
    /// `checkpoints` list and whose end goes out on `eos`; `wanted` subscribers were
    /// waited for; it keeps at most `bound` bytes.
    fn new(
        ipc: &'a Ipc,
        out: &'a Pub<M::Payload, M::UserHeader>,
        checkpoints: &'a Sub<Checkpointed, ()>,
        eos: &'a Pub<EndOfStream, ()>,
        stream: StreamId,
        wanted: usize,
        bound: usize,
    ) -> Self {
        Self {
            ipc,
            out,
            checkpoints,
            eos,
            stream,
            kept: VecDeque::new(),
            bytes: 0,
            bound,
            newest: None,
            deaths: 0,
            resumes: 0,
            wanted,
            seen: Subscribers {
                alive: wanted,
                ..Subscribers::default()
            },
            looked: None,
            end: None,
        }
    }

    /// True while new messages wait for a resumed service's request.
    fn paused(&self) -> bool {
        self.deaths > self.resumes
    }

    /// Sends `m` and keeps it, forgetting the oldest but the first beyond the bound (the
    /// first is the mark a resend starts with). After the service died, first waits (up
    /// to the wait timeout) for the resumed service's request.
    fn send(&mut self, m: M) -> Result<(), IpcError> {
        if !self.paused() && self.out.subscribers() < self.wanted {
            // One of the subscribers waited for is gone: died, or left. Look now.
            self.looked = None;
            self.tend()?;
        }
        if self.paused() {
            let ipc = self.ipc;
            ipc.wait_for(
                || "a resumed service to ask for what it missed".into(),
                || {
                    self.tend()?;
                    Ok((!self.paused()).then_some(()))
                },
            )?;
        }
        m.send(self.out)?;
        self.newest = Some(m.header());
        self.bytes += m.bytes();
        self.kept.push_back(m);
        while self.bytes > self.bound
            && self.kept.len() > 1
            && let Some(old) = self.kept.remove(1)
        {
            self.bytes -= old.bytes();
        }
        Ok(())
    }

    /// Forgets what a checkpoint covering stamps up to `covered_ns` holds, but for its
    /// last input (the newest kept at or before `covered_ns`): a resend starts with it,
    /// which tells the resumed service that the resend has begun.
    fn forget(&mut self, covered_ns: u64) {
        while (self.kept.get(1)).is_some_and(|next| next.header().stamp_ns <= covered_ns)
            && let Some(old) = self.kept.pop_front()
        {
            self.bytes -= old.bytes();
        }
    }

    /// Takes the checkpoint notices (forgetting what they cover; sending everything
    /// after it again when a resumed service asks), and at most every [`WATCH_EVERY`]
    /// looks whether a subscriber died (a service: then holds new messages back).
    /// Returns the subscribers seen at the last look.
    fn tend(&mut self) -> Result<Subscribers, IpcError> {
        let mut notices = Vec::new();
        self.checkpoints.drain(|c| notices.push(*c.payload()))?;
        for notice in notices {
            // A stream the service does not take is not covered: it keeps its bound.
            if let Some(covered_ns) = notice.covered_ns(self.stream) {
                self.forget(covered_ns);
            }
            if notice.resume != 0 {
                self.resend()?;
            }
        }
        if self.looked.is_some_and(|t| t.elapsed() < WATCH_EVERY) {
            return Ok(self.seen);
        }
        self.looked = Some(Instant::now());
        let seen = self.out.watch()?;
        self.seen = seen;
        self.deaths += seen.died_resuming as u64;
        // A consumer that does not resume (the client, a viewer) is not waited for: the
        // stack carries on, and a restarted one counts again once it has subscribed.
        let consumers = seen.died - seen.died_resuming;
        self.wanted = self.wanted.saturating_sub(consumers).max(seen.alive);
        if consumers > 0 {
            tracing::info!(
                consumers,
                "a subscriber that does not resume died (the client, a viewer): carrying on"
            );
        }
        if seen.died_resuming > 0 && self.paused() {
            tracing::warn!(
                kept = self.kept.len(),
                "the service died: holding new messages until a resumed service asks for what it missed"
            );
        } else if seen.died_resuming > 0 {
            tracing::info!("the service died; a resumed service has already asked");
        }
        Ok(self.seen)
    }

    /// Messages forgotten after the first kept (the resend's mark) that a resend would
    /// have to start with: the gap in sequence numbers after the mark.
    fn lost(&self) -> u64 {
        let Some(mark) = self.kept.front() else {
            return 0;
        };
        let next = match self.kept.get(1) {
            Some(next) => next.header().seq,
            None => self.newest.map_or(0, |h| h.seq + 1),
        };
        next.saturating_sub(mark.header().seq + 1)
    }

    /// Sends everything kept again, then the end-of-stream if the stream has ended, and
    /// lets new messages go.
    fn resend(&mut self) -> Result<(), IpcError> {
        self.resumes += 1;
        let lost = self.lost();
        if lost > 0 {
            tracing::warn!(
                lost,
                "messages beyond the history's bound cannot be sent again: lost"
            );
        }
        for m in &self.kept {
            m.send(self.out)?;
        }
        self.out.flush()?;
        if let Some(end) = self.end {
            self.eos.send(end)?;
        }
        tracing::info!(
            messages = self.kept.len(),
            "sent again to a resumed service"
        );
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
        mut flush: impl FnMut() -> anyhow::Result<()>,
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
