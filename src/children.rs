//! Children that die with the process that started them, however it ends: each asks the
//! kernel for SIGKILL when its parent ends (`PR_SET_PDEATHSIG`). Every process the
//! launcher, its commands and the test harness start is one. And how they are stopped:
//! signal after signal, each after a grace period, SIGKILL last ([`stop`]).

use nix::errno::Errno;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use std::os::unix::process::CommandExt;
use std::process::{Child, Command};
use std::time::{Duration, Instant};

/// How long a child gets after each signal of [`stop`] before the next, stronger one.
pub const GRACE: Duration = Duration::from_secs(5);
/// How often [`stop`] looks whether the children have ended.
const POLL: Duration = Duration::from_millis(20);

/// `command`, whose process the kernel kills (SIGKILL) when this process ends, however
/// it ends (`PR_SET_PDEATHSIG`). The kernel sends it when the *thread* that starts the
/// child ends: start it from a thread that outlives it.
pub fn dying_with_this_process(command: &mut Command) -> &mut Command {
    let launcher = nix::unistd::getpid();
    // SAFETY: `die_with` makes two system calls and allocates nothing, as a function run
    // between fork and exec must.
    unsafe { command.pre_exec(move || die_with(launcher)) }
}

/// In a child between fork and exec: SIGKILL when the `launcher` ends. A launcher that
/// ended before the request took effect (the child was then re-parented) fails the
/// start instead, so no child outlives it.
fn die_with(launcher: Pid) -> std::io::Result<()> {
    nix::sys::prctl::set_pdeathsig(Signal::SIGKILL)?;
    if nix::unistd::getppid() != launcher {
        return Err(std::io::Error::other("the launcher has ended"));
    }
    Ok(())
}

/// A started child that [`stop`] stops.
#[derive(Debug)]
pub struct Stopping<'a> {
    /// The child.
    pub child: &'a mut Child,
    /// True when the child leads a process group of its own (`process_group(0)`) whose
    /// every process is signalled and waited for: a shell and what it started.
    pub group: bool,
}

impl Stopping<'_> {
    /// The target of its signals: the child, or its process group.
    fn target(&self) -> Pid {
        let pid = self.child.id() as i32;
        Pid::from_raw(if self.group { -pid } else { pid })
    }

    /// True while the child (reaped here when it has ended) or, for a group, any process
    /// of its group runs.
    fn running(&mut self) -> bool {
        let child_runs = !matches!(self.child.try_wait(), Ok(Some(_)));
        child_runs || (self.group && kill(self.target(), None) != Err(Errno::ESRCH))
    }
}

/// Stops `children`: sends each of `signals` in turn to those still running and gives
/// them [`GRACE`] to end before the next; returns once all have ended (the children are
/// reaped) or the last signal's grace is over. With SIGKILL last, nothing outlives it.
pub fn stop(children: &mut [Stopping<'_>], signals: &[Signal]) {
    for &signal in signals {
        let mut any = false;
        for c in children.iter_mut() {
            if c.running() {
                any = true;
                // It may have ended since the look: ESRCH is fine.
                let _ = kill(c.target(), signal);
            }
        }
        if !any {
            return;
        }
        let deadline = Instant::now() + GRACE;
        while Instant::now() < deadline && children.iter_mut().any(|c| c.running()) {
            std::thread::sleep(POLL);
        }
    }
}
