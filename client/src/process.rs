//! Records a run of the stack and writes its run folder when every stream has ended
//! (or, marked incomplete, on SIGINT/SIGTERM). While it records, it prints a progress
//! line on stdout a few times a second (see [`crate::progress`]).

use crate::expect::JudgeArgs;
use crate::inputs::{Ends, Inputs, LidarMessage, TRUTH_WAIT_S, TruthWait};
use crate::latency::LatencyMatcher;
use crate::mcap::RunMcap;
use crate::metrics::{AlignMode, ScoreAt, fit_alignment, interpolate, scored_at};
use crate::progress::{LiveAte, Progress};
use crate::reference::NoiseModel;
use crate::relations::{Relation, read_relations};
use crate::resources::ProcessMonitor;
use crate::{Metrics, Recording, report};
use fastslam_protocol::ipc::{Ended, Flow, Ipc};
use fastslam_protocol::stream::Repeats;
use fastslam_protocol::{StreamId, cli, validate};
use fastslam_service::config::ServiceConfig;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How often the client prints a progress line and samples the processes' CPU and memory.
const SAMPLE_EVERY: Duration = Duration::from_millis(200);

/// What `--help` says about this process.
pub const ABOUT: &str = "Metrics client: records ground truth (when the run has it), odometry, pose \
estimates, maps and the occupancy grid from the stack and, when every stream has ended, writes a \
run folder scored against ground truth and, with `--relations`, against a relations file; with \
`--expect`, it then judges the run.";

/// Flags of the client.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Stack to join.
    #[command(flatten)]
    pub stack: cli::StackArgs,
    /// Run folder to write (metrics.json, TUM trajectories, maps).
    #[arg(long, default_value = "runs/latest")]
    pub out: PathBuf,
    /// Give up waiting for the stack's publishers after this many seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
    /// How to wait for the stack's topics.
    #[command(flatten)]
    pub wait: cli::WaitArgs,
    /// The run has no ground truth: do not subscribe to `ground_truth` nor
    /// `truth/landmarks`; metrics.json then has only what needs no truth.
    #[arg(long)]
    pub no_truth: bool,
    /// Without `--no-truth`: when the `ground_truth` topic has no publisher once the other
    /// subscriptions are open, wait this many seconds for one, then record without ground
    /// truth (saying so in the log).
    #[arg(long, default_value_t = TRUTH_WAIT_S, value_name = "SECONDS")]
    pub truth_wait_s: f64,
    /// A relations file (`t1 t2 x y z roll pitch yaw` per line, times on the data set's
    /// clock): the estimate, the smoothed trajectory and dead reckoning are also scored by
    /// their relative motions against it (metrics.json `relations`). Read at start-up.
    #[arg(long, value_name = "FILE")]
    pub relations: Option<PathBuf>,
    /// The data set's epoch on the relations' clock (s): stamps on the wire are
    /// nanoseconds since it.
    #[arg(long, default_value_t = 0.0, value_name = "SECONDS")]
    pub relations_epoch_s: f64,
    /// Align the estimate with the truth before scoring: none (simulation: the map frame
    /// is the true frame) or se2 (external data: least-squares rigid alignment).
    #[arg(long, value_enum, default_value_t = AlignMode::None)]
    pub align: AlignMode,
    /// Compare with the truth at every pose estimate (estimates) or at every truth sample
    /// (truth: for sparse truth such as GPS fixes; the estimate is interpolated there).
    #[arg(long, value_enum, default_value_t = ScoreAt::Estimates)]
    pub score_at: ScoreAt,
    /// The service's config file (TOML). With it the client also solves the
    /// achievable-accuracy reference under the filter's own noise model, when the
    /// observations carry landmark ids (metrics.json `reference`); the launcher passes
    /// the file its service runs with.
    #[arg(long)]
    pub service_config: Option<PathBuf>,
    /// Expectations on the metrics and a JUnit report.
    #[command(flatten)]
    pub judge: JudgeArgs,
}

/// Records until every stream has ended (or a signal arrives), then writes the run folder.
///
/// # Errors
/// IPC failures or a run folder that cannot be written.
pub fn run(args: Args) -> anyhow::Result<()> {
    let expectations = args.judge.expectations()?;
    let relations = args.relations.as_deref().map(load_relations).transpose()?;
    let noise = (args.service_config.as_deref())
        .map(|path| {
            anyhow::Ok(NoiseModel::of(
                &ServiceConfig::load(Some(path))?.filter_config(),
            ))
        })
        .transpose()?;
    let ipc = Ipc::open(
        &args.stack.stack(),
        "client",
        Duration::from_secs_f64(args.wait_timeout_s.max(0.0)),
    )?
    .busy_polling(args.wait.busy_poll)
    .spinning(args.wait.spin());
    let truth_wait = if args.no_truth {
        TruthWait::Off
    } else {
        TruthWait::Within(Duration::from_secs_f64(args.truth_wait_s.max(0.0)))
    };
    let inputs = Inputs::open(&ipc, truth_wait)?;
    let Inputs {
        eos,
        true_map,
        map,
        grid,
        smoothed,
        smoothed_map,
        particles,
        status,
        lidar,
        truth,
        odometry,
        pose,
    } = &inputs;
    tracing::info!(lidar = ?lidar.stream(), ground_truth = truth.is_some(), "recording");

    std::fs::create_dir_all(&args.out)?;
    let mut mcap = RunMcap::create(&args.out.join(report::files::MCAP))?;
    let mut rec = Recording {
        without_truth: truth.is_none(),
        ..Recording::default()
    };
    let mut ends = Ends::new(lidar.stream(), truth.is_some());
    let mut seen = Repeats::default();
    let mut latency = LatencyMatcher::default();
    let mut monitor = ProcessMonitor::new();
    let mut live_ate = LiveAte::default();
    let mut last_sample = Instant::now();
    monitor.sample(&ipc);
    let ended = ipc.wake_loop::<anyhow::Error>(&inputs.sources(), Some(SAMPLE_EVERY), || {
        // Truth before poses, observations before poses: a pose's truth and observation
        // were published before it, so they are in by the time the pose is.
        if let Some(truth) = truth {
            truth.drain(|s| {
                ends.saw(StreamId::GroundTruth, s.header.seq);
                accept(validate::ground_truth(s.payload()), "ground truth", || {
                    rec.add_truth(s.payload());
                    mcap.truth(s.payload());
                });
            })?;
        }
        odometry.drain(|s| {
            if !seen.fresh(StreamId::Odometry, s.header) {
                return;
            }
            ends.saw(StreamId::Odometry, s.header.seq);
            accept(validate::odometry(s.payload()), "odometry", || {
                rec.add_odometry(s.payload());
                mcap.dead_reckoning(s.payload());
            });
        })?;
        lidar.drain(|header, message| {
            if !seen.fresh(lidar.stream(), header) {
                return;
            }
            ends.saw(lidar.stream(), header.seq);
            latency.observation(header.stamp_ns, Instant::now());
            match message {
                LidarMessage::Observations(h, o) => {
                    rec.add_observations(h, o);
                    mcap.observations(h, o);
                }
                LidarMessage::Scan(h, data) => mcap.scan(h, data),
                LidarMessage::Invalid => {}
            }
        })?;
        pose.drain(|s| {
            if !seen.fresh(StreamId::Pose, s.header) {
                return;
            }
            let stamp_ns = s.header.stamp_ns;
            latency.pose(stamp_ns, Instant::now());
            ends.saw(StreamId::Pose, s.header.seq);
            rec.add_estimate(s.payload());
            mcap.pose(s.payload());
            if let Some(t) = interpolate(&rec.truth, stamp_ns) {
                live_ate.add((s.x - t.x).hypot(s.y - t.y));
            }
        })?;
        status.drain(|s| {
            if !seen.fresh(StreamId::Status, s.header) {
                return;
            }
            ends.saw(StreamId::Status, s.header.seq);
            rec.add_status(s.payload());
        })?;
        map.drain(|s| {
            if !seen.fresh(StreamId::Map, s.user_header().header) {
                return;
            }
            ends.saw(StreamId::Map, s.user_header().header.seq);
            accept(
                validate::landmark_map(s.user_header(), s.payload()),
                "map",
                || {
                    rec.map = s.payload().to_vec();
                    mcap.map(s.user_header(), s.payload());
                },
            );
        })?;
        grid.drain(|s| {
            if !seen.fresh(StreamId::Grid, s.user_header().header) {
                return;
            }
            ends.saw(StreamId::Grid, s.user_header().header.seq);
            accept(
                validate::occupancy_grid(s.user_header(), s.payload()),
                "grid",
                || {
                    mcap.grid(s.user_header(), s.payload());
                    rec.grid = Some((*s.user_header(), s.payload().to_vec()));
                },
            );
        })?;
        smoothed.drain(|s| {
            if !seen.fresh(StreamId::SmoothedTrajectory, s.user_header().header) {
                return;
            }
            ends.saw(StreamId::SmoothedTrajectory, s.user_header().header.seq);
            accept(
                validate::trajectory(s.user_header(), s.payload()),
                "smoothed trajectory",
                || {
                    mcap.smoothed(s.user_header(), s.payload());
                    rec.set_smoothed(s.user_header(), s.payload());
                },
            );
        })?;
        smoothed_map.drain(|s| {
            if !seen.fresh(StreamId::SmoothedMap, s.user_header().header) {
                return;
            }
            ends.saw(StreamId::SmoothedMap, s.user_header().header.seq);
            accept(
                validate::landmark_map(s.user_header(), s.payload()),
                "smoothed map",
                || {
                    mcap.smoothed_map(s.user_header(), s.payload());
                    rec.smoothed_map = s.payload().to_vec();
                },
            );
        })?;
        particles.drain(|s| {
            if !seen.fresh(StreamId::Particles, s.user_header().header) {
                return;
            }
            ends.saw(StreamId::Particles, s.user_header().header.seq);
            accept(
                validate::particles(s.user_header(), s.payload()),
                "particle cloud",
                || mcap.particles(s.user_header(), s.payload()),
            );
        })?;
        if let Some(true_map) = true_map {
            true_map.drain(|s| {
                accept(
                    validate::landmark_map(s.user_header(), s.payload()),
                    "true map",
                    || {
                        rec.true_map = s.payload().to_vec();
                        mcap.true_map(s.user_header(), s.payload());
                    },
                );
            })?;
        }
        let mut announced = false;
        eos.drain(|s| announced |= ends.announce(s.payload()))?;
        // A publisher that announced its end has done its work: sample its CPU time now,
        // before it exits (see `resources`).
        if announced || last_sample.elapsed() >= SAMPLE_EVERY {
            last_sample = Instant::now();
            monitor.sample(&ipc);
            let p = Progress {
                sim_s: rec
                    .estimates
                    .last()
                    .map_or(0.0, |e| e.pose.stamp_ns as f64 * 1e-9),
                ate_m: live_ate.rmse(),
                poses: rec.estimates.len(),
            };
            print_progress(&p);
        }
        Ok(if ends.finished() {
            Flow::Stop
        } else {
            Flow::Continue
        })
    })?;
    monitor.sample(&ipc);
    rec.latencies = latency.latencies().to_vec();
    rec.streamed_s = latency.streamed_s();
    rec.processes = monitor.usage();

    let alignment = fit_alignment(&scored_at(&rec, args.score_at), args.align);
    let mut rec = alignment.apply(&rec);
    let mut metrics = Metrics::compute(&rec, ended == Ended::Done, alignment, args.score_at)
        .with_smoothed(&mut rec);
    if let Some(relations) = &relations {
        metrics = metrics.with_relations(&rec, relations, args.relations_epoch_s);
        if metrics.estimate.relations.is_none() && !rec.estimates.is_empty() {
            tracing::warn!(
                relations = relations.len(),
                epoch_s = args.relations_epoch_s,
                "no relation has estimates within 0.1 s of both its times: is \
                 --relations-epoch-s the data set's epoch?"
            );
        }
    }
    if let Some(noise) = &noise {
        metrics = metrics.with_reference(&mut rec, noise);
    }
    report::write(&args.out, &rec, &metrics)?;
    mcap.finish(&metrics)?;
    tracing::info!(
        folder = %args.out.display(), complete = metrics.complete,
        ground_truth = metrics.ground_truth, ate_m = metrics.estimate.ate_rmse_m,
        landmark_rmse_m = metrics.map.rmse_m,
        relations_trans_m = metrics.estimate.relations.map(|r| r.trans_mean_m),
        "run folder written"
    );
    metrics.require_a_pose(&args.out)?;
    if args.judge.on() {
        let verdict = expectations.judge(&metrics);
        let mut out = std::io::stdout().lock();
        for line in verdict.lines() {
            writeln!(out, "{line}")?;
        }
        if let Some(junit) = &args.judge.junit {
            let suite = args.out.file_name().map_or_else(
                || "fastslam".to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            verdict.write_junit(junit, &suite)?;
        }
        verdict.into_result()?;
    }
    Ok(())
}

/// The relations of the file at `path`, checked before the run starts.
///
/// # Errors
/// The file and line of what is wrong with it, or a file without a relation.
fn load_relations(path: &Path) -> anyhow::Result<Vec<Relation>> {
    let relations = read_relations(path)?;
    anyhow::ensure!(
        !relations.is_empty(),
        "{}: no relation in the file",
        path.display()
    );
    Ok(relations)
}

/// Prints a progress line on stdout. A reader that went away (closed pipe) is not an
/// error of the recording: the line is dropped.
fn print_progress(p: &Progress) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{p}").and_then(|()| out.flush());
}

/// Runs `keep` for a valid message; logs and skips an invalid one.
fn accept(check: Result<(), validate::Rejection>, what: &str, keep: impl FnOnce()) {
    match check {
        Ok(()) => keep(),
        Err(reason) => tracing::warn!(%reason, "{what} skipped"),
    }
}
