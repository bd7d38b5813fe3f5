//! A stack for your own integration tests: the FastSLAM service and the metrics client,
//! each a real process, under a fresh stack prefix and iceoryx2 root of their own; your
//! publisher joins it (a child process with [`Stack::env`], or a thread with
//! [`Stack::config`]); [`Stack::finish`] waits for the run to end and hands back the
//! client's [`Metrics`], typed.
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
//! `env!("CARGO_BIN_EXE_fastslam-stack")`, elsewhere an installed `fastslam-stack`. Drop
//! stops what still runs (SIGTERM) and removes the stack's shared memory and root.

use crate::topology::{REPLAY, Role};
use anyhow::{Context, bail};
use fastslam_client::Metrics;
use fastslam_protocol::ipc::{StackConfig, remove_stack_files};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// How a [`Stack`] is started.
#[derive(Debug, Clone)]
pub struct StackBuilder {
    launcher: PathBuf,
    service_config: Option<String>,
    client_flags: Vec<String>,
    dir: Option<PathBuf>,
}

impl StackBuilder {
    /// The service's configuration file contents (TOML, the service's config format);
    /// default: the service's defaults.
    pub fn service_config(mut self, toml: &str) -> Self {
        self.service_config = Some(toml.to_string());
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

    /// Starts the client, then the service, under a fresh prefix.
    ///
    /// # Errors
    /// When the folder cannot be made or a process cannot be started.
    pub fn start(self) -> anyhow::Result<Stack> {
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
        };
        let mut service = Vec::new();
        if let Some(toml) = &self.service_config {
            let file = stack.dir.join("service.toml");
            std::fs::write(&file, toml).with_context(|| format!("writing {}", file.display()))?;
            service.extend(["--config".to_string(), file.display().to_string()]);
        }
        let mut client = vec!["--out".to_string(), stack.out.display().to_string()];
        client.extend(self.client_flags);
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
    /// The client, then the service.
    children: Vec<(&'static str, Child)>,
}

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
            client_flags: Vec::new(),
            dir: None,
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

    /// Runs `publisher` with [`Stack::env`] to its end; its output goes to
    /// `publisher.log` in the stack's folder.
    ///
    /// # Errors
    /// When it cannot be started, or fails (with the end of its log).
    pub fn run_publisher(&mut self, mut publisher: Command) -> anyhow::Result<()> {
        let log_path = self.dir.join("publisher.log");
        let log = std::fs::File::create(&log_path)?;
        let status = publisher
            .envs(self.env())
            .stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log)
            .status()
            .context("starting the publisher")?;
        if !status.success() {
            bail!("the publisher failed ({status}):\n{}", tail(&log_path));
        }
        Ok(())
    }

    /// Waits (up to `timeout`) until the service and the client have ended, then reads the
    /// client's metrics.
    ///
    /// # Errors
    /// When a process fails or outlives `timeout` (with the end of its log), or the
    /// metrics cannot be read.
    pub fn finish(mut self, timeout: Duration) -> anyhow::Result<Metrics> {
        let started = Instant::now();
        for i in 0..self.children.len() {
            let status = loop {
                if let Some(status) = self.children[i].1.try_wait()? {
                    break status;
                }
                if started.elapsed() > timeout {
                    let name = self.children[i].0;
                    bail!(
                        "the {name} did not end within {timeout:?}:\n{}",
                        tail(&self.log(name))
                    );
                }
                std::thread::sleep(Duration::from_millis(20));
            };
            self.check(i, status)?;
        }
        Metrics::read(&self.out.join("metrics.json"))
    }

    /// Fails with the end of the log of child `i` unless `status` is success.
    fn check(&self, i: usize, status: ExitStatus) -> anyhow::Result<()> {
        let name = self.children[i].0;
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
        let child = Command::new(launcher)
            .arg(role.name)
            .args(["--prefix", &self.stack.prefix])
            .args(["--iox-root", self.stack.root.as_deref().unwrap_or_default()])
            .args(flags)
            .args(role.wait_flags())
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
        for (_, child) in &mut self.children {
            if child.try_wait().ok().flatten().is_none() {
                let pid = nix::unistd::Pid::from_raw(child.id() as i32);
                let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM);
                let _ = child.wait();
            }
        }
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
