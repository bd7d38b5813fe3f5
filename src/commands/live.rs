//! `--live` of `run` and `replay`: the live viewer, one more process of the stack that
//! serves the run to Foxglove over WebSocket (see `docs/LIVE.md`).

use crate::supervisor::Supervisor;
use fastslam_client::viewer;
use fastslam_stack::topology::VIEWER;
use std::path::Path;

/// Flags of the live view.
#[derive(Debug, Clone, clap::Args)]
pub struct LiveArgs {
    /// Serve the run live to Foxglove over WebSocket while it goes (connect Foxglove to
    /// ws://localhost:8765): a viewer process joins the stack; no publisher waits on it.
    #[arg(long)]
    pub live: bool,
    /// Port of the live view's WebSocket server (0: any free port, named in the viewer's
    /// log).
    #[arg(long, default_value_t = viewer::DEFAULT_PORT, value_name = "PORT")]
    pub live_port: u16,
}

impl Default for LiveArgs {
    fn default() -> Self {
        Self {
            live: false,
            live_port: viewer::DEFAULT_PORT,
        }
    }
}

impl LiveArgs {
    /// With `--live`, starts the viewer on the stack `stack_flags` names (its log in
    /// `logs`) and says where to connect; before the other processes, which then wait for
    /// its subscriptions too (see `topology`).
    ///
    /// # Errors
    /// When the viewer cannot be started.
    pub fn spawn(
        &self,
        stack: &mut Supervisor,
        exe: &Path,
        stack_flags: &[String],
        logs: &Path,
    ) -> std::io::Result<()> {
        if !self.live {
            return Ok(());
        }
        let mut argv = vec![VIEWER.to_string()];
        argv.extend(stack_flags.iter().cloned());
        argv.extend(["--port".into(), self.live_port.to_string()]);
        stack.spawn(VIEWER, exe, &argv, &logs.join(format!("{VIEWER}.log")))?;
        match self.live_port {
            0 => eprintln!("live view: on the port named in {VIEWER}.log"),
            port => eprintln!("live view: connect Foxglove to ws://localhost:{port}"),
        }
        Ok(())
    }
}
