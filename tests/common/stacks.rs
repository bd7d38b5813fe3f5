//! The short scenario's stack for tests that join it or damage it: started by the
//! launcher in the background, or process by process ([`SimStack`]).

use super::{HandStack, LAUNCHER, folder, prefix, short_scenario};
use fastslam_protocol::ipc::{Ipc, StackConfig};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// The stack's iceoryx2 location, as `fastslam-stack run` derives it from the prefix.
pub fn stack(prefix: &str) -> StackConfig {
    StackConfig {
        prefix: prefix.to_string(),
        root: Some(fastslam_stack::stack_root(prefix).display().to_string()),
    }
}

/// Starts `fastslam-stack run` on `scenario` in real time in the background.
pub fn launch(prefix: &str, out: &Path, scenario: &Path) -> Child {
    launcher(prefix, out, scenario)
        .spawn()
        .expect("starting the launcher")
}

/// The command of [`launch`].
pub fn launcher(prefix: &str, out: &Path, scenario: &Path) -> Command {
    let mut command = Command::new(LAUNCHER);
    command
        .args(["run", "--prefix", prefix, "--realtime", "--scenario"])
        .arg(scenario)
        .arg("--out")
        .arg(out)
        .args(["--timeout-s", "120"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    command
}

/// The short scenario's stack started by hand ([`HandStack`]) with the flags the launcher
/// gives each process; its folder (logs, run folder) is removed on drop unless the test
/// failed.
pub struct SimStack {
    /// The processes.
    pub stack: HandStack,
    /// The test's folder: logs, scenario, run folder.
    pub dir: PathBuf,
    /// The short scenario's file.
    pub scenario: PathBuf,
    /// Pace the truth in real time (else as fast as the stack goes).
    pub realtime: bool,
    /// Subscribers the truth waits for (odometry, lidar, client).
    pub truth_subscribers: usize,
    /// Extra flags of the service.
    pub service_flags: Vec<String>,
}

impl SimStack {
    /// The stack of test `test`, nothing started yet: in real time, the truth waiting for
    /// three subscribers, the service with no extra flags.
    pub fn new(test: &str) -> Self {
        let prefix = prefix(test);
        let dir = folder(&prefix);
        let scenario = short_scenario(&dir);
        Self {
            stack: HandStack::new(&prefix, dir.join("logs")),
            dir,
            scenario,
            realtime: true,
            truth_subscribers: 3,
            service_flags: Vec::new(),
        }
    }

    /// Starts every process in the launcher's order: the consumers, then the sensors.
    pub fn start_all(&mut self) {
        for name in [
            "client",
            "service",
            "odometry-sim",
            "lidar-sim",
            "truth-sim",
        ] {
            self.start(name);
        }
    }

    /// Starts process `name` (a launcher subcommand) with the flags the launcher gives it.
    pub fn start(&mut self, name: &'static str) {
        let sim = |subscribers: &str| {
            vec![
                "--scenario".to_string(),
                self.scenario.display().to_string(),
                "--seed".into(),
                "1".into(),
                "--wait-subscribers".into(),
                subscribers.into(),
            ]
        };
        let mut args = Vec::new();
        match name {
            "truth-sim" => {
                args.extend(sim(&self.truth_subscribers.to_string()));
                if self.realtime {
                    args.push("--realtime".into());
                }
            }
            "odometry-sim" | "lidar-sim" => args.extend(sim("2")),
            "service" => {
                args.extend(["--seed", "1", "--wait-subscribers", "1"].map(String::from));
                if !self.realtime {
                    args.push("--as-fast-as-possible".into());
                }
                args.extend(self.service_flags.iter().cloned());
            }
            "client" => args.extend(["--out".into(), self.out().display().to_string()]),
            other => panic!("unknown process {other}"),
        }
        self.stack.start(name, &args);
    }

    /// The process id of the running `name`.
    pub fn pid(&mut self, name: &str) -> u32 {
        self.stack.child(name).id()
    }

    /// The client's run folder.
    pub fn out(&self) -> PathBuf {
        self.dir.join("run")
    }

    /// Joins the stack as the test's own process.
    pub fn ipc(&self) -> Ipc {
        Ipc::open(
            &stack(&self.stack.prefix),
            "fault-test",
            Duration::from_secs(30),
        )
        .unwrap()
    }

    /// Waits until every process exited; panics naming any that failed or hung.
    pub fn wait_all(&mut self, limit: Duration) {
        for (name, status) in self.stack.wait_all(limit) {
            // A SIGKILLed process reports the signal; everyone else must succeed.
            assert!(
                status.success() || status.code().is_none(),
                "{name} failed ({status}); logs in {}",
                self.dir.display()
            );
        }
    }
}

impl Drop for SimStack {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir); // kept with its logs on failure
        }
    }
}
