//! The live viewer: joins a running stack as a subscriber, like the client, and serves
//! the run over Foxglove's WebSocket protocol (subprotocol `foxglove.sdk.v1`) through the run's
//! channels ([`RunLog`]: the topics and schemas of `run.mcap`, plus `/trajectory`, the
//! estimated trajectory so far). Open Foxglove and connect to `ws://localhost:8765`.
//!
//! It must keep no publisher waiting: a publisher waits while a subscriber's buffer is full,
//! so the viewer takes every pending sample on every wake-up and keeps only the newest of
//! each topic (copying it aside, never holding shared memory); every [`PUBLISH_EVERY`]
//! it logs what is new, and every [`RESEND_EVERY`] it logs the maps, the grid and the
//! trajectory again, for a Foxglove that connects late. Encoding and sending happen only
//! for topics a Foxglove client subscribed to, and the server drops its oldest queued
//! messages rather than block. It exits once every stream of the stack has ended.

use crate::foxglove_log::RunLog;
use crate::inputs::{Ends, Inputs, Opening, TRUTH_WAIT_S, TruthWait};
use fastslam_protocol::ipc::{Flow, Ipc};
use fastslam_protocol::message::Message;
use fastslam_protocol::topics::{self, Topic};
use fastslam_protocol::{
    GroundTruth, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation, ObservationsHeader,
    OccupancyGridHeader, Odometry, Particle, ParticlesHeader, PoseEstimate, TrajectoryHeader,
    TrajectoryPose, cli,
};
use foxglove::{Context, WebSocketServer};
use std::time::{Duration, Instant};

/// What `--help` says about this process.
pub const ABOUT: &str = "Live viewer: joins a running stack and serves it to Foxglove over \
WebSocket (connect Foxglove to ws://localhost:8765): the pose with its covariance, the truth \
and dead reckoning, the trajectory so far, the landmark map with 2σ ellipses, the scans or \
observations, the occupancy grid and, when the service sends it, the particle cloud. It keeps only \
the newest of each topic and keeps no publisher waiting.";

/// The WebSocket port Foxglove connects to by default.
pub const DEFAULT_PORT: u16 = 8765;

/// How often the viewer logs what is new.
pub const PUBLISH_EVERY: Duration = Duration::from_millis(50);
/// How often the viewer logs the maps, the grid and the trajectory again.
pub const RESEND_EVERY: Duration = Duration::from_millis(500);

/// Flags of the viewer.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack to join.
    #[command(flatten)]
    pub stack: cli::StackArgs,
    /// Port of the WebSocket server (0: any free port, named in the log).
    #[arg(long, default_value_t = DEFAULT_PORT)]
    pub port: u16,
    /// Address the WebSocket server listens on.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Give up waiting for the stack's publishers after this many seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
}

/// Serves the stack until every stream has ended (or a signal arrives).
///
/// # Errors
/// A port that cannot be bound, or IPC failures.
pub fn run(args: Args) -> anyhow::Result<()> {
    let context = Context::new();
    // Every channel exists before a client can connect, so a client gets them all in one
    // advertisement: a subscription sent back to a channel advertised on its own can race
    // the server's record of that advertisement and be refused as an unknown channel.
    let mut log = RunLog::new(&context);
    let server = WebSocketServer::new()
        .name("fastslam")
        .context(&context)
        .bind(&args.host, args.port)
        .start_blocking()?;
    tracing::info!(
        url = %format!("ws://{}:{}", args.host, server.port()),
        "live view: connect Foxglove to it"
    );
    let ipc = Ipc::open(
        &args.stack.stack(),
        "viewer",
        Duration::from_secs_f64(args.wait_timeout_s.max(0.0)),
    )?;
    let truth = TruthWait::Within(Duration::from_secs_f64(TRUTH_WAIT_S));
    let opening = Opening::Wait {
        truth,
        resend: false,
    };
    let inputs = Inputs::open(&ipc, opening)?;
    let mut newest = Newest::default();
    let mut ends = inputs.ends();
    let mut published = Instant::now();
    let mut resent = Instant::now();
    ipc.wake_loop::<anyhow::Error>(&inputs.sources(), Some(PUBLISH_EVERY), || {
        newest.drain(&inputs, &mut ends)?;
        if published.elapsed() >= PUBLISH_EVERY {
            published = Instant::now();
            let again = resent.elapsed() >= RESEND_EVERY;
            if again {
                resent = published;
            }
            newest.log(&mut log, again);
        }
        Ok(if ends.finished() {
            Flow::Stop
        } else {
            Flow::Continue
        })
    })?;
    newest.log(&mut log, true);
    server.stop().wait_blocking();
    Ok(())
}

/// The newest message of one topic, copied out of shared memory, and whether it was
/// logged since.
struct Latest<T> {
    value: Option<T>,
    fresh: bool,
}

impl<T> Default for Latest<T> {
    fn default() -> Self {
        Self {
            value: None,
            fresh: false,
        }
    }
}

impl<T> Latest<T> {
    /// Replaces the value.
    fn keep(&mut self, value: T) {
        self.value = Some(value);
        self.fresh = true;
    }

    /// The value when it was not logged yet, or in any case when `again`; it then counts
    /// as logged.
    fn take(&mut self, again: bool) -> Option<&T> {
        let due = std::mem::take(&mut self.fresh) || again;
        self.value.as_ref().filter(|_| due)
    }
}

impl<H: Copy, T: Copy> Latest<(H, Vec<T>)> {
    /// Replaces the value by a header and a copy of `items`, reusing the last one's
    /// memory.
    fn keep_slice(&mut self, header: H, items: &[T]) {
        let (h, v) = self.value.get_or_insert_with(|| (header, Vec::new()));
        *h = header;
        v.clear();
        v.extend_from_slice(items);
        self.fresh = true;
    }
}

/// The newest of every topic, and the estimated trajectory so far.
#[derive(Default)]
struct Newest {
    pose: Latest<PoseEstimate>,
    trajectory: Latest<Vec<PoseEstimate>>,
    truth: Latest<GroundTruth>,
    odometry: Latest<Odometry>,
    scan: Latest<(LaserScanHeader, Vec<f32>)>,
    observations: Latest<(ObservationsHeader, Vec<Observation>)>,
    map: Latest<(LandmarkMapHeader, Vec<MapLandmark>)>,
    true_map: Latest<(LandmarkMapHeader, Vec<MapLandmark>)>,
    grid: Latest<(OccupancyGridHeader, Vec<i8>)>,
    smoothed: Latest<(TrajectoryHeader, Vec<TrajectoryPose>)>,
    smoothed_map: Latest<(LandmarkMapHeader, Vec<MapLandmark>)>,
    particles: Latest<(ParticlesHeader, Vec<Particle>)>,
}

impl Newest {
    /// Takes every pending sample of every topic, keeping the newest valid one of each
    /// and noting each stream's progress in `ends`.
    fn drain(&mut self, inputs: &Inputs, ends: &mut Ends) -> anyhow::Result<()> {
        inputs.drain(|row, message, checked| {
            ends.note(row, message);
            if checked.is_ok() {
                self.keep(row.topic, message);
            }
        })
    }

    /// Keeps a valid message of `topic` as the newest of its topic (a pose also extends
    /// the trajectory); the status and end of stream only count for the streams' ends.
    fn keep(&mut self, topic: Topic, message: Message<'_>) {
        match (topic, message) {
            (topics::GROUND_TRUTH, Message::GroundTruth(m)) => self.truth.keep(*m),
            (topics::ODOMETRY, Message::Odometry(m)) => self.odometry.keep(*m),
            (topics::SCAN, Message::Scan(h, d)) => self.scan.keep_slice(*h, d),
            (topics::OBSERVATIONS, Message::Observations(h, o)) => {
                self.observations.keep_slice(*h, o);
            }
            (topics::POSE, Message::Pose(m)) => {
                self.pose.keep(*m);
                let trajectory = self.trajectory.value.get_or_insert_with(Vec::new);
                trajectory.push(*m);
                self.trajectory.fresh = true;
            }
            (topics::MAP, Message::LandmarkMap(h, l)) => self.map.keep_slice(*h, l),
            (topics::SMOOTHED_MAP, Message::LandmarkMap(h, l)) => {
                self.smoothed_map.keep_slice(*h, l);
            }
            (topics::TRUE_LANDMARKS, Message::LandmarkMap(h, l)) => {
                self.true_map.keep_slice(*h, l);
            }
            (topics::GRID, Message::Grid(h, c)) => self.grid.keep_slice(*h, c),
            (topics::SMOOTHED_TRAJECTORY, Message::Trajectory(h, p)) => {
                self.smoothed.keep_slice(*h, p);
            }
            (topics::PARTICLES, Message::Particles(h, p)) => self.particles.keep_slice(*h, p),
            _ => {}
        }
    }

    /// Logs what is new; with `again`, also the maps, the grid and the trajectory as
    /// they stand.
    fn log(&mut self, log: &mut RunLog, again: bool) {
        if let Some(m) = self.truth.take(false) {
            log.truth(m);
        }
        if let Some(m) = self.odometry.take(false) {
            log.dead_reckoning(m);
        }
        if let Some((h, d)) = self.scan.take(false) {
            log.scan(h, d);
        }
        if let Some((h, o)) = self.observations.take(false) {
            log.observations(h, o);
        }
        if let Some(m) = self.pose.take(false) {
            log.pose(m);
        }
        if let Some((h, p)) = self.particles.take(false) {
            log.particles(h, p);
        }
        if again && let Some(poses) = self.trajectory.take(false) {
            log.trajectory(poses);
        }
        if let Some((h, l)) = self.true_map.take(again) {
            log.true_map(h, l);
        }
        if let Some((h, l)) = self.map.take(again) {
            log.map(h, l);
        }
        if let Some((h, c)) = self.grid.take(again) {
            log.grid(h, c);
        }
        if let Some((h, p)) = self.smoothed.take(again) {
            log.smoothed(h, p);
        }
        if let Some((h, l)) = self.smoothed_map.take(again) {
            log.smoothed_map(h, l);
        }
    }
}
