//! Starts the stack's processes, watches them, and stops them: SIGINT, then SIGTERM,
//! then SIGKILL, each after a grace period (as ROS 2 launch does). Each child runs in its
//! own process group, so a Ctrl-C in the terminal reaches only the launcher, which then
//! stops the children in order. Ctrl-Z, too, reaches only the launcher: it suspends the
//! children, then itself, and resumes them when `fg` resumes it.
//!
//! The children die with the launcher, however it dies (even SIGKILL): each asks the
//! kernel for SIGKILL when its parent ends (`PR_SET_PDEATHSIG`). The kernel sends it when
//! the *thread* that started the child ends, so a supervisor lives on the thread that
//! made it.

use fastslam_stack::children::{self, Stopping, dying_with_this_process};
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use std::fs::{File, OpenOptions};
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, ExitStatus, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How often children are polled.
const POLL: Duration = Duration::from_millis(20);

/// One started process.
#[derive(Debug)]
pub struct Process {
    /// Its role in the stack (also the subcommand that started it).
    pub name: &'static str,
    child: Child,
    status: Option<ExitStatus>,
    /// Its command line and log.
    exe: PathBuf,
    args: Vec<String>,
    log: PathBuf,
    /// Whether it is started again when a signal kills it
    /// ([`Supervisor::restart_when_killed`]).
    again: Option<Again>,
}

/// How a process killed by a signal is started again: its command line with `flag`
/// added, its output appended to its log, at most [`MOST_RESTARTS`] times.
#[derive(Debug)]
struct Again {
    flag: &'static str,
    restarts: u32,
}

/// The most times a process is started again after a signal killed it.
pub const MOST_RESTARTS: u32 = 10;

/// How the stack ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Every process exited 0 on its own.
    Finished,
    /// A process failed; the others were stopped.
    Failed {
        /// The failed process.
        name: &'static str,
        /// Its exit status, as text.
        status: String,
    },
    /// The launcher was interrupted (SIGINT/SIGTERM); the processes were stopped.
    Interrupted,
    /// The run took longer than allowed; the processes were stopped.
    TimedOut {
        /// The processes still running when the time was up.
        running: Vec<&'static str>,
    },
}

/// The running processes of one stack.
#[derive(Debug, Default)]
pub struct Supervisor {
    processes: Vec<Process>,
}

impl Supervisor {
    /// Starts `exe` with `args` as process `name`, its output written to `log`.
    ///
    /// # Errors
    /// When the log cannot be opened or the process cannot be started.
    pub fn spawn(
        &mut self,
        name: &'static str,
        exe: &Path,
        args: &[String],
        log: &Path,
    ) -> std::io::Result<()> {
        let out = open_log(log)?;
        self.start(name, exe, args, log, out.try_clone()?.into(), out)
            .map(|_| ())
    }

    /// As [`Supervisor::spawn`], but the process's stdout comes back as a pipe for the
    /// caller to read (and copy into `log`, which is opened for appending, so both
    /// writers' lines land whole).
    ///
    /// # Errors
    /// When the log cannot be opened or the process cannot be started.
    pub fn spawn_reading_stdout(
        &mut self,
        name: &'static str,
        exe: &Path,
        args: &[String],
        log: &Path,
    ) -> std::io::Result<ChildStdout> {
        let out = open_log(log)?;
        let child = self.start(name, exe, args, log, Stdio::piped(), out)?;
        child
            .stdout
            .take()
            .ok_or_else(|| std::io::Error::other("the child's stdout pipe is missing"))
    }

    /// Starts process `name` again, with `flag` added to its command line, whenever a
    /// signal kills it (SIGKILL, a crash), at most [`MOST_RESTARTS`] times; its output
    /// then goes to its log, appended. A process that exits, whatever its status, is not
    /// started again.
    pub fn restart_when_killed(&mut self, name: &'static str, flag: &'static str) {
        if let Some(p) = self.processes.iter_mut().find(|p| p.name == name) {
            p.again = Some(Again { flag, restarts: 0 });
        }
    }

    /// Starts again the processes that a signal killed and that may be (see
    /// [`Supervisor::restart_when_killed`]), saying so on stderr.
    fn restart_killed(&mut self) {
        for p in &mut self.processes {
            let (Some(status), Some(again)) = (p.status, &mut p.again) else {
                continue;
            };
            let Some(signal) = status.signal() else {
                continue;
            };
            if again.restarts >= MOST_RESTARTS {
                continue;
            }
            again.restarts += 1;
            let args = (p.args.iter().map(String::as_str)).chain([again.flag]);
            let started = OpenOptions::new()
                .append(true)
                .open(&p.log)
                .and_then(|log| launch(&p.exe, args, log.try_clone()?.into(), log));
            match started {
                Ok(child) => {
                    eprintln!(
                        "the {} was killed (signal {signal}): started again with {} ({} of at most {MOST_RESTARTS})",
                        p.name, again.flag, again.restarts
                    );
                    p.child = child;
                    p.status = None;
                }
                Err(e) => eprintln!("the {} cannot be started again: {e}", p.name),
            }
        }
    }

    fn start(
        &mut self,
        name: &'static str,
        exe: &Path,
        args: &[String],
        log: &Path,
        stdout: Stdio,
        stderr: File,
    ) -> std::io::Result<&mut Child> {
        let child = launch(exe, args, stdout, stderr)?;
        tracing::debug!(name, pid = child.id(), "started");
        self.processes.push(Process {
            name,
            child,
            status: None,
            exe: exe.to_path_buf(),
            args: args.to_vec(),
            log: log.to_path_buf(),
            again: None,
        });
        let last = self.processes.len() - 1;
        Ok(&mut self.processes[last].child)
    }

    /// Waits until every process has exited, one fails, `stop` is raised or `timeout`
    /// passes; in the last three cases the remaining processes are stopped.
    ///
    /// Time spent suspended (Ctrl-Z until `fg`) does not count towards `timeout`.
    pub fn wait(&mut self, stop: &AtomicBool, timeout: Option<Duration>) -> Outcome {
        let start = Instant::now();
        let mut suspended = Duration::ZERO;
        let ctrl_z = CtrlZ::watch();
        let outcome = loop {
            let _ = self.poll();
            self.restart_killed();
            if let Some(failed) = self.poll().find(|p| p.status.is_some_and(|s| !s.success())) {
                break Outcome::Failed {
                    name: failed.name,
                    status: describe(failed.status),
                };
            }
            if self.processes.iter().all(|p| p.status.is_some()) {
                return Outcome::Finished;
            }
            if stop.load(Ordering::SeqCst) {
                break Outcome::Interrupted;
            }
            if timeout.is_some_and(|t| start.elapsed().saturating_sub(suspended) > t) {
                // The statuses were refreshed at the top of this round.
                let running = self.processes.iter().filter(|p| p.status.is_none());
                break Outcome::TimedOut {
                    running: running.map(|p| p.name).collect(),
                };
            }
            if ctrl_z.pressed() {
                let since = Instant::now();
                self.suspend_all();
                suspended += since.elapsed();
            }
            std::thread::sleep(POLL);
        };
        self.stop_all();
        outcome
    }

    /// Ctrl-Z: stops every running process (SIGSTOP, which no process can catch), then
    /// the launcher itself, as the shell expects of the job it suspended. When `fg` or
    /// `bg` resumes the launcher, it resumes the processes.
    fn suspend_all(&mut self) {
        let running: Vec<Pid> = self
            .poll()
            .filter(|p| p.status.is_none())
            .map(|p| Pid::from_raw(p.child.id() as i32))
            .collect();
        for &pid in &running {
            let _ = kill(pid, Signal::SIGSTOP);
        }
        tracing::info!(
            processes = running.len(),
            "suspended (Ctrl-Z); fg resumes the run"
        );
        if let Err(e) = signal_hook::low_level::raise(signal_hook::consts::SIGSTOP) {
            tracing::warn!(error = %e, "cannot suspend the launcher itself");
        }
        for &pid in &running {
            let _ = kill(pid, Signal::SIGCONT);
        }
        tracing::info!("resumed");
    }

    /// Refreshes exit statuses and returns the processes.
    fn poll(&mut self) -> impl Iterator<Item = &Process> {
        for p in self.processes.iter_mut().filter(|p| p.status.is_none()) {
            p.status = p.child.try_wait().ok().flatten();
        }
        self.processes.iter()
    }

    /// Stops every running process: SIGINT, SIGTERM, SIGKILL, each after
    /// [`children::GRACE`].
    pub fn stop_all(&mut self) {
        let mut running: Vec<Stopping<'_>> = (self.processes.iter_mut())
            .filter(|p| p.status.is_none())
            .map(|p| Stopping {
                child: &mut p.child,
                group: false,
            })
            .collect();
        children::stop(
            &mut running,
            &[Signal::SIGINT, Signal::SIGTERM, Signal::SIGKILL],
        );
        let _ = self.poll();
    }
}

/// Ctrl-Z (SIGTSTP) to the launcher, watched while it waits for its processes.
struct CtrlZ {
    pressed: Arc<AtomicBool>,
    id: Option<signal_hook::SigId>,
}

impl CtrlZ {
    /// Starts watching until dropped; without a handler (logged) Ctrl-Z stops the
    /// launcher alone, as before.
    fn watch() -> Self {
        let pressed = Arc::new(AtomicBool::new(false));
        let id = signal_hook::flag::register(signal_hook::consts::SIGTSTP, Arc::clone(&pressed))
            .map_err(|e| tracing::warn!(error = %e, "cannot watch Ctrl-Z: it will stop the launcher only"))
            .ok();
        Self { pressed, id }
    }

    /// True once per Ctrl-Z.
    fn pressed(&self) -> bool {
        self.pressed.swap(false, Ordering::SeqCst)
    }
}

impl Drop for CtrlZ {
    fn drop(&mut self) {
        if let Some(id) = self.id.take() {
            signal_hook::low_level::unregister(id);
        }
    }
}

impl Drop for Supervisor {
    fn drop(&mut self) {
        self.stop_all();
    }
}

/// Starts `exe` with `args` in a process group of its own, dying with this process, its
/// output going to `stdout` and `stderr`.
fn launch<I, S>(exe: &Path, args: I, stdout: Stdio, stderr: File) -> std::io::Result<Child>
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    let mut command = Command::new(exe);
    command
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .process_group(0);
    dying_with_this_process(&mut command).spawn()
}

/// Creates (or empties) a log and opens it for appending.
fn open_log(log: &Path) -> std::io::Result<File> {
    File::create(log)?;
    OpenOptions::new().append(true).open(log)
}

fn describe(status: Option<ExitStatus>) -> String {
    status.map_or_else(|| "running".to_string(), |s| s.to_string())
}

/// A flag raised by SIGINT or SIGTERM to the launcher.
///
/// # Errors
/// When the signal handlers cannot be installed.
pub fn stop_flag() -> std::io::Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&flag))?;
    }
    Ok(flag)
}
