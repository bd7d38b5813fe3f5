//! The IPC plumbing every process of the stack shares: where a stack lives (prefix and
//! root path), and publishers/subscribers that pair each topic with an event service so
//! receivers sleep in a `WaitSet` instead of polling.
//!
//! Delivery is lossless by default: services are created without safe overflow and
//! publishers retry until a full subscriber buffer has room ("as fast as possible, lose
//! nothing"), giving up only when the process is asked to shut down.

use crate::topics::{self, RequestResponse, Topic};
use iceoryx2::node::NodeWaitFailure;
use iceoryx2::port::ReceiveError;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::service::builder::publish_subscribe::{
    Builder as PubSubBuilder, PublishSubscribeOpenOrCreateError,
};
use iceoryx2::service::port_factory::PortFactory as _;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use iceoryx2::service::port_factory::request_response::PortFactory as RequestResponsePortFactory;
use iceoryx2::waitset::WaitSetRunResult;
use std::cell::{Cell, RefCell};
use std::fmt::Debug;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// The iceoryx2 service flavour the stack uses: inter-process, shared memory.
pub type Service = ipc::Service;

/// A sample received on a [`Sub`]: a header `H` and payload `P` in shared memory.
pub type Received<P, H> = Sample<Service, P, H>;

/// What can go wrong while setting up or using IPC.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IpcError {
    /// The prefix or root path cannot be used as an iceoryx2 file name / path.
    #[error("invalid stack location `{value}`: {reason}")]
    InvalidLocation {
        /// The rejected value.
        value: String,
        /// Why it was rejected.
        reason: String,
    },
    /// An iceoryx2 call failed.
    #[error("{action} failed: {reason}")]
    Iceoryx {
        /// What the process tried to do, e.g. "open service fastslam/pose".
        action: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// Waiting for peers took longer than allowed.
    #[error("timed out after {waited:?} waiting for {what}")]
    Timeout {
        /// What was awaited.
        what: String,
        /// How long the process waited.
        waited: Duration,
    },
    /// SIGINT or SIGTERM arrived while waiting.
    #[error("shutdown requested")]
    Shutdown,
}

/// Result alias of the IPC helpers.
pub type Result<T> = std::result::Result<T, IpcError>;

fn iox_err<E: Debug>(action: impl Into<String>) -> impl FnOnce(E) -> IpcError {
    let action = action.into();
    move |e| IpcError::Iceoryx {
        action,
        reason: format!("{e:?}"),
    }
}

/// The files in `/dev/shm` of the stack with `prefix` (its iceoryx2 file prefix): a stack
/// with a live node always has some.
pub fn shared_memory_files(prefix: &str) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir("/dev/shm") else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .map(|e| e.path())
        .collect()
}

/// Removes what is left of the stack with `prefix` once its processes are gone: its
/// shared-memory files and, when it has one of its own, its iceoryx2 `root` directory.
/// Best effort: a file that cannot be removed stays.
pub fn remove_stack_files(prefix: &str, root: Option<&std::path::Path>) {
    for file in shared_memory_files(prefix) {
        let _ = std::fs::remove_file(file);
    }
    if let Some(root) = root {
        let _ = std::fs::remove_dir_all(root);
    }
}

/// Where a stack lives. The prefix is used twice: as iceoryx2's file prefix (so
/// `/dev/shm/<prefix>*` belongs to this stack alone) and as the service-name prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StackConfig {
    /// Stack name: letters, digits, `_` and `-` only.
    pub prefix: String,
    /// iceoryx2 root directory (Unix sockets live here; keep it short). `None`: the
    /// iceoryx2 default.
    pub root: Option<String>,
}

impl StackConfig {
    /// The iceoryx2 configuration of this stack.
    ///
    /// # Errors
    /// [`IpcError::InvalidLocation`] when the prefix or root is not a valid file name/path.
    pub fn iceoryx_config(&self) -> Result<Config> {
        let invalid = |value: &str, reason: &str| IpcError::InvalidLocation {
            value: value.to_string(),
            reason: reason.to_string(),
        };
        let ok_char = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if self.prefix.is_empty() || self.prefix.len() > 32 || !self.prefix.chars().all(ok_char) {
            return Err(invalid(&self.prefix, "use 1–32 of [A-Za-z0-9_-]"));
        }
        let mut config = Config::default();
        config.global.prefix = FileName::new(self.prefix.as_bytes())
            .map_err(|e| invalid(&self.prefix, &format!("{e:?}")))?;
        if let Some(root) = &self.root {
            let path = Path::new(root.as_bytes()).map_err(|e| invalid(root, &format!("{e:?}")))?;
            config.global.set_root_path(&path);
        }
        Ok(config)
    }
}

/// Process-wide shutdown flag: set once SIGINT or SIGTERM arrived.
///
/// iceoryx2 catches more signals than these (SIGCONT, SIGTSTP, SIGUSR1, SIGURG, SIGPROF,
/// …), and each of them interrupts a wait with EINTR. An interrupted wait therefore asks
/// [`requested`](shutdown::requested) whether to stop: `kill -CONT` or a sampling
/// profiler must not end a process.
///
/// [`install`](shutdown::install) sets the dispositions every stack process needs on
/// top of iceoryx2's:
/// - SIGINT and SIGTERM also set a flag of their own. iceoryx2 keeps only the *last*
///   signal, so a SIGTERM followed by any other caught signal before anyone looked was
///   lost.
/// - SIGTSTP (Ctrl-Z) gets its default action back, which suspends the process; iceoryx2
///   would otherwise catch it and the stack would run on. `fg` (SIGCONT) resumes it.
pub mod shutdown {
    use iceoryx2_bb_posix::signal::SignalHandler;
    use nix::sys::signal::{SigHandler, Signal, signal};
    use std::sync::Once;
    use std::sync::atomic::{AtomicBool, Ordering};

    static REQUESTED: AtomicBool = AtomicBool::new(false);
    /// True when SIGINT and SIGTERM both set [`REQUESTED`]: iceoryx2's record (behind a
    /// mutex) then need not be asked on every look.
    static WATCHED: AtomicBool = AtomicBool::new(false);
    static INSTALLED: Once = Once::new();

    /// Sets this process's signal dispositions (see the module documentation); once per
    /// process, and before the process waits on anything.
    ///
    /// iceoryx2 installs its own handlers when it is first used; this uses it first, so
    /// that the flag's handler comes after and calls iceoryx2's in turn.
    pub fn install() {
        INSTALLED.call_once(|| {
            if SignalHandler::termination_requested() {
                request();
            }
            let mut watched = true;
            for terminate in [Signal::SIGINT, Signal::SIGTERM] {
                if let Err(e) = signal_hook::flag::register(terminate as i32, &REQUESTED) {
                    tracing::warn!(signal = ?terminate, error = %e, "cannot watch the signal; relying on iceoryx2's");
                    watched = false;
                }
            }
            WATCHED.store(watched, Ordering::SeqCst);
            // A signal between the first look and the registration is only in iceoryx2's
            // record.
            if SignalHandler::termination_requested() {
                request();
            }
            // SAFETY: the default action is no handler: nothing runs in signal context.
            if let Err(e) = unsafe { signal(Signal::SIGTSTP, SigHandler::SigDfl) } {
                tracing::warn!(error = %e, "cannot restore Ctrl-Z's default action; it will not suspend this process");
            }
        });
    }

    /// True once SIGINT or SIGTERM arrived (or [`request`] was called). Once
    /// [`install`]ed, a load of an atomic flag: cheap enough for a busy-polling loop.
    pub fn requested() -> bool {
        if REQUESTED.load(Ordering::SeqCst) {
            return true;
        }
        if !WATCHED.load(Ordering::SeqCst) && SignalHandler::termination_requested() {
            request();
            return true;
        }
        false
    }

    /// Marks the process as shutting down (for example when a `WaitSet` reported a signal).
    pub fn request() {
        REQUESTED.store(true, Ordering::SeqCst);
    }
}

/// One process's connection to a stack: an iceoryx2 node under the stack's config.
pub struct Ipc {
    node: Node<Service>,
    prefix: String,
    wait_timeout: Duration,
    busy_poll: bool,
    spin: Duration,
}

impl Ipc {
    /// Joins the stack as node `name`. `wait_timeout` bounds every wait for peers
    /// (publishers of a topic this process subscribes to, subscribers it waits for).
    ///
    /// # Errors
    /// [`IpcError::InvalidLocation`] for a bad prefix/root, [`IpcError::Iceoryx`] when
    /// the node cannot be created (for example `/dev/shm` is not writable).
    pub fn open(stack: &StackConfig, name: &str, wait_timeout: Duration) -> Result<Self> {
        // Installs the signal handlers now, so a signal never kills the process in the
        // middle of writing shared memory.
        shutdown::install();
        let config = stack.iceoryx_config()?;
        let node_name = NodeName::new(name).map_err(iox_err(format!("node name {name}")))?;
        let node = NodeBuilder::new()
            .name(&node_name)
            .config(&config)
            .create::<Service>()
            .map_err(iox_err(format!("create node {name}")))?;
        Ok(Self {
            node,
            prefix: stack.prefix.clone(),
            wait_timeout,
            busy_poll: false,
            spin: Duration::ZERO,
        })
    }

    /// The same connection, whose [`Ipc::wake_loop`] busy-polls when `on` (see
    /// [`WaitArgs`](crate::cli::WaitArgs)).
    pub fn busy_polling(mut self, on: bool) -> Self {
        self.busy_poll = on;
        self
    }

    /// The same connection, whose [`Ipc::wake_loop`] goes on polling after each wake-up
    /// until no sample has arrived for `spin`, and only then sleeps again (see
    /// [`WaitArgs`](crate::cli::WaitArgs)).
    pub fn spinning(mut self, spin: Duration) -> Self {
        self.spin = spin;
        self
    }

    /// The underlying iceoryx2 node.
    pub fn node(&self) -> &Node<Service> {
        &self.node
    }

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

    /// Polls `ready` until it holds, the wait timeout passes or a signal arrives.
    ///
    /// # Errors
    /// [`IpcError::Timeout`] naming `what`, or [`IpcError::Shutdown`].
    pub fn wait_until(&self, what: impl Fn() -> String, ready: impl Fn() -> bool) -> Result<()> {
        self.wait_for(what, || Ok(ready().then_some(())))
    }

    /// Polls `poll` until it yields a value, the wait timeout passes or a signal arrives.
    ///
    /// # Errors
    /// `poll`'s error, [`IpcError::Timeout`] naming `what`, or [`IpcError::Shutdown`].
    pub fn wait_for<T>(
        &self,
        what: impl Fn() -> String,
        mut poll: impl FnMut() -> Result<Option<T>>,
    ) -> Result<T> {
        let start = Instant::now();
        loop {
            if let Some(value) = poll()? {
                return Ok(value);
            }
            if start.elapsed() > self.wait_timeout {
                return Err(IpcError::Timeout {
                    what: what(),
                    waited: start.elapsed(),
                });
            }
            self.sleep(Duration::from_millis(2))?;
        }
    }

    /// Sleeps for `d` unless a shutdown signal arrives first.
    ///
    /// # Errors
    /// [`IpcError::Shutdown`] when SIGINT/SIGTERM arrived.
    pub fn sleep(&self, d: Duration) -> Result<()> {
        let until = Instant::now() + d;
        loop {
            let left = until.saturating_duration_since(Instant::now());
            // `Interrupt` is any caught signal: `requested` tells a termination apart, and
            // another signal only cut the sleep short, so it goes on.
            if let Err(NodeWaitFailure::TerminationRequest) = self.node.wait(left) {
                shutdown::request();
            }
            if shutdown::requested() {
                return Err(IpcError::Shutdown);
            }
            if Instant::now() >= until {
                return Ok(());
            }
        }
    }

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

    /// Offers the request–response service `rr`: requests `Q`, responses a header `H`
    /// plus a slice of `T`. Poll it with [`SliceServer::answer`].
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when the service or the server cannot be created.
    pub fn slice_server<Q, H, T>(&self, rr: &RequestResponse) -> Result<SliceServer<Q, H, T>>
    where
        Q: Debug + ZeroCopySend + 'static,
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + Copy + 'static,
    {
        let server = self
            .request_response::<Q, H, T>(rr)?
            .server_builder()
            .initial_max_slice_len(rr.initial_slice_len)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(iox_err(format!("create server on {}", rr.name)))?;
        Ok(SliceServer {
            server,
            name: rr.name,
        })
    }

    /// Sends `request` to the request–response service `rr` and returns the first
    /// response (header and a copy of the slice).
    ///
    /// # Errors
    /// [`IpcError::Timeout`] when no server is there or none answers within the wait
    /// timeout, [`IpcError::Shutdown`] on a signal, [`IpcError::Iceoryx`] when sending or
    /// receiving fails.
    pub fn request_slice<Q, H, T>(&self, rr: &RequestResponse, request: Q) -> Result<(H, Vec<T>)>
    where
        Q: Debug + ZeroCopySend + 'static,
        H: Debug + ZeroCopySend + Copy + 'static,
        T: Debug + ZeroCopySend + Copy + 'static,
    {
        let service = self.request_response::<Q, H, T>(rr)?;
        let full = topics::service_name(&self.prefix, rr.name);
        self.wait_until(
            || format!("a server of {full}"),
            || service.dynamic_config().number_of_servers() > 0,
        )?;
        let client = service
            .client_builder()
            .create()
            .map_err(iox_err(format!("create client on {}", rr.name)))?;
        let pending = client
            .send_copy(request)
            .map_err(iox_err(format!("request on {}", rr.name)))?;
        self.wait_for(
            || format!("an answer from {full}"),
            || {
                let response = pending
                    .receive()
                    .map_err(iox_err(format!("response on {}", rr.name)))?;
                Ok(response.map(|r| (*r.user_header(), r.payload().to_vec())))
            },
        )
    }

    fn request_response<Q, H, T>(
        &self,
        rr: &RequestResponse,
    ) -> Result<RequestResponsePortFactory<Service, Q, (), [T], H>>
    where
        Q: Debug + ZeroCopySend + 'static,
        H: Debug + ZeroCopySend + 'static,
        T: Debug + ZeroCopySend + 'static,
    {
        let name = topics::service_name(&self.prefix, rr.name);
        let service_name =
            ServiceName::new(&name).map_err(iox_err(format!("service name {name}")))?;
        retry_interrupted(|| {
            self.node
                .service_builder(&service_name)
                .request_response::<Q, [T]>()
                .response_user_header::<H>()
                .open_or_create()
        })
        .map_err(iox_err(format!("open service {name}")))
    }

    fn pubsub<P, H>(&self, topic: &Topic) -> Result<PortFactory<Service, P, H>>
    where
        P: Wire + ?Sized,
        H: Debug + ZeroCopySend + 'static,
    {
        let name = topics::service_name(&self.prefix, topic.name);
        let service_name =
            ServiceName::new(&name).map_err(iox_err(format!("service name {name}")))?;
        retry_interrupted(|| {
            let builder = self
                .node
                .service_builder(&service_name)
                .publish_subscribe::<P>()
                .user_header::<H>()
                .enable_safe_overflow(false)
                .subscriber_max_buffer_size(topic.buffer)
                .history_size(topic.history)
                .max_publishers(topics::MAX_PUBLISHERS)
                .max_subscribers(topics::MAX_SUBSCRIBERS);
            P::open_service(builder)
        })
        .map_err(iox_err(format!("open service {name}")))
    }

    fn event(
        &self,
        topic: &Topic,
    ) -> Result<iceoryx2::service::port_factory::event::PortFactory<Service>> {
        let name = topics::service_name(&self.prefix, topic.name);
        let service_name =
            ServiceName::new(&name).map_err(iox_err(format!("service name {name}")))?;
        retry_interrupted(|| {
            self.node
                .service_builder(&service_name)
                .event()
                .open_or_create()
        })
        .map_err(iox_err(format!("open event {name}")))
    }
}

/// Runs `open` again while it fails only because a signal cut one of iceoryx2's waits
/// short (the `Interrupt` variants of its errors) and the process is not shutting down.
/// Opening a service waits while another process creates it, and any signal iceoryx2
/// catches interrupts that wait (see [`shutdown`]): Ctrl-Z and `fg` during start-up must
/// not fail the stack.
fn retry_interrupted<T, E: Debug>(
    mut open: impl FnMut() -> std::result::Result<T, E>,
) -> std::result::Result<T, E> {
    loop {
        match open() {
            Err(e) if format!("{e:?}").contains("Interrupt") && !shutdown::requested() => {
                tracing::debug!(error = ?e, "interrupted by a signal: trying again");
            }
            done => return done,
        }
    }
}

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

    /// Creates a publisher (slices: growing by powers of two from the topic's first guess).
    ///
    /// # Errors
    /// iceoryx2's error when the publisher cannot be created.
    fn create_publisher<H: Debug + ZeroCopySend + 'static>(
        service: &PortFactory<Service, Self, H>,
        topic: &Topic,
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
    fn open_service<H: Debug + ZeroCopySend + 'static>(
        builder: PubSubBuilder<Self, H, Service>,
    ) -> std::result::Result<PortFactory<Service, Self, H>, PublishSubscribeOpenOrCreateError> {
        builder.open_or_create()
    }

    fn create_publisher<H: Debug + ZeroCopySend + 'static>(
        service: &PortFactory<Service, Self, H>,
        _topic: &Topic,
    ) -> std::result::Result<Publisher<Service, Self, H>, PublisherCreateError> {
        service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
            .set_backpressure_handler(retry_unless_shutting_down)
            .create()
    }

    fn receive<H: Debug + ZeroCopySend + 'static>(
        subscriber: &Subscriber<Service, Self, H>,
    ) -> std::result::Result<Option<Sample<Service, Self, H>>, ReceiveError> {
        subscriber.receive()
    }
}

impl<T: Debug + ZeroCopySend + 'static> Wire for [T] {
    fn open_service<H: Debug + ZeroCopySend + 'static>(
        builder: PubSubBuilder<Self, H, Service>,
    ) -> std::result::Result<PortFactory<Service, Self, H>, PublishSubscribeOpenOrCreateError> {
        builder.open_or_create()
    }

    fn create_publisher<H: Debug + ZeroCopySend + 'static>(
        service: &PortFactory<Service, Self, H>,
        topic: &Topic,
    ) -> std::result::Result<Publisher<Service, Self, H>, PublisherCreateError> {
        service
            .publisher_builder()
            .initial_max_slice_len(topic.initial_slice_len)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
            .set_backpressure_handler(retry_unless_shutting_down)
            .create()
    }

    fn receive<H: Debug + ZeroCopySend + 'static>(
        subscriber: &Subscriber<Service, Self, H>,
    ) -> std::result::Result<Option<Sample<Service, Self, H>>, ReceiveError> {
        subscriber.receive()
    }
}

/// Samples this process has received on any [`Sub`]: a [spinning](Ipc::spinning) wake
/// loop polls on while it grows.
static RECEIVED: AtomicU64 = AtomicU64::new(0);

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
fn retry_unless_shutting_down(info: &BackpressureInfo) -> BackpressureAction {
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

/// The server side of a request–response service whose responses are a header `H` plus
/// a slice of `T`; see [`Ipc::slice_server`].
pub struct SliceServer<Q, H, T>
where
    Q: Debug + ZeroCopySend + 'static,
    H: Debug + ZeroCopySend + 'static,
    T: Debug + ZeroCopySend + 'static,
{
    server: Server<Service, Q, (), [T], H>,
    name: &'static str,
}

impl<Q, H, T> SliceServer<Q, H, T>
where
    Q: Debug + ZeroCopySend + 'static,
    H: Debug + ZeroCopySend + Default + 'static,
    T: Debug + ZeroCopySend + Copy + 'static,
{
    /// Answers every pending request with what `respond` returns for it (without
    /// blocking); returns how many were answered. A client that left before its answer
    /// was sent is skipped.
    ///
    /// # Errors
    /// [`IpcError::Iceoryx`] when receiving a request or loaning the response fails.
    pub fn answer(&self, mut respond: impl FnMut(&Q) -> (H, Vec<T>)) -> Result<usize> {
        let mut n = 0;
        while let Some(request) = self
            .server
            .receive()
            .map_err(iox_err(format!("receive request on {}", self.name)))?
        {
            let (header, items) = respond(request.payload());
            let mut response = request
                .loan_slice_uninit(items.len())
                .map_err(iox_err(format!("loan response on {}", self.name)))?;
            *response.user_header_mut() = header;
            if let Err(e) = response.write_from_slice(&items).send() {
                tracing::debug!(error = ?e, "answer on {} not delivered", self.name);
            }
            n += 1;
        }
        Ok(n)
    }
}

/// A subscriber on one topic, with the listener a `WaitSet` can sleep on.
pub struct Sub<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    subscriber: Subscriber<Service, P, H>,
    listener: Listener<Service>,
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
        self.take(|sample| {
            each(sample);
            None
        })
        .map(|(n, _)| n)
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

    /// Receives until `each` hands a sample back (returned, with the count received).
    fn take(
        &self,
        mut each: impl FnMut(Received<P, H>) -> Option<Received<P, H>>,
    ) -> Result<(usize, Option<Received<P, H>>)> {
        let fired = self.fired.swap(false, Ordering::Relaxed);
        if !fired
            && !self
                .subscriber
                .has_samples()
                .map_err(iox_err(format!("look for samples on {}", self.topic)))?
        {
            return Ok((0, None));
        }
        self.clear_wakeups()?;
        let mut n = 0;
        while let Some(sample) =
            P::receive(&self.subscriber).map_err(iox_err(format!("receive on {}", self.topic)))?
        {
            n += 1;
            RECEIVED.fetch_add(1, Ordering::Relaxed);
            if let Some(held) = each(sample) {
                return Ok((n, Some(held)));
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
            Taken::Done => None,
            Taken::Hold => Some(sample),
        })?;
        self.held
            .replace(held.map(|sample| (sample, Instant::now())));
        Ok(())
    }

    /// True while a sample is held back.
    pub fn holds(&self) -> bool {
        self.held.borrow().is_some()
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

    /// A stack of its own for one test: prefix and root, removed by [`TestStack::drop`].
    struct TestStack {
        prefix: String,
        root: std::path::PathBuf,
    }

    impl TestStack {
        fn new(tag: &str) -> Self {
            let prefix = format!("{tag}{}x", std::process::id());
            let root = std::env::temp_dir().join("fsl").join(&prefix);
            Self { prefix, root }
        }

        fn config(&self) -> StackConfig {
            StackConfig {
                prefix: self.prefix.clone(),
                root: Some(self.root.display().to_string()),
            }
        }
    }

    /// Runs `test` with an `Ipc` on `stack` on a thread of its own and returns what it
    /// returned (errors as text); fails with `hang` if it has not returned within 10 s.
    fn on_thread<T: Send + 'static>(
        stack: StackConfig,
        hang: &str,
        test: impl FnOnce(&Ipc) -> Result<T> + Send + 'static,
    ) -> std::result::Result<T, String> {
        let (done, result) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let run = || test(&Ipc::open(&stack, "test", Duration::from_secs(5))?);
            let _ = done.send(run().map_err(|e| e.to_string()));
        });
        result.recv_timeout(Duration::from_secs(10)).expect(hang)
    }

    /// A publisher and a subscriber of the end-of-stream topic, the topic these tests
    /// send on (the publisher first: a subscriber waits for one).
    fn eos_ports(ipc: &Ipc) -> Result<(Pub<EndOfStream, ()>, Sub<EndOfStream, ()>)> {
        let out = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
        Ok((out, ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?))
    }

    impl Drop for TestStack {
        fn drop(&mut self) {
            remove_stack_files(&self.prefix, Some(&self.root));
        }
    }

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
