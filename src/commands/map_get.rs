//! `fastslam-stack map-get`: asks a running FastSLAM service for its current map (the
//! `map/get` request–response service) and writes it as a saved-map CSV.

use anyhow::bail;
use fastslam_protocol::ipc::{self, Ipc, IpcError};
use fastslam_protocol::{LandmarkMapHeader, MapLandmark, MapRequest, cli, topics};
use fastslam_service::map_file;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Flags of `map-get`.
#[derive(Debug, Clone, clap::Args)]
pub struct MapGetArgs {
    /// The stack whose service to ask.
    #[command(flatten)]
    pub stack: cli::StackArgs,
    /// Where to write the map (CSV, the format of the service's `--save-map`, which
    /// `--load-map` reads).
    #[arg(long)]
    pub out: PathBuf,
    /// Give up when no service answers within this many seconds.
    #[arg(long, default_value_t = 10.0)]
    pub timeout_s: f64,
}

/// Requests the map, writes it to `--out` and prints how many landmarks it has.
///
/// # Errors
/// When no service answers in time, or the file cannot be written.
pub fn run(args: &MapGetArgs) -> anyhow::Result<()> {
    let stack = args.stack.stack();
    let timeout = Duration::from_secs_f64(args.timeout_s.max(0.0));
    // Asking a stack that does not exist creates its first shared-memory files: they are
    // removed again when nothing answers.
    let root = stack.root.as_deref().map(Path::new);
    let no_stack_yet =
        ipc::shared_memory_files(&stack.prefix).is_empty() && root.is_none_or(|r| !r.exists());
    let ipc = Ipc::open(&stack, "map-get", timeout)?;
    let request = ipc.request_slice::<MapRequest, LandmarkMapHeader, MapLandmark>(
        &topics::MAP_GET,
        MapRequest::default(),
    );
    let (header, map) = match request {
        Err(IpcError::Timeout { .. }) => {
            drop(ipc);
            if no_stack_yet {
                ipc::remove_stack_files(&stack.prefix, root);
            }
            bail!(
                "no FastSLAM service answered on {} within {} s (is the stack `{}` running?)",
                topics::service_name(&stack.prefix, topics::MAP_GET.name),
                args.timeout_s,
                stack.prefix
            )
        }
        other => other?,
    };
    map_file::save(&args.out, &map)?;
    println!(
        "{} landmarks (estimate at {:.3} s) written to {}",
        map.len(),
        header.header.stamp_ns as f64 * 1e-9,
        args.out.display()
    );
    Ok(())
}
