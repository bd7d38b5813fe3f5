//! Records a run of the stack and writes its run folder when every stream has ended
//! (or, marked incomplete, on SIGINT/SIGTERM). While it records, it prints a progress
//! line on stdout a few times a second (see [`crate::progress`]).

use crate::align::Se2;
use crate::expect::{Expectations, JudgeArgs};
use crate::inputs::{Ends, Inputs, Opening, TRUTH_WAIT_S, TruthWait};
use crate::journal::{self, Journal, Start};
use crate::latency::LatencyMatcher;
use crate::mcap::RunMcap;
use crate::metrics::{AlignMode, ScoreAt, fit_alignment, interpolate, scored_at};
use crate::progress::{LiveAte, Progress};
use crate::reference::NoiseModel;
use crate::relations::{Relation, read_relations};
use crate::resources::ProcessMonitor;
use crate::warnings::Warnings;
use crate::{Metrics, Recording, report};
use fastslam_estimation::graph::g2o::G2o;
use fastslam_protocol::ipc::{Ended, Flow, Ipc};
use fastslam_protocol::message::Message;
use fastslam_protocol::stream::Repeats;
use fastslam_protocol::topics::{Publisher, Topic, TopicRow};
use fastslam_protocol::{Header, cli, validate};
use fastslam_service::config::{InputConfig, ServiceConfig};
use fastslam_service::health::RejectionLog;
use std::collections::HashSet;
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
    /// The pose on the base (x m, y m, θ rad) of the body whose motions the relations
    /// are: the laser's mount for relations measured by aligning scans, as the Freiburg
    /// benchmark's. Every pose is scored as `pose ∘ mount`. Default: the base itself.
    #[arg(long, value_name = "X,Y,THETA", default_value = "0,0,0", value_parser = mount,
          allow_hyphen_values = true)]
    pub relations_mount: Se2,
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
    /// Write the achievable-accuracy reference's solved graph here as g2o (needs
    /// `--service-config`; gzipped when the name ends in `.gz`), to check it with another
    /// solver.
    #[arg(long, value_name = "FILE")]
    pub graph_out: Option<PathBuf>,
    /// Expectations on the metrics and a JUnit report.
    #[command(flatten)]
    pub judge: JudgeArgs,
    /// Go on recording the run of a client that died: take what its journal in `--out`
    /// holds, and ask the stack's publishers for what they kept since (the launcher
    /// starts a client that died again with this flag).
    #[arg(long)]
    pub resume: bool,
}

/// Records until every stream has ended (or a signal arrives), then writes the run folder.
///
/// # Errors
/// IPC failures or a run folder that cannot be written.
pub fn run(args: Args) -> anyhow::Result<()> {
    let expectations = args.judge.expectations()?;
    let relations = args.relations.as_deref().map(load_relations).transpose()?;
    if let Some(relations) = &relations {
        let body = args.relations_mount;
        tracing::info!(
            relations = relations.len(),
            x_m = body.x,
            y_m = body.y,
            theta_rad = body.theta,
            "relations read: scored on the body at this pose on the base"
        );
    }
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
    std::fs::create_dir_all(&args.out)?;
    let (inputs, mut recorder) = if args.resume {
        let start = journal::start_of(&args.out)?;
        let inputs = Inputs::open(&ipc, Opening::Resume(start))?;
        let mut recorder = Recorder::new(&ipc, &inputs, &args.out)?;
        recorder.resume(&ipc, &args.out)?;
        (inputs, recorder)
    } else {
        // The first notice goes out before the producers start: they keep from then on.
        let journal = Journal::create(&ipc, &args.out)?;
        let opening = Opening::Wait {
            truth: truth_wait,
            resend: true,
        };
        let inputs = Inputs::open(&ipc, opening)?;
        let mut recorder = Recorder::new(&ipc, &inputs, &args.out)?;
        recorder.journal = Some(journal);
        recorder.journal_start(inputs.start());
        (inputs, recorder)
    };
    tracing::info!(lidar = ?inputs.lidar(), ground_truth = inputs.ground_truth(), "recording");

    let ended = ipc.wake_loop::<anyhow::Error>(&inputs.sources(), Some(SAMPLE_EVERY), || {
        recorder.wake(&ipc, &inputs)
    })?;
    let (rec, mcap, journal) = recorder.finish(&ipc);
    let (rec, metrics) = score(&args, &rec, ended == Ended::Done, relations, noise);
    for line in Warnings::of(&metrics).lines {
        tracing::warn!("{line}");
    }
    report::write(&args.out, &rec, &metrics)?;
    mcap.finish(&metrics)?;
    if let Some(journal) = journal {
        journal.finish()?;
    }
    tracing::info!(
        folder = %args.out.display(), complete = metrics.complete,
        ground_truth = metrics.ground_truth, ate_m = metrics.estimate.ate_rmse_m,
        landmark_rmse_m = metrics.map.rmse_m,
        relations_trans_m = metrics.estimate.relations.map(|r| r.trans_mean_m),
        "run folder written"
    );
    metrics.require_a_pose(&args.out)?;
    if args.judge.on() {
        judge(&args, &expectations, &metrics)?;
    }
    Ok(())
}

/// What the client keeps while it records: the recording and its MCAP file, and the
/// bookkeeping of the streams, the skipped inputs, the latency, the live score and the
/// processes' usage.
struct Recorder {
    rec: Recording,
    mcap: RunMcap,
    ends: Ends,
    /// Inputs the checks refused, logged once per reason per interval as the service does.
    rejected: RejectionLog,
    seen: Repeats,
    latency: LatencyMatcher,
    monitor: ProcessMonitor,
    live_ate: LiveAte,
    last_sample: Instant,
    /// The journal, written as messages are taken.
    journal: Option<Journal>,
    /// Set when recording the run of a client that died: messages then come out of
    /// order (the journal's, those sent again, new ones), each taken once.
    resumed: Option<HashSet<(u32, u64, u64)>>,
}

impl Recorder {
    /// Records `inputs` into a new recording and the MCAP file at `mcap`, with a first
    /// sample of the processes' usage.
    ///
    /// # Errors
    /// When the file cannot be created.
    fn new(ipc: &Ipc, inputs: &Inputs, out: &Path) -> anyhow::Result<Self> {
        let mcap = &out.join(report::files::MCAP);
        let mut recorder = Self::recording(inputs.ends(), !inputs.ground_truth(), mcap)?;
        recorder.monitor.sample(ipc);
        Ok(recorder)
    }

    /// Records the streams of `ends` (`without_truth` when there is no ground truth) into
    /// a new recording and the MCAP file at `mcap`.
    ///
    /// # Errors
    /// When the file cannot be created.
    fn recording(ends: Ends, without_truth: bool, mcap: &Path) -> anyhow::Result<Self> {
        let log_interval = Duration::from_secs_f64(InputConfig::default().log_interval_s);
        Ok(Self {
            rec: Recording {
                without_truth,
                ..Recording::default()
            },
            mcap: RunMcap::create(mcap)?,
            ends,
            rejected: RejectionLog::new(log_interval),
            seen: Repeats::default(),
            latency: LatencyMatcher::default(),
            monitor: ProcessMonitor::new(),
            live_ate: LiveAte::default(),
            last_sample: Instant::now(),
            journal: None,
            resumed: None,
        })
    }

    /// Records the topics chosen, in the journal.
    fn journal_start(&mut self, start: Start) {
        if let Some(journal) = &mut self.journal {
            journal.started(start);
        }
    }

    /// Takes again what the journal of the client that died in `out` holds, and goes on
    /// journaling there; its first notice asks the publishers for what they kept.
    ///
    /// # Errors
    /// The journal cannot be read or written.
    fn resume(&mut self, ipc: &Ipc, out: &Path) -> anyhow::Result<()> {
        self.resumed = Some(HashSet::new());
        let (journal, start) = Journal::resume(ipc, out, |row, message, checked| {
            self.take_message(row, message, checked, false);
        })?;
        self.journal = Some(journal);
        self.journal_start(start);
        tracing::info!(
            poses = self.rec.estimates.len(),
            truth = self.rec.truth.len(),
            "resumed the recording of a client that died: its journal is taken; the \
             publishers send again what they kept"
        );
        Ok(())
    }

    /// One wake-up: takes every pending message, samples the processes and prints the
    /// progress when due; stops once every stream has ended.
    ///
    /// # Errors
    /// IPC failures.
    fn wake(&mut self, ipc: &Ipc, inputs: &Inputs) -> anyhow::Result<Flow> {
        let mut announced = false;
        inputs.drain(|row, message, checked| announced |= self.take(row, message, checked))?;
        if let Some(journal) = &mut self.journal {
            journal.tend()?;
        }
        self.rejected.flush(Instant::now());
        // A publisher that announced its end has done its work: sample its CPU time now,
        // before it exits (see `resources`).
        if announced || self.last_sample.elapsed() >= SAMPLE_EVERY {
            self.last_sample = Instant::now();
            self.monitor.sample(ipc);
            print_progress(&self.progress());
        }
        Ok(if self.ends.finished() {
            Flow::Stop
        } else {
            Flow::Continue
        })
    }

    /// Takes one message of `row`'s topic: a repeat is skipped, any other counts for its
    /// stream's end and the latency, and, when `checked` passed, is recorded. True when
    /// it announced the end of one of the streams.
    fn take(
        &mut self,
        row: &'static TopicRow,
        message: Message<'_>,
        checked: Result<(), validate::Rejection>,
    ) -> bool {
        self.take_message(row, message, checked, true)
    }

    /// As [`Recorder::take`]; `live` when it just arrived (else it comes from the
    /// journal: neither journaled again nor timed).
    fn take_message(
        &mut self,
        row: &'static TopicRow,
        message: Message<'_>,
        checked: Result<(), validate::Rejection>,
        live: bool,
    ) -> bool {
        if self.repeat(row, message.header()) {
            return false;
        }
        if live {
            if let Some(journal) = &mut self.journal {
                journal.add(row, message);
            }
            self.time(message);
        }
        let announced = self.ends.note(row, message);
        let unusable = self.rec.lidar.note(message, checked.is_ok());
        if unusable && self.rec.lidar.unusable == 1 && matches!(message, Message::Scan(..)) {
            tracing::warn!(
                seq = message.header().seq,
                "a scan without a single return (every beam NaN, too close or beyond \
                 range): it gives the filter nothing; such scans are counted in \
                 metrics.json (/inputs/lidar_unusable), not logged"
            );
        }
        match checked {
            Ok(()) => self.keep(row.topic, message),
            // An invalid lidar message counts for its stamp only.
            Err(_) if matches!(message, Message::Observations(..) | Message::Scan(..)) => {}
            Err(reason) => {
                let seq = message.header().seq;
                (self.rejected).reject(Instant::now(), row.what, seq, reason.kind(), &reason);
            }
        }
        announced
    }

    /// True when the message with `header` was taken already: the sensors and the
    /// service send again what a resumed service or a restarted bridge may lack (see
    /// [`Repeats`]); the truth is never sent again.
    fn repeat(&mut self, row: &TopicRow, header: Header) -> bool {
        match (row.stream, &mut self.resumed) {
            // Of a stream where the newest counts, an older one is moot.
            (Some(id), _) if journal::snapshot(id) => !self.seen.fresh(id, header),
            (Some(id), Some(taken)) => !taken.insert((id as u32, header.seq, header.stamp_ns)),
            (Some(id), None) if row.publisher != Publisher::Truth => !self.seen.fresh(id, header),
            _ => false,
        }
    }

    /// Notes when a lidar message or a pose arrived, for the latency.
    fn time(&mut self, message: Message<'_>) {
        let stamp_ns = message.header().stamp_ns;
        match message {
            Message::Observations(..) | Message::Scan(..) => {
                self.latency.observation(stamp_ns, Instant::now());
            }
            Message::Pose(_) => self.latency.pose(stamp_ns, Instant::now()),
            _ => {}
        }
    }

    /// Records a valid message of `topic`, and scores a pose against the truth so far.
    fn keep(&mut self, topic: Topic, message: Message<'_>) {
        self.rec.add(topic, message);
        self.mcap.message(topic, message);
        if let Message::Pose(p) = message
            && let Some(t) = interpolate(&self.rec.truth, p.header.stamp_ns)
        {
            self.live_ate.add((p.x - t.x).hypot(p.y - t.y));
        }
    }

    /// The progress line as it stands.
    fn progress(&self) -> Progress {
        Progress {
            sim_s: (self.rec.estimates.last()).map_or(0.0, |e| e.pose.stamp_ns as f64 * 1e-9),
            ate_m: self.live_ate.rmse(),
            poses: self.rec.estimates.len(),
        }
    }

    /// The recording with its latencies and the processes' usage, and the MCAP file.
    fn finish(mut self, ipc: &Ipc) -> (Recording, RunMcap, Option<Journal>) {
        self.rejected.flush_all();
        self.monitor.sample(ipc);
        self.rec.latencies = self.latency.latencies().to_vec();
        self.rec.streamed_s = self.latency.streamed_s();
        self.rec.processes = self.monitor.usage();
        if self.resumed.is_some() {
            self.rec.sort_by_stamp();
        }
        (self.rec, self.mcap, self.journal)
    }
}

/// The metrics of `rec` (`complete` when every stream ended) as `args` ask, with the
/// recording aligned to the truth as they were scored.
fn score(
    args: &Args,
    rec: &Recording,
    complete: bool,
    relations: Option<Vec<Relation>>,
    noise: Option<NoiseModel>,
) -> (Recording, Metrics) {
    let alignment = fit_alignment(&scored_at(rec, args.score_at), args.align);
    let mut rec = alignment.apply(rec);
    let mut metrics =
        Metrics::compute(&rec, complete, alignment, args.score_at).with_smoothed(&mut rec);
    if let Some(relations) = &relations {
        let (epoch_s, body) = (args.relations_epoch_s, &args.relations_mount);
        metrics = metrics.with_relations(&rec, relations, epoch_s, body);
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
    if let Some(path) = &args.graph_out {
        match &rec.reference_graph {
            Some(graph) => match G2o::from_graph(graph).save(path) {
                Ok(()) => tracing::info!(path = %path.display(), "reference graph written"),
                Err(e) => {
                    tracing::warn!(path = %path.display(), "reference graph not written: {e}")
                }
            },
            None => tracing::warn!(
                "--graph-out: no reference was solved (no ground truth, no landmark ids or no --service-config)"
            ),
        }
    }
    (rec, metrics)
}

/// Judges `metrics` against `expectations`: prints the verdict, writes the JUnit report
/// `args` ask for.
///
/// # Errors
/// A failed expectation, or a report that cannot be written.
fn judge(args: &Args, expectations: &Expectations, metrics: &Metrics) -> anyhow::Result<()> {
    let verdict = expectations.judge(metrics);
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
    verdict.into_result()
}

/// A pose given as `x,y,θ` (m, m, rad), three finite numbers.
fn mount(text: &str) -> Result<Se2, String> {
    let values: Vec<f64> = (text.split(','))
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [x, y, theta] if values.iter().all(|v| v.is_finite()) => Ok(Se2 { x, y, theta }),
        _ => Err(format!("expected three finite numbers x,y,θ, got `{text}`")),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_protocol::status::RejectionKind;
    use fastslam_protocol::{GroundTruth, LaserScanHeader, topics};

    #[test]
    fn bad_inputs_are_logged_once_per_reason_per_interval_and_every_one_counted() {
        let dir = std::env::temp_dir().join(format!("client-skips-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut recorder =
            Recorder::recording(Ends::default(), false, &dir.join("run.mcap")).unwrap();
        let truth = topics::row("ground_truth").unwrap();
        for seq in 0..1000 {
            let sample = GroundTruth {
                header: Header {
                    stamp_ns: seq * 1_000_000,
                    seq,
                },
                x: f64::NAN,
                ..GroundTruth::default()
            };
            let checked = validate::ground_truth(&sample);
            recorder.take(truth, Message::GroundTruth(&sample), checked);
        }
        let k = RejectionKind::NonFinite as usize;
        assert_eq!(recorder.rejected.counts()[k], 1000);
        assert_eq!(
            recorder.rejected.pending()[k],
            999,
            "one line, the rest summarised"
        );
        assert!(recorder.rec.truth.is_empty());
        let scan = topics::row("scan").unwrap();
        let h = LaserScanHeader {
            angle_increment: 0.01,
            range_max: 30.0,
            ranges: 3,
            ..LaserScanHeader::default()
        };
        for seq in 0..5 {
            let h = LaserScanHeader {
                header: Header { stamp_ns: seq, seq },
                ..h
            };
            let nan = [f32::NAN; 3];
            recorder.take(
                scan,
                Message::Scan(&h, &nan),
                validate::laser_scan(&h, &nan),
            );
        }
        assert_eq!(recorder.rec.lidar.messages, 5);
        assert_eq!(recorder.rec.lidar.unusable, 5, "every beam NaN: counted");
        let account = crate::metrics::InputAccount::of(&recorder.rec);
        assert_eq!(account.lidar_unusable, 5);
        assert_eq!(account.warnings().len(), 1, "{:?}", account.warnings());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
