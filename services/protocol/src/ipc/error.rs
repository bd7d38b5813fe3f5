//! What can go wrong in the IPC helpers ([`IpcError`]), and how iceoryx2's errors become
//! one.

use std::fmt::Debug;
use std::time::Duration;

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
    /// A topic's service exists with settings the stack cannot use: another process
    /// created it with settings of its own.
    #[error("{reason}")]
    Incompatible {
        /// Which setting falls short, what the stack needs, and what to do.
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

pub(super) fn iox_err<E: Debug>(action: impl Into<String>) -> impl FnOnce(E) -> IpcError {
    let action = action.into();
    move |e| IpcError::Iceoryx {
        action,
        reason: format!("{e:?}"),
    }
}
