//! The IPC plumbing every process of the stack shares: where a stack lives (prefix and
//! root path), and publishers/subscribers that pair each topic with an event service so
//! receivers sleep in a `WaitSet` instead of polling.
//!
//! Delivery is lossless by default: services are created without safe overflow and
//! publishers retry until a full subscriber buffer has room ("as fast as possible, lose
//! nothing"), giving up only when the process is asked to shut down.
//!
//! One file per concern, all re-exported here:
//! - `stack`: where a stack lives ([`StackConfig`]) and the files it leaves behind;
//! - [`shutdown`]: SIGINT/SIGTERM and the other signals iceoryx2 catches;
//! - `node`: a process's connection ([`Ipc`]), its bounded waits, opening services;
//! - `mismatch`: why a service another process created cannot be opened;
//! - `wake`: the loop that sleeps until samples arrive ([`Ipc::wake_loop`]);
//! - `publisher`: [`Pub`], lossless and optionally coalescing wake-ups;
//! - `kept`: what a publisher keeps for the client and sends again when it restarts;
//! - `subscriber`: [`Sub`], [`HoldingSub`] and publisher probes;
//! - `request_response`: [`SliceServer`] and [`Ipc::request_slice`];
//! - `wire`: [`Wire`], one API over fixed-size and slice payloads;
//! - `error`: [`IpcError`].

mod error;
mod kept;
mod mismatch;
mod node;
mod publisher;
mod request_response;
pub mod shutdown;
mod stack;
mod subscriber;
#[cfg(test)]
mod testing;
mod wake;
mod wire;

use error::iox_err;
pub use error::{IpcError, Result};
pub use node::Ipc;
pub use publisher::{
    COALESCING_PERIOD, OUTSIDE_GRACE, Pub, STACK_NODES, Subscribers, is_stack_node,
};
pub use request_response::SliceServer;
pub use stack::{StackConfig, remove_dead_nodes, remove_stack_files, shared_memory_files};
pub use subscriber::{HoldingSub, PublisherCount, Received, Sub, Taken};
pub use wake::{Ended, Flow, LOST_WAKEUP_GUARD, WakeSource};
pub use wire::{Service, Wire};
