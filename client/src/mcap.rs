//! `run.mcap`: what the client receives, as it receives it, written with the Foxglove SDK
//! through the run's channels ([`RunLog`]: topics and schemas listed there, the live
//! view's as well), stamped with the messages' own stamps; the metrics end it as one JSON
//! message on `/metrics`. Foxglove, `mcap` and the MCAP libraries open it.

use crate::Metrics;
use crate::foxglove_log::RunLog;
use foxglove::{Context, McapWriterHandle, PartialMetadata, RawChannel};
use std::fs::File;
use std::io::BufWriter;
use std::ops::{Deref, DerefMut};
use std::path::Path;
use std::sync::Arc;

/// The MCAP file of a run being recorded: the run's channels ([`RunLog`], which it
/// dereferences to) with the file as their one sink.
pub struct RunMcap {
    /// Keeps the channels' context (and so the writer's sink) alive.
    _context: Arc<Context>,
    writer: McapWriterHandle<BufWriter<File>>,
    log: RunLog,
    metrics: Arc<RawChannel>,
}

impl RunMcap {
    /// Starts the file at `path` (replacing one that is there).
    ///
    /// # Errors
    /// When the file cannot be created.
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        match std::fs::remove_file(path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e)?,
            _ => {}
        }
        let context = Context::new();
        let writer = context.mcap_writer().create_new_buffered_file(path)?;
        Ok(Self {
            log: RunLog::new(&context),
            metrics: (context.channel_builder("/metrics"))
                .message_encoding("json")
                .build_raw()?,
            writer,
            _context: context,
        })
    }

    /// Logs the metrics on `/metrics` at the newest stamp and closes the file.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn finish(self, metrics: &Metrics) -> anyhow::Result<()> {
        let json = serde_json::to_vec(metrics)?;
        self.metrics
            .log_with_meta(&json, PartialMetadata::with_log_time(self.log.last_ns()));
        self.writer.close()?;
        Ok(())
    }
}

impl Deref for RunMcap {
    type Target = RunLog;

    fn deref(&self) -> &RunLog {
        &self.log
    }
}

impl DerefMut for RunMcap {
    fn deref_mut(&mut self) -> &mut RunLog {
        &mut self.log
    }
}
