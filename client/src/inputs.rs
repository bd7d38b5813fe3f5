//! What the client and the live viewer subscribe to ([`Inputs`]: every topic of the
//! protocol's table but the checkpoints), in an order that lets the stack start, with the
//! lidar's output whichever form it takes, ground truth when the run has it
//! ([`TruthWait`]), and when every stream has ended ([`Ends`]).

use crate::journal::Start;
use fastslam_protocol::ipc::{Ipc, Sub, WakeSource};
use fastslam_protocol::message::{
    Fixed, FixedMessage, Message, PayloadVisitor, Slice, SliceMessage,
};
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::topics::{self, Publisher, Topic, TopicRow};
use fastslam_protocol::validate::Rejection;
use fastslam_protocol::{EndOfStream, StreamId};
use std::time::{Duration, Instant};

/// How long a consumer waits for a ground-truth publisher when it was not told whether
/// the run has ground truth (s).
pub const TRUTH_WAIT_S: f64 = 5.0;

/// Whether a consumer takes ground truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TruthWait {
    /// Never: the run has none.
    Off,
    /// When the `ground_truth` topic has a publisher once the other subscriptions are
    /// open, or gets one within this time; else the run goes on without truth.
    Within(Duration),
}

/// The lidar's topics, one of which a run has: raw scans first, as the service chooses
/// when both have a publisher.
const LIDAR: [Topic; 2] = [topics::SCAN, topics::OBSERVATIONS];

/// A subscriber to every topic of the stack a consumer records or shows.
pub struct Inputs {
    /// One per topic taken, in the order of the protocol's table.
    inputs: Vec<Input>,
    /// The lidar's stream: raw scans or observations.
    lidar: StreamId,
    /// Whether ground truth is taken.
    truth: bool,
}

/// The subscriber to one topic, and to its resend service when the consumer records.
struct Input {
    row: &'static TopicRow,
    port: Box<dyn Port>,
    resend: Option<Box<dyn Port>>,
}

/// How a consumer opens its subscriptions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Opening {
    /// Waiting for each topic's publisher, choosing the lidar's topic and whether to take
    /// ground truth as `TruthWait` says; `resend`: also subscribing to each topic's
    /// resend service (the client: see [`crate::journal`]).
    Wait {
        /// Whether to take ground truth.
        truth: TruthWait,
        /// Whether to subscribe to the resend services too.
        resend: bool,
    },
    /// As a client started again on a run it recorded: the topics it chose, each opened
    /// at once (some publishers may have finished), with their resend services.
    Resume(Start),
}

impl Inputs {
    /// Subscribes to every topic, waiting for each one's publisher; to ground truth and
    /// the true map only as `truth` says.
    ///
    /// # Errors
    /// IPC failures, or a timeout when a topic gets no publisher.
    pub fn open(ipc: &Ipc, opening: Opening) -> anyhow::Result<Self> {
        let mut rows: Vec<(usize, &'static TopicRow)> = (topics::TABLE.iter().enumerate())
            .filter(|(_, row)| row.topic != topics::CHECKPOINT)
            .collect();
        rows.sort_by_key(|(_, row)| opening_rank(row));
        let (mut choice, resend, wait) = match opening {
            Opening::Wait { truth, resend } => (Choice::new(truth), resend, true),
            Opening::Resume(start) => (Choice::of(start), true, false),
        };
        let mut inputs = Vec::new();
        for (i, row) in rows {
            if choice.takes(ipc, row)? {
                let open = |topic| Open { ipc, topic, wait };
                let port = row.payload.visit(open(row.topic))?;
                let resend = (resend.then(|| {
                    let topic = topics::resend(&row.topic);
                    row.payload.visit(Open {
                        wait: false,
                        ..open(topic)
                    })
                }))
                .transpose()?;
                inputs.push((i, Input { row, port, resend }));
            }
        }
        inputs.sort_by_key(|(i, _)| *i);
        let lidar = choice.lidar.and_then(|row| row.stream);
        Ok(Self {
            inputs: inputs.into_iter().map(|(_, input)| input).collect(),
            lidar: lidar.expect("every run has a lidar topic"),
            truth: choice.truth == Some(true),
        })
    }

    /// Every subscriber, to wake on.
    pub fn sources(&self) -> Vec<&dyn WakeSource> {
        (self.inputs.iter())
            .flat_map(|input| std::iter::once(&input.port).chain(&input.resend))
            .map(|port| port.source())
            .collect()
    }

    /// What a client started again on this run must take: the topics chosen.
    pub fn start(&self) -> Start {
        Start {
            lidar: self.lidar,
            truth: self.truth,
        }
    }

    /// True when the run has ground truth (its topic is subscribed to).
    pub fn ground_truth(&self) -> bool {
        self.truth
    }

    /// The lidar's stream: raw scans or landmark observations.
    pub fn lidar(&self) -> StreamId {
        self.lidar
    }

    /// The streams taken, each to follow until it ends.
    pub fn ends(&self) -> Ends {
        Ends(
            (self.inputs.iter())
                .filter_map(|input| input.row.stream)
                .map(|id| (id, StreamEnd::default()))
                .collect(),
        )
    }

    /// Calls `each` with every pending message, topic after topic in the order of the
    /// protocol's table, with its topic's row and the result of its check.
    ///
    /// # Errors
    /// IPC failures.
    pub fn drain(
        &self,
        mut each: impl FnMut(&'static TopicRow, Message<'_>, Result<(), Rejection>),
    ) -> anyhow::Result<()> {
        for input in &self.inputs {
            for port in std::iter::once(&input.port).chain(&input.resend) {
                port.drain(&mut |message, checked| each(input.row, message, checked))?;
            }
        }
        Ok(())
    }
}

/// Where a topic comes among the subscriptions. A producer starts once the subscribers
/// of one topic are there (truth simulator: ground truth; odometry: odometry; lidar: its
/// scans or observations; service: pose), and a short run may be over before a later
/// subscription exists: end-of-stream and each producer's other topics come before the
/// topic it waits on. Ground truth comes last: nothing is published before it has its
/// subscribers (the sensor simulators relay the truth; the replay waits for the truth's
/// subscribers too).
fn opening_rank(row: &TopicRow) -> u8 {
    match (row.publisher, row.topic) {
        (Publisher::EachStream, _) => 0,
        (Publisher::Service, topics::POSE) => 4,
        (Publisher::Service, _) => 1,
        (Publisher::Sensor, topics::ODOMETRY) => 3,
        (Publisher::Sensor, _) => 2,
        (Publisher::Truth, topics::GROUND_TRUTH) => 6,
        (Publisher::Truth, _) => 5,
    }
}

/// Which of the topics that a run may or may not have are taken, each decided when the
/// first of its topics comes up.
struct Choice {
    wait: TruthWait,
    /// The lidar's topic, once chosen.
    lidar: Option<&'static TopicRow>,
    /// Whether ground truth and the true map are taken, once decided.
    truth: Option<bool>,
}

impl Choice {
    /// Nothing chosen yet; ground truth as `wait` says.
    fn new(wait: TruthWait) -> Self {
        Self {
            wait,
            lidar: None,
            truth: None,
        }
    }

    /// What `start` chose.
    fn of(start: Start) -> Self {
        let lidar = (topics::TABLE.iter()).find(|row| row.stream == Some(start.lidar));
        Self {
            wait: TruthWait::Off,
            lidar,
            truth: Some(start.truth),
        }
    }

    /// Whether to subscribe to `row`'s topic.
    ///
    /// # Errors
    /// IPC failures, or a timeout when no lidar topic gets a publisher.
    fn takes(&mut self, ipc: &Ipc, row: &TopicRow) -> anyhow::Result<bool> {
        if LIDAR.contains(&row.topic) {
            let lidar = match self.lidar {
                Some(lidar) => lidar,
                None => *self.lidar.insert(lidar(ipc)?),
            };
            return Ok(row.topic == lidar.topic);
        }
        if row.publisher != Publisher::Truth {
            return Ok(true);
        }
        Ok(match self.truth {
            Some(truth) => truth,
            None => *self.truth.insert(has_truth(ipc, self.wait)?),
        })
    }
}

/// The lidar's topic: raw scans or landmark observations, whichever has a publisher,
/// scans when both do (as the service chooses).
///
/// # Errors
/// IPC failures, or a timeout when neither topic gets a publisher.
fn lidar(ipc: &Ipc) -> anyhow::Result<&'static TopicRow> {
    let [scans, observations] = LIDAR.map(|topic| topics::row(topic.name).expect("in the table"));
    let (scans_now, observations_now) = (
        ipc.row_publisher_probe(scans)?,
        ipc.row_publisher_probe(observations)?,
    );
    ipc.wait_until(
        || "a publisher on scan or observations".into(),
        || scans_now() + observations_now() > 0,
    )?;
    Ok(if scans_now() > 0 { scans } else { observations })
}

/// Whether to take ground truth, as `wait` says: for [`TruthWait::Within`], whether the
/// topic has a publisher or gets one in time (logging one line when it does not).
fn has_truth(ipc: &Ipc, wait: TruthWait) -> anyhow::Result<bool> {
    let TruthWait::Within(within) = wait else {
        return Ok(false);
    };
    let truth = topics::row(topics::GROUND_TRUTH.name).expect("in the table");
    let publishers = ipc.row_publisher_probe(truth)?;
    let start = Instant::now();
    while publishers() == 0 {
        if start.elapsed() >= within {
            tracing::info!(
                waited_s = within.as_secs_f64(),
                "no ground truth: the ground_truth topic has no publisher; going on without it"
            );
            return Ok(false);
        }
        ipc.sleep(Duration::from_millis(2))?;
    }
    Ok(true)
}

/// A subscriber to one topic, whatever its payload type.
trait Port {
    /// The subscriber, to wake on.
    fn source(&self) -> &dyn WakeSource;
    /// Calls `each` with every pending message and the result of its check.
    fn drain(
        &self,
        each: &mut dyn FnMut(Message<'_>, Result<(), Rejection>),
    ) -> anyhow::Result<usize>;
}

/// A subscriber to a topic of fixed messages `T`.
struct FixedPort<T: FixedMessage> {
    sub: Sub<T, ()>,
    payload: &'static Fixed<T>,
}

/// A subscriber to a topic of headers `H` and slices.
struct SlicePort<H: SliceMessage> {
    sub: Sub<[H::Item], H>,
    payload: &'static Slice<H>,
}

impl<T: FixedMessage> Port for FixedPort<T> {
    fn source(&self) -> &dyn WakeSource {
        &self.sub
    }

    fn drain(
        &self,
        each: &mut dyn FnMut(Message<'_>, Result<(), Rejection>),
    ) -> anyhow::Result<usize> {
        Ok(self.sub.drain(|s| {
            let (message, checked) = self.payload.read(s.payload());
            each(message, checked);
        })?)
    }
}

impl<H: SliceMessage> Port for SlicePort<H> {
    fn source(&self) -> &dyn WakeSource {
        &self.sub
    }

    fn drain(
        &self,
        each: &mut dyn FnMut(Message<'_>, Result<(), Rejection>),
    ) -> anyhow::Result<usize> {
        Ok(self.sub.drain(|s| {
            let (message, checked) = self.payload.read(s.user_header(), s.payload());
            each(message, checked);
        })?)
    }
}

/// Opens the subscriber of a topic whose payload type is named at run time, waiting for
/// a publisher or not.
struct Open<'a> {
    ipc: &'a Ipc,
    topic: Topic,
    wait: bool,
}

impl PayloadVisitor for Open<'_> {
    type Output = anyhow::Result<Box<dyn Port>>;

    fn fixed<T: FixedMessage>(self, payload: &'static Fixed<T>) -> Self::Output {
        let sub = if self.wait {
            self.ipc.subscriber::<T>(&self.topic)?
        } else {
            self.ipc.optional_subscriber::<T>(&self.topic)?
        };
        Ok(Box::new(FixedPort { sub, payload }))
    }

    fn slice<H: SliceMessage>(self, payload: &'static Slice<H>) -> Self::Output {
        let sub = if self.wait {
            self.ipc.slice_subscriber::<H, H::Item>(&self.topic)?
        } else {
            self.ipc
                .optional_slice_subscriber::<H, H::Item>(&self.topic)?
        };
        Ok(Box::new(SlicePort { sub, payload }))
    }
}

/// The streams a consumer takes until they end, each with its end bookkeeping (none by
/// default).
#[derive(Default)]
pub struct Ends(Vec<(StreamId, StreamEnd)>);

impl Ends {
    /// Notes a message of `row`'s topic: an end-of-stream message is recorded (true when
    /// it closes one of these streams), any other counts as processed for its stream.
    pub fn note(&mut self, row: &TopicRow, message: Message<'_>) -> bool {
        if let Message::EndOfStream(eos) = message {
            return self.announce(eos);
        }
        if let Some(id) = row.stream {
            self.saw(id, message.header().seq);
        }
        false
    }

    /// The message `seq` of stream `id` was processed.
    fn saw(&mut self, id: StreamId, seq: u64) {
        if let Some((_, end)) = self.0.iter_mut().find(|(s, _)| *s == id) {
            end.saw(seq);
        }
    }

    /// Records an end-of-stream message; true when it closes one of these streams.
    fn announce(&mut self, eos: &EndOfStream) -> bool {
        let id = StreamId::from_u32(eos.stream);
        match self.0.iter_mut().find(|(s, _)| Some(*s) == id) {
            Some((_, end)) => {
                end.announce(eos);
                true
            }
            None => false,
        }
    }

    /// True once every stream has ended and its last message was processed.
    pub fn finished(&self) -> bool {
        self.0.iter().all(|(_, end)| end.finished())
    }
}
