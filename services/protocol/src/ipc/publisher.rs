//! Publishing: [`Pub`] sends on a topic and wakes its subscribers (at once, or
//! [coalescing](Pub::coalescing) a burst into one wake-up), and waits rather than lose a
//! sample when a subscriber's buffer is full.

#[cfg(doc)]
use super::Sub;
use super::kept::Kept;
use super::{Ipc, IpcError, Result, Service, Wire, iox_err, shutdown};
use crate::message::{FixedMessage, SliceMessage};
use crate::topics::{self, Topic};
use iceoryx2::config::Config;
use iceoryx2::node::{NodeState, NodeView};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::{BackpressureAction, BackpressureFn, BackpressureInfo};
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::PortFactory as _;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use std::cell::Cell;
use std::collections::{HashMap, HashSet};
use std::fmt::Debug;
use std::rc::Rc;
use std::sync::{Arc, Mutex, PoisonError};
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
        Pub::open(self, topic, Full::Wait)
    }

    /// Opens a publisher for fixed-size messages `T` on `topic` that never waits: a
    /// sample that finds a subscriber's buffer full is not delivered to it. For topics
    /// where a newer sample makes the older ones moot (`checkpoint`).
    ///
    /// # Errors
    /// As [`Ipc::publisher`].
    pub fn newest_only_publisher<T: Debug + ZeroCopySend + 'static>(
        &self,
        topic: &Topic,
    ) -> Result<Pub<T, ()>> {
        Pub::open(self, topic, Full::Skip)
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
        Pub::open(self, topic, Full::Wait)
    }
}

/// A publisher on one topic, with the notifier that wakes its subscribers.
pub struct Pub<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    service: PortFactory<Service, P, H>,
    publisher: Publisher<Service, P, H>,
    notifier: Notifier<Service>,
    pub(super) topic: &'static str,
    /// Wake-ups sent at most once per this period ([`Pub::coalescing`]); `None`: one per
    /// sample.
    coalesce: Option<Duration>,
    /// Samples sent since the last wake-up, at most `max_deferred` (a quarter of the
    /// subscribers' buffer).
    deferred: Cell<usize>,
    max_deferred: usize,
    last_notified: Cell<Option<Instant>>,
    /// The subscribers' nodes, shared with the backpressure handler.
    watch: Arc<Mutex<Watch>>,
    /// The subscriber count when their nodes were last learnt, and when that was
    /// ([`Pub::learn_subscribers`]).
    learnt: Cell<(usize, Option<Instant>)>,
    /// The stack's iceoryx2 configuration (to list its nodes).
    config: Config,
    /// The topic's settings.
    settings: Topic,
    /// What is kept for the client ([`Pub::kept_for_client`]).
    kept: Option<Rc<Kept<P, H>>>,
}

/// What a publisher does when a subscriber's buffer is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Full {
    /// Wait until it has room, unless the subscriber's node died or the process shuts
    /// down.
    Wait,
    /// Skip that subscriber.
    Skip,
}

/// How many of a publisher's subscribers are alive, and how many died since the last
/// look ([`Pub::watch`]). The stack's own processes are told from others by their node
/// names ([`STACK_NODES`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Subscribers {
    /// Subscribers of the stack's own processes whose node is alive.
    pub alive: usize,
    /// Subscribers of other processes (a viewer, a logger of one's own) whose node is
    /// alive.
    pub outside: usize,
    /// Subscribers of the stack's own processes whose node was found dead since the last
    /// look (killed, crashed: a subscriber that leaves is gone, not dead).
    pub died: usize,
    /// Of those, subscribers of a process that asks for what it missed when it is
    /// started again ([`RESUMING_NODES`]: the service, a bridge); the others (the client,
    /// a viewer) are consumers whose death the stack carries on through.
    pub died_resuming: usize,
}

/// The iceoryx2 node names of the stack's own processes. A process of one's own that
/// joins a stack takes another name: the stack's processes do not wait for its
/// subscribers at their end beyond [`OUTSIDE_GRACE`], and the client does not count it
/// among the stack's processes.
pub const STACK_NODES: [&str; 10] = [
    "truth-sim",
    "odometry-sim",
    "lidar-sim",
    "fastslam-service",
    "client",
    "replay-mrclam",
    "replay-victoria-park",
    "replay-recording",
    "viewer",
    "bridge",
];

/// The node names of the stack's processes that, started again after a crash, ask the
/// sensors for what they missed (on the `checkpoint` topic): the service, and a bridge
/// that forwards to one.
pub const RESUMING_NODES: [&str; 2] = ["fastslam-service", "bridge"];

/// True when `name` is the node name of one of the stack's own processes.
pub fn is_stack_node(name: &str) -> bool {
    STACK_NODES.contains(&name)
}

/// How long a publisher that has finished waits for the subscribers of processes not of
/// the stack to leave, once the stack's own have: a reader that keeps up leaves at the
/// end of its streams; one that never reads is left behind.
pub const OUTSIDE_GRACE: Duration = Duration::from_secs(2);

/// What a publisher knows of its subscribers' nodes: filled in by [`Pub::watch`], read by
/// its backpressure handler.
#[derive(Debug, Default)]
struct Watch {
    /// The node of every subscriber port seen, by port id.
    node_of: HashMap<u128, u128>,
    /// Nodes found dead: listed as dead while still holding a subscriber port. iceoryx2
    /// also lists a node as dead while its process removes the node's files on a clean
    /// exit, but the process has given up its ports before then; a process that died
    /// keeps its ports until someone cleans up after it.
    dead: HashSet<u128>,
    /// Nodes the backpressure handler found listed as dead: dead once the handler is
    /// called again for their port (it is called only while the port is connected).
    suspects: HashSet<u128>,
    /// Nodes that are not the stack's own processes.
    outside: HashSet<u128>,
    /// Nodes of [`RESUMING_NODES`].
    resuming: HashSet<u128>,
    /// Dead nodes [`Pub::watch`] has reported.
    reported: HashSet<u128>,
}

impl Watch {
    /// True when subscriber port `port` belongs to a node known to be dead; with
    /// `look`, a node not known to be dead yet is looked up among the stack's nodes
    /// (`config`).
    fn port_is_dead(&mut self, port: u128, look: bool, config: &Config) -> bool {
        let Some(node) = self.node_of.get(&port).copied() else {
            return false;
        };
        if self.suspects.contains(&node) {
            // Still connected after its node was listed as dead: not leaving, dead.
            self.dead.insert(node);
        }
        if look && !self.dead.contains(&node) {
            // A failed look leaves the node as it was known: alive.
            if self
                .look(config)
                .is_ok_and(|listed_dead| listed_dead.contains(&node))
            {
                self.suspects.insert(node);
            }
        }
        self.dead.contains(&node)
    }

    /// Lists the stack's nodes (`config`): notes those that are not the stack's own
    /// processes and those that resume, and returns those listed as dead (whose process
    /// died, or is removing the node's files as it exits).
    fn look(&mut self, config: &Config) -> Result<HashSet<u128>> {
        let mut listed_dead = HashSet::new();
        let listed = Node::<Service>::list(config, |state| {
            let (id, details) = match &state {
                NodeState::Alive(view) => (view.id().value(), view.details()),
                NodeState::Dead(view) => {
                    listed_dead.insert(view.id().value());
                    (view.id().value(), view.details())
                }
                _ => return CallbackProgression::Continue,
            };
            let name = details.as_ref().map(|d| d.name().as_str().to_owned());
            if name.as_deref().is_some_and(|n| !is_stack_node(n)) {
                self.outside.insert(id);
            }
            if name.is_some_and(|n| RESUMING_NODES.contains(&n.as_str())) {
                self.resuming.insert(id);
            }
            CallbackProgression::Continue
        });
        listed.map_err(iox_err("list the stack's nodes"))?;
        Ok(listed_dead)
    }
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
    fn open(ipc: &Ipc, topic: &Topic, full: Full) -> Result<Self> {
        let service = ipc.pubsub::<P, H>(topic)?;
        let watch = Arc::new(Mutex::new(Watch::default()));
        let config = ipc.node.config().clone();
        let created = match full {
            Full::Wait => {
                let handler = retry_unless_dead_or_shutting_down(watch.clone(), config.clone());
                P::create_publisher(&service, topic, handler)
            }
            Full::Skip => P::create_publisher(&service, topic, |_: &BackpressureInfo| {
                BackpressureAction::DiscardData
            }),
        };
        let publisher = created.map_err(iox_err(format!("create publisher on {}", topic.name)))?;
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
            watch,
            learnt: Cell::new((0, None)),
            config,
            settings: *topic,
            kept: None,
        })
    }

    /// This publisher, keeping every message it sends for the client until the client's
    /// notices say it recorded it, and sending what it keeps again, on the topic's
    /// resend service, to a client started again after a crash (see
    /// [`crate::ClientNotice`]). Nothing is kept before a client has given notice.
    ///
    /// # Errors
    /// As [`Ipc::publisher`], for the resend service and the notices.
    pub fn kept_for_client(mut self, ipc: &Ipc) -> Result<Self> {
        let resend = Self::open(ipc, &topics::resend(&self.settings), Full::Wait)?;
        self.kept = Some(Kept::open(ipc, &self.settings, resend)?);
        Ok(self)
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

    /// How many subscribers are alive, and how many died since the last look: a
    /// subscriber whose node is dead (its process was killed or crashed) is told apart
    /// from one that left, which is simply gone. From then on a sample that finds a dead
    /// subscriber's buffer full is not delivered to it rather than waited for.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the stack's nodes cannot be listed.
    pub fn watch(&self) -> Result<Subscribers> {
        self.look(true)
    }

    /// The subscribers as [`Pub::watch`] sees them; only with `report` are those that
    /// died counted as reported.
    fn look(&self, report: bool) -> Result<Subscribers> {
        let mut guard = self.watch.lock().unwrap_or_else(PoisonError::into_inner);
        // The ports are listed after the nodes: a node listed as dead whose port is still
        // there was not leaving (see `Watch::dead`).
        let listed_dead = guard.look(&self.config)?;
        let Watch {
            node_of,
            dead,
            outside,
            resuming,
            reported,
            ..
        } = &mut *guard;
        let mut seen = Subscribers::default();
        self.service.dynamic_config().list_subscribers(|d| {
            let node = d.node_id.value();
            node_of.insert(d.subscriber_id.value(), node);
            if listed_dead.contains(&node) {
                dead.insert(node);
            }
            match (dead.contains(&node), outside.contains(&node)) {
                (true, _) => {}
                (false, true) => seen.outside += 1,
                (false, false) => seen.alive += 1,
            }
            CallbackProgression::Continue
        });
        // Also those the backpressure handler found dead, or that were removed since.
        let died: HashSet<u128> = (node_of.values())
            .filter(|&node| dead.contains(node) && !outside.contains(node))
            .filter(|&node| !reported.contains(node))
            .copied()
            .collect();
        seen.died = died.len();
        seen.died_resuming = died.iter().filter(|&node| resuming.contains(node)).count();
        if report {
            reported.extend(died);
        }
        Ok(seen)
    }

    /// Waits until at least `n` subscribers of the stack's own processes are connected,
    /// so that nothing published afterwards is lost on a subscriber that was still
    /// starting (a subscriber of another process does not count: it may come first). A
    /// [`Sub`] connects as it is created, see [`Ipc::subscriber`], so every counted
    /// subscriber is ready.
    ///
    /// # Errors
    /// [`IpcError::Timeout`] after the wait timeout, [`IpcError::Shutdown`] on a signal,
    /// [`IpcError::Iceoryx`] when the stack's nodes cannot be listed.
    pub fn wait_for_subscribers(&self, ipc: &Ipc, n: usize) -> Result<()> {
        ipc.wait_for(
            || format!("{n} subscriber(s) of the stack on {}", self.topic),
            || Ok((self.look(false)?.alive >= n).then_some(())),
        )
    }

    /// Waits until every subscriber has left, for a process about to exit: those of the
    /// stack's own processes (bounded by the wait timeout), then the others for at most
    /// [`OUTSIDE_GRACE`]. A slice topic's samples live in the publisher's growable data
    /// segment, which a subscriber maps only when it receives from it: were the
    /// publisher to exit first, samples not yet received would be lost (iceoryx2 logs
    /// "Lost chunk"). Consumers leave once they have everything, so this wait is short; a
    /// process of one's own that never leaves (a viewer) is left behind, with a warning.
    ///
    /// # Errors
    /// [`IpcError::Shutdown`] on a signal, [`IpcError::Iceoryx`] when the stack's nodes
    /// cannot be listed (a timeout is not an error).
    pub fn wait_until_unsubscribed(&self, ipc: &Ipc) -> Result<()> {
        self.wait_until_left(ipc, || self.watch().map(Some))
    }

    /// As [`Pub::wait_until_unsubscribed`], for a process that watches its subscribers
    /// itself: `look` gives what it saw ([`Pub::watch`]), or `None` while the process
    /// has other reasons to stay.
    ///
    /// # Errors
    /// `look`'s error, [`IpcError::Shutdown`] on a signal (a timeout is not an error).
    pub fn wait_until_left(
        &self,
        ipc: &Ipc,
        mut look: impl FnMut() -> Result<Option<Subscribers>>,
    ) -> Result<()> {
        let mut outsiders_since = None;
        let mut told = false;
        let left = ipc.wait_for(
            || format!("the subscribers of {} to leave", self.topic),
            || {
                // A client that died may be started again and ask for what it missed.
                let keeping = ipc.tend_kept()?;
                let seen = look()?.filter(|seen| seen.alive == 0);
                if keeping && seen.is_some() && !std::mem::replace(&mut told, true) {
                    tracing::warn!(
                        "the client died before it recorded everything: keeping what it \
                         missed for a client started again (`client --resume`)"
                    );
                }
                let seen = seen.filter(|_| !keeping);
                let Some(Subscribers { outside, .. }) = seen else {
                    return Ok(None);
                };
                let since = *outsiders_since.get_or_insert_with(Instant::now);
                if outside > 0 && since.elapsed() >= OUTSIDE_GRACE {
                    tracing::warn!(
                        outside,
                        "leaving the subscribers of {} that are not the stack's own behind",
                        self.topic
                    );
                }
                Ok((outside == 0 || since.elapsed() >= OUTSIDE_GRACE).then_some(()))
            },
        );
        match left {
            Err(IpcError::Timeout { what, waited }) => {
                tracing::warn!(?waited, "gave up waiting for {what}");
                Ok(())
            }
            other => other,
        }
    }

    /// Learns the nodes of subscribers that joined (when their count changed, else at
    /// most every [`LEARN_EVERY`]), so that a send that finds a buffer full can tell
    /// whether its subscriber's process died, also of a subscriber that joined late (a
    /// restarted client) without this publisher ever watching. Reads shared memory only.
    fn learn_subscribers(&self) {
        let count = self.subscribers();
        let (learnt, at) = self.learnt.get();
        if count == learnt && at.is_some_and(|t| t.elapsed() < LEARN_EVERY) {
            return;
        }
        self.learnt.set((count, Some(Instant::now())));
        let mut guard = self.watch.lock().unwrap_or_else(PoisonError::into_inner);
        self.service.dynamic_config().list_subscribers(|d| {
            (guard.node_of).insert(d.subscriber_id.value(), d.node_id.value());
            CallbackProgression::Continue
        });
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

/// How often a publisher learns its subscribers' nodes when their count stays the same.
const LEARN_EVERY: Duration = Duration::from_millis(100);

/// Retries of a full subscriber buffer made at once, before [`BACKPRESSURE_NAP`]s.
const QUICK_RETRIES: u64 = 16;
/// Sleep between later retries of a full subscriber buffer.
const BACKPRESSURE_NAP: Duration = Duration::from_micros(50);

/// A send that has waited this long on a full buffer asks whether its subscriber died.
const DEAD_CHECK_AFTER: Duration = Duration::from_millis(20);
/// Retries between two such questions (listing the nodes reads the file system).
const DEAD_CHECK_EVERY: u64 = 64;

/// Keeps retrying a full subscriber buffer, unless the process is shutting down or the
/// subscriber's node is dead (known from [`Pub::watch`]: a publisher that never watches
/// waits as before). After [`QUICK_RETRIES`] it naps between retries: iceoryx2 would
/// otherwise yield in a loop (up to 10 000 times), which on a machine with fewer cores
/// than processes takes the CPU from the very subscriber it waits for (measured: a fifth
/// of the stack's CPU time in `sched_yield` as fast as possible on 2 cores).
fn retry_unless_dead_or_shutting_down(
    watch: Arc<Mutex<Watch>>,
    config: Config,
) -> impl BackpressureFn + 'static {
    move |info: &BackpressureInfo| {
        if shutdown::requested() {
            return BackpressureAction::DiscardData;
        }
        if info.retries >= QUICK_RETRIES {
            std::thread::sleep(BACKPRESSURE_NAP);
        }
        let look =
            info.elapsed_time >= DEAD_CHECK_AFTER && info.retries.is_multiple_of(DEAD_CHECK_EVERY);
        if (watch.lock().unwrap_or_else(PoisonError::into_inner)).port_is_dead(
            info.receiver_port_id,
            look,
            &config,
        ) {
            return BackpressureAction::DiscardData;
        }
        BackpressureAction::Retry
    }
}

impl<T: FixedMessage> Pub<T, ()> {
    /// Publishes one message and wakes the subscribers.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the sample cannot be loaned or sent.
    pub fn send(&self, value: T) -> Result<()> {
        self.learn_subscribers();
        self.publisher
            .send_copy(value)
            .map_err(iox_err(format!("send on {}", self.topic)))?;
        self.notify()?;
        match &self.kept {
            Some(kept) => kept.keep(value.message(), size_of::<T>(), move |p| p.send(value)),
            None => Ok(()),
        }
    }
}

impl<H, T> Pub<[T], H>
where
    H: SliceMessage<Item = T>,
    T: Debug + ZeroCopySend + Copy + 'static,
{
    /// Publishes `header` with `items` and wakes the subscribers. The items are written
    /// once, straight into shared memory.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the sample cannot be loaned or sent.
    pub fn send(&self, header: H, items: &[T]) -> Result<()> {
        self.learn_subscribers();
        let mut sample = self
            .publisher
            .loan_slice_uninit(items.len())
            .map_err(iox_err(format!("loan on {}", self.topic)))?;
        *sample.user_header_mut() = header;
        let sample = sample.write_from_slice(items);
        sample
            .send()
            .map_err(iox_err(format!("send on {}", self.topic)))?;
        self.notify()?;
        let Some(kept) = &self.kept else {
            return Ok(());
        };
        let bytes = size_of::<H>() + size_of_val(items);
        let copy = items.to_vec();
        kept.keep(header.message(items), bytes, move |p| p.send(header, &copy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::EndOfStream;
    use crate::ipc::StackConfig;
    use crate::ipc::testing::{TestStack, eos_ports, on_thread};
    use crate::topics;

    /// Set in the subscriber process [`a_subscriber_died_only_if_its_node_died_holding_its_port`]
    /// starts: the stack's prefix and root, and whether it leaves before it is killed.
    const SUBSCRIBER_CHILD: &str = "FASTSLAM_TEST_SUBSCRIBER_CHILD";

    /// The subscriber process: subscribes as the service would, says `ready`; if it is
    /// one that leaves, drops its subscriber once a line comes on stdin and says `left`;
    /// then waits to be killed.
    fn subscriber_child(spec: &str) {
        let mut parts = spec.split('|');
        let (prefix, root, leave) = (parts.next(), parts.next(), parts.next());
        let stack = StackConfig {
            prefix: prefix.unwrap().to_string(),
            root: root.map(str::to_string),
        };
        let ipc = Ipc::open(&stack, "fastslam-service", Duration::from_secs(5)).unwrap();
        let sub = ipc
            .subscriber::<EndOfStream>(&topics::END_OF_STREAM)
            .unwrap();
        println!("ready");
        if leave == Some("leave") {
            let _ = std::io::stdin().lines().next();
            drop(sub);
            println!("left");
        }
        std::thread::sleep(Duration::from_secs(60));
    }

    /// A subscriber whose node iceoryx2 lists as dead counts as died only when it still
    /// holds its port: a process exiting cleanly gives up its ports, then its node is
    /// listed as dead while it removes the node's files. Here both are frozen by a
    /// SIGKILL: one subscriber process killed holding its port, one killed after it left.
    #[test]
    fn a_subscriber_died_only_if_its_node_died_holding_its_port() {
        if let Ok(spec) = std::env::var(SUBSCRIBER_CHILD) {
            return subscriber_child(&spec);
        }
        use std::io::{BufRead, Write};
        let test = TestStack::new("died");
        let config = test.config();
        let spec = |leave: &str| {
            let root = config.root.clone().unwrap_or_default();
            format!("{}|{root}|{leave}", config.prefix)
        };
        let (holding, leaving) = (spec("hold"), spec("leave"));
        let seen = on_thread(test.config(), "watching the subscribers hung", move |ipc| {
            let out = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
            let mut seen = Vec::new();
            for spec in [holding, leaving] {
                let mut child = std::process::Command::new(std::env::current_exe().unwrap())
                    .args(["--exact", "--nocapture", "--test-threads=1"])
                    .arg("ipc::publisher::tests::a_subscriber_died_only_if_its_node_died_holding_its_port")
                    .env(SUBSCRIBER_CHILD, &spec)
                    .stdin(std::process::Stdio::piped())
                    .stdout(std::process::Stdio::piped())
                    .spawn()
                    .unwrap();
                let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
                let mut says = |word: &str| {
                    (lines.by_ref().map_while(std::result::Result::ok)).any(|l| l.ends_with(word))
                };
                // Its port seen as a sensor sees the service's while it runs; then, for
                // the one that leaves, gone.
                let mut talk = || -> Result<Option<&str>> {
                    if !says("ready") {
                        return Ok(Some("ready"));
                    }
                    assert_eq!(out.watch()?.alive, 1);
                    if spec.ends_with("leave") {
                        writeln!(child.stdin.as_mut().unwrap(), "leave").unwrap();
                        if !says("left") {
                            return Ok(Some("left"));
                        }
                    }
                    Ok(None)
                };
                let unsaid = talk();
                child.kill().unwrap();
                child.wait().unwrap();
                if let Some(word) = unsaid? {
                    panic!("the subscriber process did not say {word}");
                }
                seen.push(out.watch()?);
            }
            Ok(seen)
        });
        let seen = seen.unwrap();
        assert_eq!(
            (seen[0].alive, seen[0].died, seen[0].died_resuming),
            (0, 1, 1)
        );
        assert_eq!(
            (seen[1].alive, seen[1].died, seen[1].died_resuming),
            (0, 0, 0)
        );
    }

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
