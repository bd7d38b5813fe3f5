//! A stack for your own integration tests: the FastSLAM service and the metrics client,
//! each a real process, under a fresh stack prefix and iceoryx2 root of their own; your
//! publisher joins it (a child process with [`Stack::env`], or a thread with
//! [`Stack::config`]); [`Stack::finish`] waits for the run to end and hands back the
//! client's [`Metrics`], typed. Expectations given to the builder ([`StackBuilder::expect`])
//! are judged by the client, as `fastslam-stack test` does.
//!
//! ```no_run
//! use fastslam_stack::harness::Stack;
//! # fn main() -> anyhow::Result<()> {
//! let mut stack = Stack::builder("fastslam-stack")
//!     .service_config("[filter.association]\nmode = \"known\"\n")
//!     .start()?;
//! let mut publisher = std::process::Command::new("python3");
//! publisher.arg("examples/python/publisher.py");
//! stack.run_publisher(publisher)?;
//! let metrics = stack.finish(std::time::Duration::from_secs(120))?;
//! assert!(metrics.estimate.ate_rmse_m < 0.5);
//! # Ok(())
//! # }
//! ```
//!
//! The processes are the launcher's own subcommands (`service`, `client`), started from
//! the launcher executable you name: in this workspace's tests
//! `env!("CARGO_BIN_EXE_fastslam-stack")`, elsewhere an installed `fastslam-stack`. The
//! service runs as fast as possible (it takes the publisher's samples as fast as they
//! come, drops none and waits for a silent one) unless [`StackBuilder::realtime`] says
//! otherwise. Drop stops what still runs — SIGTERM, then SIGKILL after
//! [`children::GRACE`] — and removes the stack's shared memory and root; every process
//! it starts also dies with the process that started it, however that ends
//! (`PR_SET_PDEATHSIG`, sent when the thread that started the process ends: keep a
//! [`Stack`] on the thread that made it).

use crate::children::{self, Stopping, dying_with_this_process};
use crate::topology::{REPLAY, Role};
use anyhow::{Context, bail};
use fastslam_client::Metrics;
use fastslam_client::expect::{Expectations, JudgeArgs, Verdict};
use fastslam_protocol::ipc::{StackConfig, remove_stack_files};
use nix::sys::signal::Signal;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How a [`Stack`] is started.
#[derive(Debug, Clone)]
pub struct StackBuilder {
    launcher: PathBuf,
    service_config: Option<String>,
    service_flags: Vec<String>,
    realtime: bool,
    client_flags: Vec<String>,
    dir: Option<PathBuf>,
    judge: JudgeArgs,
    stop: Option<Arc<AtomicBool>>,
}

impl StackBuilder {
    /// The service's configuration file contents (TOML, the service's config format);
    /// default: the service's defaults.
    pub fn service_config(mut self, toml: &str) -> Self {
        self.service_config = Some(toml.to_string());
        self
    }

    /// Extra flags for the service (`--save-map=map.csv`).
    pub fn service_flags<S: Into<String>>(mut self, flags: impl IntoIterator<Item = S>) -> Self {
        self.service_flags.extend(flags.into_iter().map(Into::into));
        self
    }

    /// The service takes its inputs as real-time sensors' instead of as fast as possible:
    /// a full input queue drops its oldest input, and a sensor silent beyond the deadline
    /// is not waited for (docs/SENSORS.md).
    pub fn realtime(mut self, realtime: bool) -> Self {
        self.realtime = realtime;
        self
    }

    /// Extra flags for the client (`--align se2`, `--score-at truth`).
    pub fn client_flags<S: Into<String>>(mut self, flags: impl IntoIterator<Item = S>) -> Self {
        self.client_flags.extend(flags.into_iter().map(Into::into));
        self
    }

    /// Where the run folder (`run/`) and the processes' logs go (default: a fresh folder
    /// under the system's temporary directory).
    pub fn dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.dir = Some(dir.into());
        self
    }

    /// An expectation on the metrics (`"estimate.ate_rmse_m < 0.5"`, see
    /// `client/METRICS.md`) for the client to judge; [`Stack::finish`] fails when one
    /// does not hold.
    pub fn expect(mut self, expression: impl Into<String>) -> Self {
        self.judge.expect.push(expression.into());
        self
    }

    /// Expectations and a JUnit report, as the client's flags give them.
    pub fn judge(mut self, judge: JudgeArgs) -> Self {
        self.judge.expect.extend(judge.expect);
        self.judge.junit = judge.junit.or(self.judge.junit);
        self
    }

    /// A flag that, once raised (a signal handler's), makes [`Stack::finish`] give up.
    pub fn stop_flag(mut self, stop: Arc<AtomicBool>) -> Self {
        self.stop = Some(stop);
        self
    }

    /// Starts the client, then the service, under a fresh prefix.
    ///
    /// # Errors
    /// When an expectation is malformed or names no number of the metrics, the folder
    /// cannot be made, or a process cannot be started.
    pub fn start(self) -> anyhow::Result<Stack> {
        let expectations = self.judge.expectations()?;
        let prefix = fresh_prefix();
        let dir = self
            .dir
            .unwrap_or_else(|| std::env::temp_dir().join(format!("fastslam-harness-{prefix}")));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut stack = Stack {
            stack: StackConfig {
                prefix: prefix.clone(),
                root: Some(crate::stack_root(&prefix).display().to_string()),
            },
            out: dir.join("run"),
            dir,
            children: Vec::new(),
            judge: self.judge.on().then_some(expectations),
            stop: self.stop,
        };
        let old_metrics = stack.out.join("metrics.json");
        if old_metrics.is_file() {
            std::fs::remove_file(&old_metrics)
                .with_context(|| format!("removing {}", old_metrics.display()))?;
        }
        let mut service = Vec::new();
        let mut client = vec!["--out".to_string(), stack.out.display().to_string()];
        if let Some(toml) = &self.service_config {
            let file = stack.dir.join("service.toml");
            std::fs::write(&file, toml).with_context(|| format!("writing {}", file.display()))?;
            service.extend(["--config".to_string(), file.display().to_string()]);
            client.extend(["--service-config".to_string(), file.display().to_string()]);
        }
        if !self.realtime {
            service.push("--as-fast-as-possible".to_string());
        }
        service.extend(self.service_flags);
        client.extend(self.client_flags);
        client.extend(self.judge.flags());
        for role in REPLAY.iter().filter(|r| r.name != "replay") {
            let flags = if role.name == "client" {
                &client
            } else {
                &service
            };
            stack.spawn(&self.launcher, role, flags)?;
        }
        Ok(stack)
    }
}

/// A running service and client; see the module documentation.
#[derive(Debug)]
pub struct Stack {
    stack: StackConfig,
    dir: PathBuf,
    out: PathBuf,
    /// The client, then the service, then the publisher if it was started.
    children: Vec<(&'static str, Child)>,
    /// The expectations when the run is judged.
    judge: Option<Expectations>,
    stop: Option<Arc<AtomicBool>>,
}

/// The name of the publisher among a stack's processes (and of its log).
const PUBLISHER: &str = "publisher";

/// A prefix no other stack of this machine uses: the process id and a counter.
fn fresh_prefix() -> String {
    use std::sync::atomic::{AtomicU32, Ordering};
    static NEXT: AtomicU32 = AtomicU32::new(0);
    format!(
        "fh{}x{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    )
}

impl Stack {
    /// A stack of the launcher executable `launcher` (a path, or a name on `PATH`).
    pub fn builder(launcher: impl Into<PathBuf>) -> StackBuilder {
        StackBuilder {
            launcher: launcher.into(),
            service_config: None,
            service_flags: Vec::new(),
            realtime: false,
            client_flags: Vec::new(),
            dir: None,
            judge: JudgeArgs::default(),
            stop: None,
        }
    }

    /// The stack's prefix and iceoryx2 root, for a publisher on a thread of the test
    /// (`fastslam_protocol::ipc::Ipc::open`).
    pub fn config(&self) -> &StackConfig {
        &self.stack
    }

    /// The environment a publisher process needs to join: `FASTSLAM_PREFIX` and
    /// `FASTSLAM_IOX_ROOT` (the processes of this stack read the same variables).
    pub fn env(&self) -> [(&'static str, String); 2] {
        [
            ("FASTSLAM_PREFIX", self.stack.prefix.clone()),
            (
                "FASTSLAM_IOX_ROOT",
                self.stack.root.clone().unwrap_or_default(),
            ),
        ]
    }

    /// The run folder the client writes (`metrics.json`, trajectories, pictures).
    pub fn run_folder(&self) -> &Path {
        &self.out
    }

    /// Starts `publisher` with [`Stack::env`], in a process group of its own (so that
    /// stopping it stops what it started, a shell's children too); its output goes to
    /// `publisher.log` in the stack's folder. [`Stack::finish`] waits for it.
    ///
    /// # Errors
    /// When it cannot be started.
    pub fn start_publisher(&mut self, mut publisher: Command) -> anyhow::Result<()> {
        let log = std::fs::File::create(self.log(PUBLISHER))?;
        let child = dying_with_this_process(&mut publisher)
            .envs(self.env())
            .stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log)
            .process_group(0)
            .spawn()
            .context("starting the publisher")?;
        self.children.push((PUBLISHER, child));
        Ok(())
    }

    /// Runs `publisher` as [`Stack::start_publisher`] does, to its end.
    ///
    /// # Errors
    /// When it cannot be started, or fails (with the end of its log).
    pub fn run_publisher(&mut self, publisher: Command) -> anyhow::Result<()> {
        self.start_publisher(publisher)?;
        let last = self.children.len() - 1;
        let status = self.children[last].1.wait()?;
        self.check(last, status)
    }

    /// Waits (up to `timeout`) until every process has ended, then reads the client's
    /// metrics.
    ///
    /// # Errors
    /// When a process fails or outlives `timeout` (with the end of its log), the stop flag
    /// is raised, the metrics cannot be read, or, with expectations, the run fails them
    /// (or a stream did not end).
    pub fn finish(self, timeout: Duration) -> anyhow::Result<Metrics> {
        let judged = self.judge.is_some();
        let (metrics, verdict) = self.finish_judged(timeout)?;
        if judged {
            verdict.into_result()?;
        }
        Ok(metrics)
    }

    /// As [`Stack::finish`], but a run that fails its expectations is no error: returns
    /// the metrics and the verdict (without expectations, only whether every stream
    /// ended).
    ///
    /// # Errors
    /// When a process fails or outlives `timeout` (with the end of its log), the stop flag
    /// is raised, or the metrics cannot be read.
    pub fn finish_judged(mut self, timeout: Duration) -> anyhow::Result<(Metrics, Verdict)> {
        let started = Instant::now();
        let mut running: Vec<usize> = (0..self.children.len()).collect();
        while !running.is_empty() {
            let mut still = Vec::new();
            for i in running {
                match self.children[i].1.try_wait()? {
                    None => still.push(i),
                    Some(status) if status.success() || self.judged_failure(i) => {}
                    Some(status) => self.check(i, status)?,
                }
            }
            running = still;
            if self.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst)) {
                bail!("interrupted");
            }
            if !running.is_empty() && started.elapsed() > timeout {
                let names: Vec<&str> = running.iter().map(|&i| self.children[i].0).collect();
                let log = tail(&self.log(names[0]));
                let end = if log.is_empty() {
                    String::new()
                } else {
                    format!("; the {}'s log ends with:\n{log}", names[0])
                };
                bail!("still running after {timeout:?}: {}{end}", names.join(", "));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let metrics = Metrics::read(&self.out.join("metrics.json"))?;
        let verdict = self.judge.clone().unwrap_or_default().judge(&metrics);
        Ok((metrics, verdict))
    }

    /// True when child `i` is the client and it failed because the run it judged failed
    /// its expectations (it wrote metrics.json that fail them).
    fn judged_failure(&self, i: usize) -> bool {
        let judged = self
            .judge
            .as_ref()
            .filter(|_| self.children[i].0 == "client");
        judged.is_some_and(|e| e.judge_folder(&self.out).is_ok_and(|v| !v.passed()))
    }

    /// Fails with the end of the log of child `i` unless `status` is success; a client
    /// that failed a run without a pose estimate (its run folder written) fails with that
    /// one line.
    fn check(&self, i: usize, status: ExitStatus) -> anyhow::Result<()> {
        let name = self.children[i].0;
        if name == "client"
            && let Ok(metrics) = Metrics::read(&self.out.join("metrics.json"))
        {
            metrics.require_a_pose(&self.out)?;
        }
        if !status.success() {
            bail!("the {name} failed ({status}):\n{}", tail(&self.log(name)));
        }
        Ok(())
    }

    /// The log file of process `name` (`service`, `client`, `publisher`).
    pub fn log(&self, name: &str) -> PathBuf {
        self.dir.join(format!("{name}.log"))
    }

    fn spawn(&mut self, launcher: &Path, role: &Role, flags: &[String]) -> anyhow::Result<()> {
        let log = std::fs::File::create(self.log(role.name))?;
        let child = dying_with_this_process(&mut Command::new(launcher))
            .arg(role.name)
            .args(["--prefix", &self.stack.prefix])
            .args(["--iox-root", self.stack.root.as_deref().unwrap_or_default()])
            .args(flags)
            .args(role.wait_flags(false))
            .stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log)
            .spawn()
            .with_context(|| format!("starting {} {}", launcher.display(), role.name))?;
        self.children.push((role.name, child));
        Ok(())
    }
}

impl Drop for Stack {
    fn drop(&mut self) {
        // The publisher leads a process group of its own: all of it is stopped, also
        // what it left running after it ended.
        let mut running: Vec<Stopping<'_>> = (self.children.iter_mut())
            .map(|(name, child)| Stopping {
                group: *name == PUBLISHER,
                child,
            })
            .collect();
        children::stop(&mut running, &[Signal::SIGTERM, Signal::SIGKILL]);
        let root = self.stack.root.as_deref().map(Path::new);
        remove_stack_files(&self.stack.prefix, root);
    }
}

/// The last lines of a log, for an error message.
fn tail(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(15)..].join("\n")
}
