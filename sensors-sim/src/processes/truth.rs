//! Drives the simulated vehicle through the scenario and publishes ground truth and the
//! true landmark map; ends with an end-of-stream message.

use crate::args::SimArgs;
use crate::ground_truth::{GroundTruthSource, true_map};
use fastslam_protocol::cli::PaceArgs;
use fastslam_protocol::ipc::{Ipc, IpcError, shutdown};
use fastslam_protocol::{
    EndOfStream, GroundTruth, Header, LandmarkMapHeader, MapLandmark, StreamId, topics,
};
use std::time::{Duration, Instant};

/// What `--help` says about this process.
pub const ABOUT: &str = "Simulated world: drives the vehicle along the scenario's route and publishes \
ground truth and the true landmark map, then an end-of-stream message.";

/// The true map is sent again every this many ground-truth samples (and before the end),
/// so a subscriber that joined late still gets it.
const TRUE_MAP_EVERY: u64 = 400;

/// Flags of the truth simulator.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack, scenario, seed and start-up flags.
    #[command(flatten)]
    pub sim: SimArgs,
    /// Real time or as fast as possible.
    #[command(flatten)]
    pub pace: PaceArgs,
}

/// Runs the process until the route is finished (or a signal arrives).
///
/// # Errors
/// Scenario, IPC or timeout errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let (scenario, _) = args.sim.scenario()?;
    let ipc = Ipc::open(
        &args.sim.stack.stack(),
        "truth-sim",
        args.sim.wait_timeout(),
    )?;
    // As fast as possible, several samples share a wake-up of the sensors and the client.
    let truth = ipc
        .publisher::<GroundTruth>(&topics::GROUND_TRUTH)?
        .coalescing()
        .kept_for_client(&ipc)?;
    let landmarks = (ipc
        .slice_publisher::<LandmarkMapHeader, MapLandmark>(&topics::TRUE_LANDMARKS)?)
    .kept_for_client(&ipc)?;
    let eos = (ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?).kept_for_client(&ipc)?;
    truth.wait_for_subscribers(&ipc, args.sim.wait_subscribers)?;

    let map = true_map(&scenario);
    let send_map = |header: Header| {
        landmarks.send(
            LandmarkMapHeader {
                header,
                count: map.len() as u32,
                reserved: 0,
            },
            &map,
        )
    };

    let start = Instant::now();
    tracing::info!(scenario = %scenario.name, realtime = args.pace.realtime, rate = args.pace.rate, "driving");
    let mut last = Header::default();
    for sample in GroundTruthSource::new(&scenario) {
        let header = sample.header;
        if header.seq % TRUE_MAP_EVERY == 0 {
            send_map(Header {
                stamp_ns: header.stamp_ns,
                seq: header.seq / TRUE_MAP_EVERY,
            })?;
        }
        truth.send(sample)?;
        last = header;
        if args.pace.realtime {
            truth.flush()?;
            let due = Duration::from_secs_f64(header.stamp_s() / args.pace.rate);
            ipc.sleep(due.saturating_sub(start.elapsed()))?;
        } else if shutdown::requested() {
            return Err(IpcError::Shutdown.into());
        }
    }
    truth.flush()?;
    send_map(Header {
        stamp_ns: last.stamp_ns,
        seq: last.seq / TRUE_MAP_EVERY + 1,
    })?;
    eos.send(EndOfStream::new(StreamId::GroundTruth, Some(last)))?;
    tracing::info!(
        samples = last.seq + 1,
        simulated_s = last.stamp_s(),
        "route finished"
    );
    landmarks.wait_until_unsubscribed(&ipc)?;
    Ok(())
}
