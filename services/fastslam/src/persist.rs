//! What the service keeps across runs: checkpoints (`--checkpoint`, `--resume`) and
//! saved maps (`--save-map`, `--load-map`, `--localise-only`). The flags, how the filter
//! starts from them, and when files are written; the formats are in [`crate::checkpoint`]
//! and [`crate::map_file`].

use crate::checkpoint::Checkpoint;
use crate::config::{MapKind, ServiceConfig};
use crate::map_file;
use crate::slam::Slam;
use anyhow::{Context, bail};
use fastslam_protocol::Header;
use std::path::PathBuf;

/// Flags for checkpoints and saved maps.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct PersistArgs {
    /// Write a checkpoint (the full filter state) to this file every `--checkpoint-every`
    /// steps and at shutdown. Default: no checkpoints.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// Observation steps between checkpoints.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..))]
    pub checkpoint_every: u64,
    /// Continue from this checkpoint: inputs stamped at or before its last processed
    /// stamps are skipped.
    #[arg(long, conflicts_with = "load_map")]
    pub resume: Option<PathBuf>,
    /// Save the best particle's map (CSV, see `map_file`) to this file at shutdown.
    #[arg(long)]
    pub save_map: Option<PathBuf>,
    /// Start from this saved map (CSV) instead of an empty one.
    #[arg(long)]
    pub load_map: Option<PathBuf>,
    /// Keep the map fixed and estimate only the pose (needs `--load-map` or `--resume`).
    #[arg(long)]
    pub localise_only: bool,
}

impl PersistArgs {
    /// The filter these flags ask for — fresh, from a saved map or from a checkpoint — and
    /// the checkpoint it resumes, if any.
    ///
    /// # Errors
    /// A one-line reason when a file cannot be read, is not valid, or does not fit the
    /// configuration (another seed or particle count).
    pub fn start(&self, config: &ServiceConfig) -> anyhow::Result<(Slam, Option<Checkpoint>)> {
        if self.localise_only && self.load_map.is_none() && self.resume.is_none() {
            bail!("--localise-only needs a map: give --load-map or --resume");
        }
        if config.map.kind == MapKind::Grid && (self.load_map.is_some() || self.localise_only) {
            bail!(
                "[map] kind = \"grid\" has no map file to load or hold fixed: --load-map and \
                 --localise-only need kind = \"landmarks\""
            );
        }
        let (mut slam, checkpoint) = if let Some(path) = &self.resume {
            let checkpoint = Checkpoint::read(path)?;
            if checkpoint.seed != config.filter.seed {
                bail!(
                    "checkpoint {} was written with seed {}, this run has seed {}",
                    path.display(),
                    checkpoint.seed,
                    config.filter.seed
                );
            }
            let slam = Slam::resume(
                config,
                &checkpoint.filter,
                checkpoint.last_odometry_ns,
                checkpoint.last_odometry_pose,
            )
            .with_context(|| format!("checkpoint {}", path.display()))?;
            (slam, Some(checkpoint))
        } else if let Some(path) = &self.load_map {
            let map = map_file::load(path)?;
            let slam =
                Slam::with_map(config, &map).with_context(|| format!("map {}", path.display()))?;
            (slam, None)
        } else {
            (Slam::new(config).context("building the filter")?, None)
        };
        if self.localise_only {
            slam.fix_map()?;
        }
        let feed = checkpoint.as_ref().map(|c| c.smoother_feed.clone());
        slam.start_smoother(config, feed.unwrap_or_default())?;
        Ok((slam, checkpoint))
    }

    /// True when a checkpoint is due after observation step `steps`.
    pub fn checkpoint_due(&self, steps: u64) -> bool {
        self.checkpoint.is_some() && steps.is_multiple_of(self.checkpoint_every)
    }

    /// Writes the checkpoint `make` builds, if checkpoints are configured.
    ///
    /// # Errors
    /// When the file cannot be written (the previous checkpoint is then intact).
    pub fn write_checkpoint(&self, make: impl FnOnce() -> Checkpoint) -> anyhow::Result<()> {
        if let Some(path) = &self.checkpoint {
            make().write(path)?;
            tracing::debug!(path = %path.display(), "checkpoint written");
        }
        Ok(())
    }

    /// Saves the best particle's map, if `--save-map` was given.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn save_map(&self, slam: &Slam) -> anyhow::Result<()> {
        if let Some(path) = &self.save_map {
            let (_, map) = slam.map(Header::default());
            map_file::save(path, &map)?;
            tracing::info!(path = %path.display(), landmarks = map.len(), "map saved");
        }
        Ok(())
    }
}
