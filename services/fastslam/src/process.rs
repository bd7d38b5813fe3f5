//! The service process: odometry and the lidar (landmark observations or raw scans) in;
//! pose estimates, landmark maps, occupancy grids and status out.

use crate::admit::Admission;
use crate::checkpoint::{Checkpoint, ResumeFloor};
use crate::config::{EstimatorChoice, LidarInput, Overrides, ServiceConfig};
use crate::deadline::{Change, Watchdog};
use crate::health::Health;
use crate::per_input::Stream;
use crate::persist::PersistArgs;
use crate::sequencer::{Input, Pushed, RawScan, Scan, ScanPlace, Sequencer};
use crate::slam::{PoseSink, Slam, Step};
use fastslam_protocol::ipc::{Flow, HoldingSub, Ipc, Pub, SliceServer, Taken, WakeSource};
use fastslam_protocol::status::{RejectionKind, ServiceStatus};
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::validate::{self, Rejection};
use fastslam_protocol::{
    EndOfStream, Header, LandmarkMapHeader, LaserScanHeader, MapLandmark, MapRequest, Observation,
    ObservationsHeader, OccupancyGridHeader, Odometry, PoseEstimate, StreamId, cli, topics,
};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// What `--help` says about this process.
pub const ABOUT: &str = "FastSLAM service: subscribes to odometry and to landmark observations or \
raw lidar scans (poles are extracted from them), runs FastSLAM in stamp order, and publishes the \
pose estimate after every observation, the best particle's landmark map and occupancy grid, and \
the filter's status.";

/// Flags of the service (they override the config file).
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack to join.
    #[command(flatten)]
    pub stack: cli::StackArgs,
    /// Config file (TOML): `[filter]`, `[optimizer]`, `[moves]`, `[output]`. Default: built-in
    /// defaults.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Number of particles.
    #[arg(long)]
    pub particles: Option<usize>,
    /// Seed of the filter's random draws.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Optimiser, proposal and move correction.
    #[command(flatten)]
    pub choice: EstimatorChoice,
    /// Lidar input: auto (whichever of `scan` and `observations` is published), scan or
    /// observations.
    #[arg(long, value_enum)]
    pub lidar: Option<LidarInput>,
    /// Wait for this many subscribers of the pose before starting, so a client that
    /// starts late loses nothing.
    #[arg(long, default_value_t = 0)]
    pub wait_subscribers: usize,
    /// Give up waiting for publishers of the inputs, or for subscribers, after this many
    /// seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
    /// How to wait for the inputs.
    #[command(flatten)]
    pub wait: cli::WaitArgs,
    /// Checkpoints and saved maps.
    #[command(flatten)]
    pub persist: PersistArgs,
}

impl Args {
    /// The configuration: file (or defaults), then flags on top, validated.
    ///
    /// # Errors
    /// When the file cannot be read or a value is invalid.
    pub fn config(&self) -> anyhow::Result<ServiceConfig> {
        let mut config =
            ServiceConfig::load(self.config.as_deref())?.with_overrides(&self.overrides())?;
        if let Some(lidar) = self.lidar {
            config.input.lidar = lidar;
        }
        Ok(config)
    }

    /// The flags that replace values of the config file.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            particles: self.particles,
            seed: self.seed,
            choice: self.choice.clone(),
        }
    }
}

/// The service's output ports (and the `map/get` server) and the last header sent on each.
struct Outputs {
    pose: Pub<PoseEstimate, ()>,
    map_get: SliceServer<MapRequest, LandmarkMapHeader, MapLandmark>,
    map: Pub<[MapLandmark], LandmarkMapHeader>,
    grid: Pub<[i8], OccupancyGridHeader>,
    status: Pub<ServiceStatus, ()>,
    eos: Pub<EndOfStream, ()>,
    last_pose: Option<Header>,
    last_map: Option<Header>,
    last_grid: Option<Header>,
    last_status: Option<Header>,
}

/// Next header of a stream whose last header was `last`.
fn next_header(last: Option<Header>, stamp_ns: u64) -> Header {
    Header {
        stamp_ns,
        seq: last.map_or(0, |h| h.seq + 1),
    }
}

impl Outputs {
    fn open(ipc: &Ipc) -> anyhow::Result<Self> {
        Ok(Self {
            // As fast as possible, the pose and status of several steps share a wake-up.
            pose: ipc.publisher(&topics::POSE)?.coalescing(),
            map_get: ipc.slice_server(&topics::MAP_GET)?,
            map: ipc.slice_publisher(&topics::MAP)?,
            grid: ipc.slice_publisher(&topics::GRID)?,
            status: ipc.publisher(&topics::STATUS)?.coalescing(),
            eos: ipc.publisher(&topics::END_OF_STREAM)?,
            last_pose: None,
            last_map: None,
            last_grid: None,
            last_status: None,
        })
    }

    /// Continues the sequence numbers of the run a checkpoint was taken from.
    fn resume(&mut self, checkpoint: &Checkpoint) {
        let header = |seq: Option<u64>| seq.map(|seq| Header { stamp_ns: 0, seq });
        let [pose, map, grid, status] = checkpoint.last_seq;
        self.last_pose = header(pose);
        self.last_map = header(map);
        self.last_grid = header(grid);
        self.last_status = header(status);
    }

    /// Sequence numbers last published: pose, map, grid, status.
    fn last_seq(&self) -> [Option<u64>; 4] {
        [
            self.last_pose,
            self.last_map,
            self.last_grid,
            self.last_status,
        ]
        .map(|h| h.map(|h| h.seq))
    }

    fn pose(&mut self, mut pose: PoseEstimate) -> anyhow::Result<()> {
        pose.header = next_header(self.last_pose, pose.header.stamp_ns);
        self.pose.send(pose)?;
        self.last_pose = Some(pose.header);
        Ok(())
    }

    fn map(&mut self, slam: &Slam, stamp_ns: u64) -> anyhow::Result<()> {
        let header = next_header(self.last_map, stamp_ns);
        let (h, map) = slam.map(header);
        self.map.send(h, &map)?;
        self.last_map = Some(header);
        Ok(())
    }

    /// Answers pending `map/get` requests with the best particle's map now, under the
    /// header of the last pose published (the estimate the map belongs to).
    fn answer_map_requests(&self, slam: &Slam) -> anyhow::Result<()> {
        let header = self.last_pose.unwrap_or_default();
        let answered = self.map_get.answer(|_| slam.map(header))?;
        if answered > 0 {
            tracing::debug!(answered, "map requests answered");
        }
        Ok(())
    }

    /// Publishes the best particle's grid, if raw scans have given one.
    fn grid(&mut self, slam: &mut Slam, stamp_ns: u64) -> anyhow::Result<()> {
        let header = next_header(self.last_grid, stamp_ns);
        let Some((h, cells)) = slam.grid(header) else {
            return Ok(());
        };
        if let Err(reason) = validate::occupancy_grid(&h, &cells) {
            tracing::warn!(%reason, "occupancy grid not published");
            return Ok(());
        }
        self.grid.send(h, &cells)?;
        self.last_grid = Some(header);
        Ok(())
    }

    fn status(&mut self, mut status: ServiceStatus) -> anyhow::Result<()> {
        status.header = next_header(self.last_status, status.header.stamp_ns);
        self.status.send(status)?;
        self.last_status = Some(status.header);
        Ok(())
    }

    /// Wakes the subscribers of poses and status sent without a wake-up of their own:
    /// before the service sleeps, and at the end.
    fn flush(&self) -> anyhow::Result<()> {
        self.pose.flush()?;
        self.status.flush()?;
        Ok(())
    }

    fn finish(&self, ipc: &Ipc) -> anyhow::Result<()> {
        self.flush()?;
        for (stream, last) in [
            (StreamId::Pose, self.last_pose),
            (StreamId::Map, self.last_map),
            (StreamId::Grid, self.last_grid),
            (StreamId::Status, self.last_status),
        ] {
            self.eos.send(EndOfStream::new(stream, last))?;
        }
        // The map and grid live in growable segments: stay until their readers have them.
        self.map.wait_until_unsubscribed(ipc)?;
        self.grid.wait_until_unsubscribed(ipc)?;
        Ok(())
    }
}

/// The lidar topic the service listens to: landmark observations or raw scans. A scan
/// that arrives before the odometry up to its stamp is held back in shared memory until
/// that odometry is in ([`HoldingSub`]), so it too reaches the filter without a copy.
enum Lidar {
    Observations(HoldingSub<[Observation], ObservationsHeader>),
    Scans(HoldingSub<[f32], LaserScanHeader>),
}

impl Lidar {
    /// Subscribes to the configured lidar topic; `auto` waits until one of the two has a
    /// publisher (and takes `scan` if both have).
    fn open(ipc: &Ipc, choice: LidarInput) -> anyhow::Result<Self> {
        let choice = match choice {
            LidarInput::Auto => {
                let scans = ipc.publisher_probe::<[f32], LaserScanHeader>(&topics::SCAN)?;
                let observations = ipc
                    .publisher_probe::<[Observation], ObservationsHeader>(&topics::OBSERVATIONS)?;
                ipc.wait_until(
                    || "a publisher on scan or observations".into(),
                    || scans() + observations() > 0,
                )?;
                if scans() > 0 {
                    LidarInput::Scan
                } else {
                    LidarInput::Observations
                }
            }
            chosen => chosen,
        };
        Ok(match choice {
            LidarInput::Scan => Self::Scans(ipc.slice_subscriber(&topics::SCAN)?.holding()),
            LidarInput::Auto | LidarInput::Observations => {
                Self::Observations(ipc.slice_subscriber(&topics::OBSERVATIONS)?.holding())
            }
        })
    }

    /// The stream whose end-of-stream closes the lidar input.
    fn stream(&self) -> StreamId {
        match self {
            Self::Observations(_) => StreamId::Observations,
            Self::Scans(_) => StreamId::Scan,
        }
    }

    /// True while a scan is held back.
    fn holds(&self) -> bool {
        match self {
            Self::Observations(sub) => sub.holds(),
            Self::Scans(sub) => sub.holds(),
        }
    }

    /// The subscriber, for the wake loop.
    fn wake_source(&self) -> &dyn WakeSource {
        match self {
            Self::Observations(sub) => sub,
            Self::Scans(sub) => sub,
        }
    }
}

/// The longest a scan is held back in shared memory waiting for odometry, as a share of
/// the sensors' deadline; then it is queued (a copy). A publisher that sends both streams
/// from one thread could otherwise wait on a full lidar buffer, with the odometry the
/// held scan needs still unsent. Well inside the deadline, so that holding never makes
/// the lidar look quiet.
const HOLD_SHARE_OF_DEADLINE: u32 = 4;

/// The service's state between wake-ups: the filter, its counters, the input queue and
/// the output ports.
struct Core {
    slam: Slam,
    health: Health,
    sequencer: Sequencer,
    out: Outputs,
    /// Scans applied straight from shared memory / all scans applied.
    direct_scans: u64,
    scans: u64,
}

impl Core {
    /// The checkpoint of the state now.
    fn checkpoint(&self, seed: u64) -> Checkpoint {
        Checkpoint {
            seed,
            filter: self.slam.state(),
            last_odometry_ns: self.slam.last_odometry_ns(),
            processed_ns: self.sequencer.released(),
            steps: self.health.steps(),
            resamplings: self.health.resamplings(),
            last_seq: self.out.last_seq(),
        }
    }

    /// Applies every input the sequencer can release now, in stamp order.
    fn release_queued(
        &mut self,
        config: &ServiceConfig,
        persist: &PersistArgs,
    ) -> anyhow::Result<()> {
        while let Some(input) = self.sequencer.release() {
            self.scans += u64::from(!matches!(input, Input::Odometry(_)));
            let stepped = self.step(|slam, publish| slam.apply(&input, publish), config, persist);
            self.sequencer.recycle(input);
            stepped?;
        }
        Ok(())
    }

    /// Applies a scan stamped `stamp` that the sequencer would release next
    /// ([`ScanPlace::Direct`]) straight from shared memory: first the odometry up
    /// to its stamp, then `step` on the sample's own slice (no copy).
    fn direct(
        &mut self,
        stamp: u64,
        step: impl FnOnce(&mut Slam, PoseSink<'_>) -> fastslam_estimation::Result<Step>,
        config: &ServiceConfig,
        persist: &PersistArgs,
    ) -> anyhow::Result<()> {
        while let Some(odometry) = self.sequencer.odometry_through(stamp) {
            self.step(
                |slam, publish| slam.apply(&odometry, publish),
                config,
                persist,
            )?;
        }
        self.sequencer.took_directly(stamp);
        self.direct_scans += 1;
        self.scans += 1;
        self.step(
            |slam, publish| step(slam, publish).map(Some),
            config,
            persist,
        )
    }

    /// Runs one filter input through `apply`, publishing its pose the moment the filter
    /// has it (before the maps are updated, about half-way through a scan's step), then
    /// the rest of what it produced ([`Core::after`]).
    fn step(
        &mut self,
        apply: impl FnOnce(&mut Slam, PoseSink<'_>) -> fastslam_estimation::Result<Option<Step>>,
        config: &ServiceConfig,
        persist: &PersistArgs,
    ) -> anyhow::Result<()> {
        let started = Instant::now();
        let out = &mut self.out;
        let mut sent = Ok(());
        let applied = apply(&mut self.slam, &mut |pose| sent = out.pose(pose));
        sent?;
        self.after(applied, started, config, persist)
    }

    /// Publishes what an applied input produced besides its pose (map and grid when due,
    /// status, checkpoint when due), or counts the filter's refusal.
    fn after(
        &mut self,
        applied: fastslam_estimation::Result<Option<Step>>,
        started: Instant,
        config: &ServiceConfig,
        persist: &PersistArgs,
    ) -> anyhow::Result<()> {
        match applied {
            Ok(Some(step)) => {
                let status =
                    self.health
                        .step(&step, started.elapsed(), &self.slam, &self.sequencer);
                let stamp_ns = step.pose.header.stamp_ns;
                let due = |every: u64| every > 0 && self.health.steps().is_multiple_of(every);
                if due(config.output.map_every) {
                    self.out.map(&self.slam, stamp_ns)?;
                }
                if due(config.output.grid_every) {
                    self.out.grid(&mut self.slam, stamp_ns)?;
                }
                self.out.status(status)?;
                if persist.checkpoint_due(self.health.steps()) {
                    let write = persist.write_checkpoint(|| self.checkpoint(config.filter.seed));
                    if let Err(e) = write {
                        tracing::warn!("{e:#}");
                    }
                }
            }
            Ok(None) => {}
            Err(e) => {
                let kind = RejectionKind::Filter;
                self.health.log.reject(Instant::now(), "input", 0, kind, &e);
            }
        }
        Ok(())
    }
}

/// Counts `pushed` if the sequencer dropped or refused an input.
fn queued(health: &mut Health, now: Instant, what: &str, seq: u64, pushed: Pushed) {
    match pushed {
        Pushed::Queued => {}
        Pushed::Overflowed => {
            let reason = "queue full: its oldest input was dropped";
            health
                .log
                .reject(now, what, seq, RejectionKind::Overflow, &reason);
        }
        Pushed::Late => {
            let reason = "older than inputs already processed";
            health
                .log
                .reject(now, what, seq, RejectionKind::Late, &reason);
        }
    }
}

/// Runs the service until both input streams have ended (or a signal arrives).
///
/// # Errors
/// Configuration or IPC errors, with their reason.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = args.config()?;
    let (slam, resumed) = args.persist.start(&config)?;
    let timeout = Duration::from_secs_f64(args.wait_timeout_s.max(0.0));
    let ipc = Ipc::open(&args.stack.stack(), "fastslam-service", timeout)?
        .busy_polling(args.wait.busy_poll)
        .spinning(args.wait.spin());
    // Publishers first, then subscribers (which wait for publishers): no wait cycles.
    let mut out = Outputs::open(&ipc)?;
    if let Some(checkpoint) = &resumed {
        out.resume(checkpoint);
    }
    // End-of-stream before the inputs: a sensor starts once its subscribers are there, and
    // a short stream may end before a later subscription exists.
    let eos_in = ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?;
    let odometry = ipc.subscriber::<Odometry>(&topics::ODOMETRY)?;
    let lidar = Lidar::open(&ipc, config.input.lidar)?;
    out.pose.wait_for_subscribers(&ipc, args.wait_subscribers)?;
    tracing::info!(
        particles = config.filter.particles, optimizer = %config.optimizer.kind,
        proposal = %config.filter.proposal, moves = %config.moves.correction,
        resampling = ?config.filter_config().resampling.scheme, seed = config.filter.seed,
        lidar = ?lidar.stream(), "running"
    );

    let input = &config.input;
    let sequencer = Sequencer::new(input.max_queue);
    let mut health = Health::new(Duration::from_secs_f64(input.log_interval_s));
    if let Some(c) = &resumed {
        health.resume(c.steps, c.resamplings);
    }
    let persist = &args.persist;
    let mut core = Core {
        slam,
        health,
        sequencer,
        out,
        direct_scans: 0,
        scans: 0,
    };
    let mut floor = ResumeFloor::of(resumed.as_ref());
    let max_jump_ns = (input.max_stamp_jump_s * 1e9) as u64;
    let mut admission = Admission::new(max_jump_ns, input.motion_limits());
    let deadline = Duration::from_secs_f64(input.deadline_s);
    let (mut odo_watch, mut lidar_watch) = (Watchdog::new(deadline), Watchdog::new(deadline));
    let (mut odo_end, mut scan_end) = (StreamEnd::default(), StreamEnd::default());
    let hold_limit = deadline / HOLD_SHARE_OF_DEADLINE;
    // The tick: a held scan's limit is checked in time even with no input waking the loop.
    let sources: [&dyn WakeSource; 3] = [&odometry, lidar.wake_source(), &eos_in];
    ipc.wake_loop::<anyhow::Error>(&sources, Some(hold_limit), || {
        let now = Instant::now();
        let (mut odo_heard, mut lidar_heard) = (None, None);
        // A scan taken straight from shared memory is applied while draining; an IPC
        // error on its outputs waits here until the drain is over.
        let mut failed: Option<anyhow::Error> = None;
        core.out.answer_map_requests(&core.slam)?;
        odometry.drain(|s| {
            let m = *s.payload();
            odo_end.saw(m.header.seq);
            if !floor.admits(Stream::Odometry, m.header.stamp_ns) {
                return;
            }
            match admission.odometry(&m) {
                Ok(()) => {
                    odo_heard = odo_watch.heard(now).or(odo_heard);
                    let pushed = core.sequencer.push_odometry(m);
                    queued(&mut core.health, now, "odometry", m.header.seq, pushed);
                }
                Err(r) => {
                    core.health
                        .log
                        .reject(now, "odometry", m.header.seq, r.kind(), &r);
                }
            };
        })?;
        // Before the lidar: a scan held for odometry goes once the odometry has ended.
        eos_in.drain(|s| match StreamId::from_u32(s.payload().stream) {
            Some(StreamId::Odometry) => odo_end.announce(s.payload()),
            Some(id) if id == lidar.stream() => scan_end.announce(s.payload()),
            _ => {}
        })?;
        if odo_end.finished() {
            core.sequencer.end_odometry();
        }
        // One lidar message with header `h`: when new (`held_since` is `None`), skipped if
        // the checkpoint already covers it, else admitted after the content check
        // `check`. Then applied straight from shared memory (`direct`), held there while
        // it waits for odometry (up to `hold_limit`), or copied into the queue (`queue`).
        let mut on_lidar =
            |h: Header,
             what: &str,
             held_since: Option<Instant>,
             check: &dyn Fn() -> Result<(), Rejection>,
             direct: &mut dyn FnMut(
                &mut Slam,
                PoseSink<'_>,
            ) -> fastslam_estimation::Result<Step>,
             queue: &mut dyn FnMut(&mut Sequencer) -> Pushed| {
                if held_since.is_none() {
                    scan_end.saw(h.seq);
                    if !floor.admits(Stream::Lidar, h.stamp_ns) {
                        return Taken::Done;
                    }
                    if let Err(r) = admission.lidar(check(), h) {
                        core.health.log.reject(now, what, h.seq, r.kind(), &r);
                        return Taken::Done;
                    }
                    lidar_heard = lidar_watch.heard(now).or(lidar_heard);
                }
                let held_for =
                    held_since.map_or(Duration::ZERO, |t| now.saturating_duration_since(t));
                match core.sequencer.place_scan(h.stamp_ns) {
                    ScanPlace::Direct => {
                        let applied = core.direct(h.stamp_ns, direct, &config, persist);
                        failed = failed.take().or(applied.err());
                    }
                    ScanPlace::AwaitOdometry if held_for < hold_limit => return Taken::Hold,
                    ScanPlace::AwaitOdometry | ScanPlace::Queue => {
                        let pushed = queue(&mut core.sequencer);
                        queued(&mut core.health, now, what, h.seq, pushed);
                    }
                }
                Taken::Done
            };
        match &lidar {
            Lidar::Observations(sub) => sub.drain(|s, held_since| {
                let header = *s.user_header();
                on_lidar(
                    header.header,
                    "observations",
                    held_since,
                    &|| validate::observations(&header, s.payload()),
                    &mut |slam, publish| slam.observe(&header, s.payload(), publish),
                    &mut |sequencer| {
                        let observations = sequencer.copy_observations(s.payload());
                        sequencer.push_scan(Scan {
                            header,
                            observations,
                        })
                    },
                )
            })?,
            Lidar::Scans(sub) => sub.drain(|s, held_since| {
                let header = *s.user_header();
                let ranges = header.ranges_of(s.payload());
                on_lidar(
                    header.header,
                    "scan",
                    held_since,
                    &|| validate::laser_scan(&header, s.payload()),
                    &mut |slam, publish| slam.observe_raw(&header, ranges, publish),
                    &mut |sequencer| {
                        let ranges = sequencer.copy_ranges(ranges);
                        sequencer.push_raw_scan(RawScan { header, ranges })
                    },
                )
            })?,
        };
        if let Some(e) = failed.take() {
            return Err(e);
        }
        if scan_end.finished() {
            core.sequencer.end_scans();
        }
        // Sensor deadlines: a quiet stream is not waited for; its return ends that.
        let odo_change = odo_heard.or_else(|| odo_watch.check(now));
        let lidar_change = lidar_heard.or_else(|| lidar_watch.check(now));
        for (stream, change) in [
            (Stream::Odometry, odo_change),
            (Stream::Lidar, lidar_change),
        ] {
            let Some(change) = change else { continue };
            let quiet = change == Change::WentQuiet;
            if quiet {
                tracing::warn!(
                    ?stream,
                    ?deadline,
                    "input quiet beyond its deadline: degraded"
                );
            } else {
                tracing::info!(?stream, "input back: recovered");
            }
            if quiet {
                admission.resync(stream);
            }
            core.sequencer.set_quiet(stream, quiet);
            if stream == Stream::Odometry {
                core.slam.set_coasting(quiet);
            }
            core.out.status(core.health.now(&core.sequencer))?;
        }
        core.health.log.flush(now);
        core.release_queued(&config, persist)?;
        core.out.flush()?;
        Ok(if core.sequencer.finished() && !lidar.holds() {
            Flow::Stop
        } else {
            Flow::Continue
        })
    })?;

    // Stopped by a signal or finished: the state goes to disk before anyone is told.
    persist.write_checkpoint(|| core.checkpoint(config.filter.seed))?;
    persist.save_map(&core.slam)?;
    let last_ns = core.out.last_pose.map_or(0, |h| h.stamp_ns);
    core.out.map(&core.slam, last_ns)?;
    core.out.grid(&mut core.slam, last_ns)?;
    core.out
        .status(core.health.final_status(&core.slam, &core.sequencer))?;
    core.out.finish(&ipc)?;
    let moves = core.slam.move_stats().unwrap_or_default();
    tracing::info!(
        steps = core.health.steps(),
        rejections = ?core.health.log.counts(),
        scans = core.scans,
        scans_from_shared_memory = core.direct_scans,
        moves_proposed = moves.proposed,
        moves_accepted = moves.accepted,
        skipped_before_checkpoint = floor.skipped(),
        "inputs finished"
    );
    Ok(())
}
