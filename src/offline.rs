//! The stack in one process, without IPC: the simulators' messages ([`OfflineRun`]) or
//! a recorded data set's (in the replay player's order), the service's own glue
//! ([`Admission`], [`Sequencer`], [`Slam`] and the status [`Health`] reports) and the client's scoring ([`Metrics::compute`], with the
//! alignment a replay profile asks for, and the relation errors when a replay has a
//! relations file) — the same code the processes run, message for message, so an
//! in-process run and a run through the processes with the same seed give identical
//! metrics (integration tests hold this). On top of it, the Monte Carlo comparison of
//! `fastslam-stack monte-carlo`.

use crate::lists::List;
use crate::methods::Methods;
use crate::settings;
use anyhow::Context;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use fastslam_client::metrics::{AlignMode, ScoreAt, fit_alignment, scored_at};
use fastslam_client::occupancy::OCCUPIED_THRESH;
use fastslam_client::reference::NoiseModel;
use fastslam_client::relations::{Relation, RelationErrors, RelationsFrame, read_relations};
use fastslam_client::{Metrics, Recording};
use fastslam_estimation::fastslam::Proposal;
use fastslam_estimation::moves::{MoveCorrection, MoveStats};
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_estimation::stats::Summary;
use fastslam_protocol::message::Message as Wire;
use fastslam_protocol::status::RejectionKind;
use fastslam_protocol::validate;
use fastslam_protocol::{Header, StreamId};
use fastslam_replay::dataset::{Association, DataSet};
use fastslam_replay::player::{Next, schedule};
use fastslam_replay::profile::Profile;
use fastslam_replay::registry::{self, DataSetKind, Request};
use fastslam_sensors_sim::Scenario;
use fastslam_sensors_sim::offline::{Message, OfflineRun};
use fastslam_service::admit::Admission;
use fastslam_service::config::{MapKind, Overrides, ServiceConfig};
use fastslam_service::health::Health;
use fastslam_service::sequencer::{Input, Pushed, RawScan, Scan, Sequencer};
use fastslam_service::slam::{Slam, Smoothed};
use std::time::{Duration, Instant};

/// What one in-process run produced.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// The client's metrics, exactly as `metrics.json` of a run through the processes.
    pub metrics: Metrics,
    /// Time spent in the filter (prediction and update calls), simulation excluded.
    pub filter_time: Duration,
    /// Simulated time covered: the stamp of the last pose estimate.
    pub simulated: Duration,
    /// What the optimiser's moves did (`None` without an optimiser).
    pub moves: Option<MoveStats>,
    /// CPU time of the whole run, every thread of the process counted (simulation and
    /// scoring included).
    pub cpu: Duration,
    /// The final occupancy grid's precision and recall against the scenario's walls and
    /// poles ([`GRID_TOLERANCE_M`]), for a simulated world with walls seen by raw scans.
    pub grid: Option<(f64, f64)>,
}

/// How far an occupied cell may lie from a wall or pole and still draw it (m), in the
/// grid precision and recall of [`RunOutcome::grid`].
pub const GRID_TOLERANCE_M: f64 = 0.2;

/// `slam`'s final grid scored against `source`'s walls, where it has walls and a grid.
fn grid_score(source: &Source, slam: &mut Slam) -> Option<(f64, f64)> {
    let Source::Simulation(scenario) = source else {
        return None;
    };
    if scenario.world.walls.is_empty() {
        return None;
    }
    let (h, cells) = slam.grid(Header::default())?;
    let width = h.width as usize;
    let occupied: Vec<[f64; 2]> = (cells.iter().enumerate())
        .filter(|(_, c)| f64::from(**c) >= 100.0 * OCCUPIED_THRESH)
        .map(|(k, _)| {
            [
                h.origin_x + ((k % width) as f64 + 0.5) * h.resolution,
                h.origin_y + ((k / width) as f64 + 0.5) * h.resolution,
            ]
        })
        .collect();
    Some((scenario.world).map_precision_recall(&occupied, h.resolution, GRID_TOLERANCE_M))
}

/// CPU time the process has used so far, user and system, every thread counted.
fn process_cpu() -> Duration {
    use nix::sys::resource::{UsageWho, getrusage};
    getrusage(UsageWho::RUSAGE_SELF).map_or(Duration::ZERO, |u| {
        let tv = |t: nix::sys::time::TimeVal| {
            Duration::new(t.tv_sec().max(0) as u64, (t.tv_usec().max(0) as u32) * 1000)
        };
        tv(u.user_time()) + tv(u.system_time())
    })
}

/// `--replay`'s values: the data sets of the [`registry`] an in-process run can read, by
/// name.
pub fn in_process_data_sets() -> impl TypedValueParser<Value = &'static DataSetKind> {
    let names = registry::DATA_SETS.iter().filter_map(|kind| {
        let reader = kind.in_process.as_ref()?;
        let help = format!("{} (see `replay {}`)", reader.title, kind.name);
        Some(PossibleValue::new(kind.name).help(help))
    });
    PossibleValuesParser::new(names).map(|name| registry::find(&name).expect("a listed name"))
}

/// What an in-process run plays.
#[derive(Debug, Clone)]
pub enum Source {
    /// A simulated scenario: the simulators' messages for the run's seed.
    Simulation(Box<Scenario>),
    /// A recorded data set, the same for every seed.
    Replay(Box<Replay>),
}

/// A recorded data set as an in-process run plays and scores it.
#[derive(Debug, Clone)]
pub struct Replay {
    /// Name for tables (the data set, robot and association).
    pub name: String,
    /// The messages.
    pub data: DataSet,
    /// What the replay's observations carry: landmark ids or none.
    pub association: Association,
    /// The service's settings (the profile's `[service]` table with the association).
    pub service: toml::Table,
    /// How the client aligns the estimate before scoring (the profile's client flags).
    pub align: AlignMode,
    /// Where the client scores (the profile's client flags).
    pub score_at: ScoreAt,
    /// Relations the trajectories are also scored against (see
    /// [`fastslam_client::relations`]; times on the data set's clock, whose epoch is
    /// [`DataSet::epoch_s`]); empty without a relations file.
    pub relations: Vec<Relation>,
    /// Whose motions the relations are: the data set's laser or its base.
    pub relations_frame: RelationsFrame,
}

impl Source {
    /// Data set `set` from `dir` (default: the repository's copy), with `profile` (default:
    /// the data set's own); `robot` and `association` apply to MRCLAM.
    ///
    /// # Errors
    /// A data set without an in-process reader, a missing or malformed data folder or
    /// profile.
    pub fn replay(
        set: &DataSetKind,
        dir: Option<&std::path::Path>,
        robot: u32,
        association: Association,
        profile: Option<&str>,
    ) -> anyhow::Result<Self> {
        let Some(reader) = &set.in_process else {
            anyhow::bail!("{} is replayed through the processes only", set.name);
        };
        let profile = Profile::load(profile.unwrap_or(set.profile))?;
        let dir = dir.unwrap_or(std::path::Path::new(reader.default_data));
        let folder = std::fs::canonicalize(dir)
            .with_context(|| format!("data set folder {}", dir.display()))?
            .file_name()
            .map_or_else(|| "data".into(), |n| n.to_string_lossy().into_owned());
        let (name, association, data) = (reader.load)(&Request {
            dir,
            folder: &folder,
            robot,
            association,
            profile: &profile,
        })?;
        let service = settings::replay_service_table(None, &profile, association)?;
        let scoring = Scoring::from_flags(&profile.client.flags)?;
        Ok(Self::Replay(Box::new(Replay {
            name,
            data,
            association,
            service,
            align: scoring.align,
            score_at: scoring.score_at,
            relations: Vec::new(),
            relations_frame: RelationsFrame::default(),
        })))
    }

    /// The same source, its trajectories also scored against the relations file at
    /// `path` (times on the data set's clock, motions of `frame`).
    ///
    /// # Errors
    /// A simulated scenario (its clock is no data set's), or a relations file that cannot
    /// be read or holds no relation.
    pub fn with_relations(
        self,
        path: &std::path::Path,
        frame: RelationsFrame,
    ) -> anyhow::Result<Self> {
        let Self::Replay(mut replay) = self else {
            anyhow::bail!("relations need a recorded data set: --relations goes with --replay");
        };
        replay.relations = read_relations(path)?;
        replay.relations_frame = frame;
        anyhow::ensure!(
            !replay.relations.is_empty(),
            "{}: no relation in the file",
            path.display()
        );
        Ok(Self::Replay(replay))
    }

    /// The name of the scenario or data set.
    pub fn name(&self) -> &str {
        match self {
            Self::Simulation(s) => &s.name,
            Self::Replay(r) => &r.name,
        }
    }

    /// The service settings: `file` if given, else the scenario's or replay's own, with
    /// `overrides` applied.
    ///
    /// # Errors
    /// As [`settings::service_config`].
    pub fn service_config(
        &self,
        file: Option<&std::path::Path>,
        overrides: &Overrides,
    ) -> anyhow::Result<ServiceConfig> {
        match (self, file) {
            (Self::Simulation(scenario), _) => settings::service_config(scenario, file, overrides),
            (Self::Replay(r), file) => {
                let (origin, table) = match file {
                    Some(path) => {
                        let mut table = settings::read_table(path)?;
                        settings::set_association_mode(&mut table, r.association)?;
                        (path.display().to_string(), table)
                    }
                    None => (format!("{} [service]", r.name), r.service.clone()),
                };
                Ok(ServiceConfig::parse(&origin, &toml::to_string(&table)?)?
                    .with_overrides(overrides)
                    .context("service settings")?)
            }
        }
    }

    /// Every message of the run with simulation seed `seed`, in publication order.
    fn messages(&self, seed: u64) -> Box<dyn Iterator<Item = Message> + '_> {
        match self {
            Self::Simulation(scenario) => Box::new(OfflineRun::new(scenario, seed)),
            Self::Replay(r) => {
                let data = &r.data;
                let map = std::iter::once(Message::TrueMap(data.landmarks.clone()));
                Box::new(
                    map.chain(schedule(data).into_iter().map(|(_, next)| match next {
                        Next::Truth(i) => Message::GroundTruth(data.truth[i]),
                        Next::Odometry(i) => Message::Odometry(data.odometry[i]),
                        Next::Scan(i) => {
                            let scan = &data.scans[i];
                            Message::Observations(scan.header, scan.items.clone())
                        }
                        Next::RawScan(i) => {
                            let scan = &data.raw_scans[i];
                            Message::RawScan(scan.header, scan.items.clone())
                        }
                    })),
                )
            }
        }
    }

    /// How the client scores the run: alignment and where.
    fn scoring(&self) -> (AlignMode, ScoreAt) {
        match self {
            Self::Simulation(_) => (AlignMode::None, ScoreAt::Estimates),
            Self::Replay(r) => (r.align, r.score_at),
        }
    }

    /// Whether the run has ground truth: a simulation always, a data set when it has
    /// truth samples.
    fn has_truth(&self) -> bool {
        match self {
            Self::Simulation(_) => true,
            Self::Replay(r) => !r.data.truth.is_empty(),
        }
    }

    /// The stream its lidar messages come on: raw scans where the scenario has a lidar or
    /// the data set raw scans (which it then plays alone), else landmark observations. The
    /// sequencer orders it against odometry, as the service orders the lidar topic it
    /// subscribed to.
    fn lidar_stream(&self) -> StreamId {
        let raw = match self {
            Self::Simulation(scenario) => scenario.lidar.is_some(),
            Self::Replay(r) => !r.data.raw_scans.is_empty(),
        };
        if raw {
            StreamId::Scan
        } else {
            StreamId::Observations
        }
    }
}

/// The client's scoring flags a replay profile passes.
#[derive(Debug, clap::Parser)]
struct Scoring {
    #[arg(long, value_enum, default_value_t = AlignMode::None)]
    align: AlignMode,
    #[arg(long, value_enum, default_value_t = ScoreAt::Estimates)]
    score_at: ScoreAt,
}

impl Scoring {
    fn from_flags(flags: &[String]) -> anyhow::Result<Self> {
        use clap::Parser;
        let argv = std::iter::once("client".to_string()).chain(flags.iter().cloned());
        Self::try_parse_from(argv).context("the profile's client flags")
    }
}

/// Runs `source` with simulation seed `seed` through the service configured by `config`
/// and scores it as the client does.
///
/// Inputs are admitted by the service's [`Admission`] (so the same inputs are refused,
/// and counted as the service counts them), ordered by its [`Sequencer`] as it orders
/// them with sensors that deliver as fast as possible, and applied by its [`Slam`]; a
/// filter error skips that input, as the service does. The client's recording takes
/// every message its own checks pass, as the client does.
///
/// # Errors
/// When the filter cannot be built from `config`.
pub fn run_in_process(
    source: &Source,
    seed: u64,
    config: &ServiceConfig,
) -> anyhow::Result<RunOutcome> {
    let cpu_start = process_cpu();
    let mut slam = Slam::new(config)?;
    slam.start_smoother(config, Vec::new())?;
    let streams = [StreamId::Odometry, source.lidar_stream()];
    let mut admission = Admission::new(&streams, config);
    let mut sequencer = Sequencer::new(&streams, config.input.max_queue);
    let mut recording = Recording {
        without_truth: !source.has_truth(),
        ..Recording::default()
    };
    let mut filter_time = Duration::ZERO;
    let mut last_pose: Option<Header> = None;
    let mut health = Health::new(Duration::from_secs(5), config.unknown_association());
    let mut apply = |sequencer: &mut Sequencer, recording: &mut Recording| {
        while let Some(input) = sequencer.release() {
            let started = Instant::now();
            let step = slam.apply(&input, &mut |_| {});
            let took = started.elapsed();
            filter_time += took;
            sequencer.recycle(input);
            match step {
                Ok(Some(step)) => {
                    recording.add_estimate(&step.pose);
                    recording.add_status(&health.step(&step, took, &slam, sequencer));
                    last_pose = Some(step.pose.header);
                }
                Ok(None) => {}
                Err(_) => count(recording, RejectionKind::Filter),
            }
        }
    };
    for message in source.messages(seed) {
        let admitted = match message {
            Message::TrueMap(map) => {
                recording.true_map = map;
                continue;
            }
            Message::GroundTruth(truth) => {
                if validate::ground_truth(&truth).is_ok() {
                    recording.add_truth(&truth);
                }
                continue;
            }
            Message::Odometry(m) => {
                if validate::odometry(&m).is_ok() {
                    recording.add_odometry(&m);
                }
                admission.odometry(&m).map(|()| Input::Odometry(m))
            }
            Message::Observations(header, items) => {
                let valid = validate::observations(&header, &items).is_ok();
                let wire = Wire::Observations(&header, &items);
                recording.lidar.note(wire, valid);
                if valid {
                    recording.add_observations(&header, &items);
                }
                (admission.observations(&header, &items))
                    .map(|()| Input::Scan(Scan { header, items }))
            }
            Message::RawScan(header, mut items) => {
                let valid = validate::laser_scan(&header, &items).is_ok();
                recording.lidar.note(Wire::Scan(&header, &items), valid);
                admission.raw_scan(&header, &items).map(|()| {
                    items.truncate(header.ranges as usize);
                    Input::RawScan(RawScan { header, items })
                })
            }
        };
        match admitted {
            Ok(input) => match queue(&mut sequencer, input) {
                Pushed::Queued => {}
                Pushed::Overflowed => count(&mut recording, RejectionKind::Overflow),
                Pushed::Late => count(&mut recording, RejectionKind::Late),
            },
            Err(rejection) => count(&mut recording, rejection.kind()),
        }
        apply(&mut sequencer, &mut recording);
    }
    for stream in streams {
        sequencer.end(stream);
    }
    apply(&mut sequencer, &mut recording);
    let stamp_ns = last_pose.map_or(0, |h| h.stamp_ns);
    recording.map = slam.map(Header { stamp_ns, seq: 0 }).1;
    if let Some(solution) = slam.finish_smoothing() {
        let smoothed = Smoothed::of(&solution, Header { stamp_ns, seq: 0 });
        recording.set_smoothed(&smoothed.trajectory.0, &smoothed.trajectory.1);
        recording.smoothed_map = smoothed.map.1;
    }
    // The service's last status, as the client records it (the back-end's last solve
    // judged).
    recording.add_status(&health.final_status(&slam, &sequencer));
    let grid = grid_score(source, &mut slam);
    let (align, score_at) = source.scoring();
    let alignment = fit_alignment(&scored_at(&recording, score_at), align);
    let mut recording = alignment.apply(&recording);
    let mut metrics =
        Metrics::compute(&recording, true, alignment, score_at).with_smoothed(&mut recording);
    if let Source::Replay(r) = source
        && !r.relations.is_empty()
    {
        let body = r.relations_frame.body(r.data.laser_mount.into());
        metrics = metrics.with_relations(&recording, &r.relations, r.data.epoch_s, &body);
    }
    let metrics = metrics.with_reference(&mut recording, &NoiseModel::of(&config.filter_config()));
    Ok(RunOutcome {
        metrics,
        filter_time,
        simulated: Duration::from_nanos(stamp_ns),
        moves: slam.move_stats(),
        cpu: process_cpu().saturating_sub(cpu_start),
        grid,
    })
}

/// Queues an admitted `input` as the service does when its sensors deliver as fast as
/// possible. There a stream whose queue is full is not taken from, and once the other
/// streams have nothing waiting the sequencer takes them as past its newest stamp
/// ([`Sequencer::vouch`]): their publisher sends every stream in stamp order from one
/// thread. An in-process run plays its messages in stamp order from one loop, so a lane
/// its push filled is vouched for at once; nothing is dropped, and the inputs reach the
/// filter in the order they reach the service's.
fn queue(sequencer: &mut Sequencer, input: Input) -> Pushed {
    let stream = input.stream();
    let pushed = sequencer.push(input);
    if sequencer.full(stream) {
        sequencer.vouch(stream);
    }
    pushed
}

/// Counts an input refused for `kind` in `recording`, as the service's status reports it
/// to the client.
fn count(recording: &mut Recording, kind: RejectionKind) {
    recording.rejections[kind as usize] += 1;
}

/// One row of the Monte Carlo comparison: an estimator (the service settings a run used)
/// with one particle count, over the seeds.
#[derive(Debug, Clone)]
pub struct Row {
    /// Short name of the estimator ([`ServiceConfig::method`]).
    pub method: String,
    /// The optimiser.
    pub optimizer: OptimiserKind,
    /// What the optimiser's answer does (meaningless without an optimiser).
    pub correction: MoveCorrection,
    /// The proposal of the new poses.
    pub proposal: Proposal,
    /// Number of particles.
    pub particles: usize,
    /// Absolute trajectory error RMSE per run (m).
    pub ate: Summary,
    /// Dead reckoning's ATE RMSE per run (m): the baseline.
    pub dead_reckoning: Summary,
    /// The achievable-accuracy reference's ATE RMSE per run (m), where the data carries
    /// landmark ids (else not a number).
    pub reference: Summary,
    /// The estimate's ATE over the reference's, per run: "times the achievable error".
    pub over_reference: Summary,
    /// The smoothing back-end's ATE RMSE per run (m), with `[smoother] enabled` (else
    /// not a number).
    pub smoothed: Summary,
    /// Runs whose smoothed final position error is under 1 m.
    pub smoothed_final_under_1m: usize,
    /// Landmark RMSE per run after optimal assignment (m).
    pub landmark: Summary,
    /// Landmarks in the published map per run (against `true_landmarks`).
    pub landmarks: Summary,
    /// Landmarks in the true map (0 where the data has none).
    pub true_landmarks: usize,
    /// Mean pose NEES per run (3 when consistent).
    pub nees: Summary,
    /// Fraction of steps within the χ²₃ 95 % bound per run.
    pub nees_within: Summary,
    /// Fraction of steps per run whose published covariance is singular (particles
    /// collapsed onto one pose; no NEES, outside the bound).
    pub singular: Summary,
    /// Time in the filter per run (s).
    pub seconds: Summary,
    /// CPU time per run (s): the whole in-process run, every thread.
    pub cpu: Summary,
    /// The optimiser's moves summed over the runs (`None` without an optimiser).
    pub moves: Option<MoveStats>,
    /// What the particles map.
    pub map: MapKind,
    /// The final grid's precision per run against the true walls ([`RunOutcome::grid`];
    /// not a number without one).
    pub grid_precision: Summary,
    /// Its recall per run.
    pub grid_recall: Summary,
    /// The estimate's mean translational relation error per run (m), with a relations
    /// file (else not a number).
    pub relations_trans: Summary,
    /// The standard deviation of its translational relation error per run (m).
    pub relations_trans_std: Summary,
    /// Its mean rotational relation error per run (°).
    pub relations_rot: Summary,
}

/// The settings of one comparison: which estimators, particle counts and seeds.
#[derive(Debug, Clone, clap::Args)]
pub struct Comparison {
    /// Optimisers, corrections and particle counts (default N: the configuration's).
    #[command(flatten)]
    pub methods: Methods,
    /// Proposals, comma-separated: motion (FastSLAM 1.0) and/or fastslam2 (default: the
    /// configuration's).
    #[arg(long, value_delimiter = ',')]
    pub proposals: Vec<Proposal>,
    /// What particles map, comma-separated: landmarks and/or grid (default: the
    /// configuration's). Grid rows ignore the move correction (the matcher is always a
    /// per-particle proposal) and appear once per optimiser.
    #[arg(long, value_delimiter = ',', value_parser = PossibleValuesParser::new(MapKind::NAMES).map(|s| MapKind::parse(&s).expect("a listed name")))]
    pub maps: Vec<MapKind>,
    /// Seeds of simulation and filter (as `run --seed`): an inclusive range `a..b` or a
    /// comma-separated list.
    #[arg(long, default_value = "1..10")]
    pub seeds: List<u64>,
}

/// Runs the comparison on `source` with the service settings of `base` (a config file,
/// else the scenario's or replay's `[service]` table), calling `row_done` after each row.
///
/// # Errors
/// A bad setting, or a filter that cannot be built.
pub fn compare(
    source: &Source,
    base: Option<&std::path::Path>,
    comparison: &Comparison,
    mut row_done: impl FnMut(&Row),
) -> anyhow::Result<Vec<Row>> {
    let mut rows = Vec::new();
    let configured = source.service_config(base, &Overrides::default())?;
    let particles = comparison
        .methods
        .particles_or(&[configured.filter.particles]);
    let proposals = if comparison.proposals.is_empty() {
        vec![configured.filter.proposal]
    } else {
        comparison.proposals.clone()
    };
    let maps = if comparison.maps.is_empty() {
        vec![configured.map.kind]
    } else {
        comparison.maps.clone()
    };
    let mut done = std::collections::HashSet::new();
    for (map, proposal) in maps
        .into_iter()
        .flat_map(|m| proposals.iter().map(move |&p| (m, p)))
    {
        for (kind, correction) in comparison.methods.methods() {
            for &particles in &particles {
                let mut runs = Vec::with_capacity(comparison.seeds.0.len());
                let mut method = String::new();
                for &seed in &comparison.seeds.0 {
                    let overrides = Overrides {
                        particles: Some(particles),
                        seed: Some(seed),
                        ..Overrides::default()
                    };
                    let mut config = source.service_config(base, &overrides)?;
                    config.filter.proposal = proposal;
                    config.optimizer.kind = kind;
                    config.moves.correction = correction;
                    config.map.kind = map;
                    method = config.method();
                    if !done.insert((method.clone(), particles, seed)) {
                        break;
                    }
                    runs.push(run_in_process(source, seed, &config)?);
                }
                if runs.is_empty() {
                    continue;
                }
                let row = Row {
                    optimizer: kind,
                    correction,
                    proposal,
                    map,
                    ..summarise(method, particles, &runs)
                };
                row_done(&row);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// The row of one estimator from its runs.
fn summarise(method: String, particles: usize, runs: &[RunOutcome]) -> Row {
    let column =
        |f: &dyn Fn(&RunOutcome) -> f64| Summary::of(&runs.iter().map(f).collect::<Vec<_>>());
    let moves = runs.iter().filter_map(|r| r.moves).reduce(|a, b| a + b);
    Row {
        method,
        optimizer: OptimiserKind::None,
        correction: MoveCorrection::None,
        proposal: Proposal::Motion,
        particles,
        ate: column(&|r| r.metrics.estimate.ate_rmse_m),
        dead_reckoning: column(&|r| r.metrics.dead_reckoning.ate_rmse_m),
        reference: column(&|r| r.metrics.reference_ate_m()),
        over_reference: column(&|r| r.metrics.estimate.ate_rmse_m / r.metrics.reference_ate_m()),
        smoothed: column(&|r| r.metrics.smoothed_ate_m()),
        smoothed_final_under_1m: (runs.iter())
            .filter_map(|r| r.metrics.smoothed.as_ref())
            .filter(|s| s.trajectory.final_error_m < 1.0)
            .count(),
        landmark: column(&|r| r.metrics.map.rmse_m),
        landmarks: column(&|r| r.metrics.map.estimated as f64),
        true_landmarks: runs.first().map_or(0, |r| r.metrics.map.truth),
        grid_precision: column(&|r| r.grid.map_or(f64::NAN, |g| g.0)),
        grid_recall: column(&|r| r.grid.map_or(f64::NAN, |g| g.1)),
        relations_trans: column(&|r| relation(r, |e| e.trans_mean_m)),
        relations_trans_std: column(&|r| relation(r, |e| e.trans_std_m)),
        relations_rot: column(&|r| relation(r, |e| e.rot_mean_deg)),
        nees: column(&|r| r.metrics.consistency.nees_mean),
        nees_within: column(&|r| r.metrics.consistency.nees_within_95),
        singular: column(&|r| {
            let c = &r.metrics.consistency;
            c.singular as f64 / (c.poses + c.singular).max(1) as f64
        }),
        seconds: column(&|r| r.filter_time.as_secs_f64()),
        cpu: column(&|r| r.cpu.as_secs_f64()),
        moves,
        map: MapKind::Landmarks,
    }
}

/// A number of the estimate's relation errors of `run`; not a number without them.
fn relation(run: &RunOutcome, field: fn(&RelationErrors) -> f64) -> f64 {
    (run.metrics.estimate.relations.as_ref()).map_or(f64::NAN, field)
}
