//! Children that die with the process that started them, however it ends: each asks the
//! kernel for SIGKILL when its parent ends (`PR_SET_PDEATHSIG`). Every process the
//! launcher, its commands and the test harness start is one.

use nix::sys::signal::Signal;
use nix::unistd::Pid;
use std::os::unix::process::CommandExt;
use std::process::Command;

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
