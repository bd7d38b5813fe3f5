//! Process-wide shutdown flag: set once SIGINT or SIGTERM arrived.
//!
//! iceoryx2 catches more signals than these (SIGCONT, SIGTSTP, SIGUSR1, SIGURG, SIGPROF,
//! …), and each of them interrupts a wait with EINTR. An interrupted wait therefore asks
//! [`requested`] whether to stop: `kill -CONT` or a sampling profiler must not end a
//! process.
//!
//! [`install`] sets the dispositions every stack process needs on top of iceoryx2's:
//! - SIGINT and SIGTERM also set a flag of their own. iceoryx2 keeps only the *last*
//!   signal, so a SIGTERM followed by any other caught signal before anyone looked was
//!   lost.
//! - SIGTSTP (Ctrl-Z) gets its default action back, which suspends the process; iceoryx2
//!   would otherwise catch it and the stack would run on. `fg` (SIGCONT) resumes it.

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
