//! One process's connection to a stack ([`Ipc`]): its iceoryx2 node, the waits that the
//! wait timeout bounds and a signal cuts short, and the opening of the services behind
//! every topic.

#[cfg(doc)]
use super::Pub;
use super::kept::Notices;
use super::{IpcError, Result, Service, StackConfig, Wire, iox_err, mismatch, shutdown, stack};
use crate::topics::{self, Topic};
use iceoryx2::node::NodeWaitFailure;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};
use std::cell::OnceCell;
use std::fmt::Debug;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// One process's connection to a stack: an iceoryx2 node under the stack's config.
pub struct Ipc {
    pub(super) node: Node<Service>,
    pub(super) prefix: String,
    wait_timeout: Duration,
    pub(super) busy_poll: bool,
    pub(super) spin: Duration,
    /// The client's notices, subscribed to once the first publisher keeps for it.
    notices: OnceCell<Rc<Notices>>,
}

impl Ipc {
    /// Joins the stack as node `name`. `wait_timeout` bounds every wait for peers
    /// (publishers of a topic this process subscribes to, subscribers it waits for).
    /// The stack's files in `/dev/shm` are its user's alone (0600).
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
        stack::make_management_file_private(&stack.prefix);
        Ok(Self {
            node,
            prefix: stack.prefix.clone(),
            wait_timeout,
            busy_poll: false,
            spin: Duration::ZERO,
            notices: OnceCell::new(),
        })
    }

    /// The same connection, whose [`Ipc::wake_loop`] busy-polls when `on` (see
    /// `cli::WaitArgs`).
    pub fn busy_polling(mut self, on: bool) -> Self {
        self.busy_poll = on;
        self
    }

    /// The same connection, whose [`Ipc::wake_loop`] goes on polling after each wake-up
    /// until no sample has arrived for `spin`, and only then sleeps again (see
    /// `cli::WaitArgs`).
    pub fn spinning(mut self, spin: Duration) -> Self {
        self.spin = spin;
        self
    }

    /// The underlying iceoryx2 node.
    pub fn node(&self) -> &Node<Service> {
        &self.node
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

    /// The process's subscription to the client's notices ([`Pub::kept_for_client`]).
    pub(super) fn client_notices(&self) -> Result<Rc<Notices>> {
        if let Some(n) = self.notices.get() {
            return Ok(n.clone());
        }
        let n = Rc::new(Notices::open(self)?);
        Ok(self.notices.get_or_init(|| n).clone())
    }

    /// Tends what this process's publishers keep for the client; true while one of them
    /// keeps messages a client that died may still ask for.
    pub(super) fn tend_kept(&self) -> Result<bool> {
        self.notices.get().map_or(Ok(false), |n| n.tend_all())
    }

    /// Waits, up to the wait timeout, until the client has recorded everything this
    /// process's publishers keep for it ([`Pub::kept_for_client`]): a process that does
    /// not wait for its subscribers to leave calls it before it exits, so that a client
    /// started again after a crash can still ask. A timeout is logged, not an error.
    ///
    /// # Errors
    /// [`IpcError::Shutdown`] on a signal, IPC failures.
    pub fn wait_for_client(&self) -> Result<()> {
        let waited = self.wait_for(
            || "the client to record what was kept for it".into(),
            || Ok((!self.tend_kept()?).then_some(())),
        );
        match waited {
            Err(IpcError::Timeout { what, waited }) => {
                tracing::warn!(?waited, "gave up waiting for {what}");
                Ok(())
            }
            other => other,
        }
    }

    pub(super) fn pubsub<P, H>(&self, topic: &Topic) -> Result<PortFactory<Service, P, H>>
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
        .map_err(|e| {
            let needed = mismatch::Needed {
                topic,
                payload: P::payload_type(),
                user_header: TypeDetail::new::<H>(TypeVariant::FixedSize),
            };
            match mismatch::incompatible(&service_name, self.node.config(), &needed) {
                Some(reason) => IpcError::Incompatible { reason },
                None => iox_err(format!("open service {name}"))(e),
            }
        })
    }

    pub(super) fn event(
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
pub(super) fn retry_interrupted<T, E: Debug>(
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
