//! `run --host`: one host's part of a stack split across two computers, with a bridge
//! that carries the topics between them over Zenoh (see `docs/MULTI_HOST.md`). The
//! sensor host runs the truth, the sensors and the client (its run folder holds the
//! metrics); the service host runs the FastSLAM service. Each host's processes wait for
//! the same subscriber counts as on one host: the bridge subscribes in the other host's
//! place once a process there does.

use crate::supervisor::{Outcome, Supervisor};
use clap::ValueEnum;
use fastslam_bridge::Side;
use fastslam_bridge::link::{DEFAULT_KEY, ZenohArgs};
use std::path::Path;

/// Flags of a split stack.
#[derive(Debug, Clone, clap::Args)]
pub struct HostArgs {
    /// Run only this host's part of the stack, with a bridge to the other host:
    /// `sensors` (truth, sensors and client; the run folder is written here) or `service`
    /// (the FastSLAM service). Run the same command with the other value on the other
    /// computer; one of the two listens (`--listen`), the other connects (`--connect`).
    #[arg(long, value_enum)]
    pub host: Option<Side>,
    /// Where the bridge meets the other host.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

impl Default for HostArgs {
    /// The whole stack on this host.
    fn default() -> Self {
        Self {
            host: None,
            zenoh: ZenohArgs {
                listen: Vec::new(),
                connect: Vec::new(),
                key: DEFAULT_KEY.to_string(),
                multicast: false,
            },
        }
    }
}

impl HostArgs {
    /// True when `process` runs on this host.
    pub fn runs_here(&self, process: &str) -> bool {
        match self.host {
            None => true,
            Some(Side::Service) => process == "service",
            Some(Side::Sensors) => process != "service",
        }
    }

    /// Checks the flags before anything starts: with `--host`, a way to the other host;
    /// the live view (`live`) only on the sensor host (the truth and the sensors are not on
    /// the service host to show).
    ///
    /// # Errors
    /// What is wrong with the flags.
    pub fn check(&self, live: bool) -> anyhow::Result<()> {
        match self.host {
            None => Ok(()),
            Some(Side::Service) if live => {
                anyhow::bail!("--live runs on the sensor host (--host sensors), where the run is")
            }
            Some(_) => self.zenoh.check(),
        }
    }

    /// Starts the bridge (first: the other processes wait for its subscriptions) on the
    /// stack `stack_flags` names, its log in `logs`; nothing without `--host`.
    ///
    /// # Errors
    /// When the bridge cannot be started.
    pub fn spawn_bridge(
        &self,
        stack: &mut Supervisor,
        exe: &Path,
        stack_flags: &[String],
        logs: &Path,
    ) -> anyhow::Result<()> {
        let Some(side) = self.host else {
            return Ok(());
        };
        let mut argv = vec!["bridge".to_string()];
        argv.extend(stack_flags.iter().cloned());
        let side = side.to_possible_value().expect("every side is a value");
        let side = side.get_name();
        argv.extend(["--side".into(), side.into()]);
        argv.extend(self.zenoh.flags());
        stack.spawn("bridge", exe, &argv, &logs.join("bridge.log"))?;
        eprintln!(
            "bridge: this is the {side} host; its log is {}",
            logs.join("bridge.log").display()
        );
        Ok(())
    }

    /// How the service host's run ended, when this is the service host (`None`
    /// otherwise: the run folder's summary says it). The metrics are on the sensor host.
    pub fn conclusion(&self, outcome: &Outcome, logs: &Path) -> Option<u8> {
        if self.host != Some(Side::Service) || *outcome != Outcome::Finished {
            return None;
        }
        println!(
            "the service finished; the run folder with the metrics is on the sensor host. Logs: {}",
            logs.display()
        );
        Some(0)
    }
}
