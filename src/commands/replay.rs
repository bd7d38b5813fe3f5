//! `fastslam-stack replay <data set>`: a recorded data set through the whole stack — the
//! data set's replay process, the FastSLAM service and the metrics client, each its own
//! process — under a fresh stack prefix, with a run folder at the end.

use crate::commands::launch::{Ended, LaunchArgs, Place, conclude, prepare};
use crate::supervisor::{Supervisor, stop_flag};
use anyhow::Context;
use fastslam_replay::dataset::Association;
use fastslam_replay::profile::Profile;
use fastslam_service::config::{EstimatorChoice, Overrides, ServiceConfig};
use fastslam_stack::settings;
use fastslam_stack::topology;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The data set to replay, with its own flags.
#[derive(Debug, Clone, clap::Subcommand)]
pub enum DataSet {
    /// UTIAS MRCLAM: one robot's odometry and barcode observations, scored against Vicon
    /// ground truth and the true landmarks.
    Mrclam {
        /// Data set folder (Barcodes.dat, Landmark_Groundtruth.dat, Robot<r>_*.dat[.gz]).
        #[arg(long, default_value = "data/mrclam7")]
        data: PathBuf,
        /// Robot number.
        #[arg(long, default_value_t = 1)]
        robot: u32,
        /// Known: barcodes as landmark ids; unknown: the service associates by itself.
        #[arg(long, value_enum, default_value_t = Association::Known)]
        association: Association,
        /// Flags every replay takes.
        #[command(flatten)]
        run: ReplayRunArgs,
    },
    /// ACFR Victoria Park: odometry and tree detections, GPS as sparse ground truth
    /// (unknown association).
    VictoriaPark {
        /// Data set folder (odometry.csv, tree_observations.csv, scan_times.csv, gps.csv,
        /// each plain or .gz).
        #[arg(long, default_value = "data/victoria_park")]
        data: PathBuf,
        /// Flags every replay takes.
        #[command(flatten)]
        run: ReplayRunArgs,
    },
}

/// Flags of `replay` common to every data set.
#[derive(Debug, Clone, clap::Args)]
pub struct ReplayRunArgs {
    /// Profile: a built-in name (mrclam, victoria-park) or a TOML file. Default: the data
    /// set's own.
    #[arg(long)]
    pub profile: Option<String>,
    /// Seed of the filter.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Optimiser, proposal and move correction of the FastSLAM service.
    #[command(flatten)]
    pub choice: EstimatorChoice,
    /// Number of particles (default: the profile's).
    #[arg(long)]
    pub particles: Option<usize>,
    /// Service config file (default: the profile's [service] table); its association
    /// mode is set from the data set's flags either way.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Run folder (default: <runs-dir>/<data>_<method>_seed<seed>, the method as `run`
    /// names it).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Where the stack runs, how fast, for how long, what is judged, the live view.
    #[command(flatten)]
    pub launch: LaunchArgs,
}

/// What the replay process needs beyond the common flags: its subcommand, run-folder
/// name, default profile, association, and its own flags.
struct Plan<'a> {
    process: &'static str,
    label: String,
    default_profile: &'static str,
    association: Association,
    data: &'a Path,
    flags: Vec<String>,
    run: &'a ReplayRunArgs,
}

impl DataSet {
    fn plan(&self) -> anyhow::Result<Plan<'_>> {
        let folder = |data: &Path| {
            let name = std::fs::canonicalize(data).with_context(|| {
                format!(
                    "data set folder {} (run from the repository root or pass --data)",
                    data.display()
                )
            })?;
            Ok::<_, anyhow::Error>(
                name.file_name()
                    .map_or_else(|| "data".to_string(), |n| n.to_string_lossy().into_owned()),
            )
        };
        Ok(match self {
            Self::Mrclam {
                data,
                robot,
                association,
                run,
            } => Plan {
                process: "replay-mrclam",
                label: format!(
                    "{}-robot{robot}-{}",
                    folder(data)?,
                    association.service_mode()
                ),
                default_profile: "mrclam",
                association: *association,
                data,
                flags: vec![
                    "--robot".into(),
                    robot.to_string(),
                    "--association".into(),
                    association.service_mode().into(),
                ],
                run,
            },
            Self::VictoriaPark { data, run } => Plan {
                process: "replay-victoria-park",
                label: folder(data)?,
                default_profile: "victoria-park",
                association: Association::Unknown,
                data,
                flags: Vec::new(),
                run,
            },
        })
    }
}

/// Runs the replay, the service and the client; returns the process exit code (0
/// finished, 1 failed, 130 interrupted).
///
/// # Errors
/// When the data set folder, profile or settings are invalid, or a process cannot start.
pub fn replay(data_set: DataSet) -> anyhow::Result<u8> {
    let plan = data_set.plan()?;
    let args = plan.run;
    let expectations = args.launch.judge.expectations()?;
    args.launch.split.check(args.launch.live.live)?;
    let profile_arg = args
        .profile
        .clone()
        .unwrap_or_else(|| plan.default_profile.to_string());
    let profile = Profile::load(&profile_arg)?;
    let place = Place::claim(
        args.launch.prefix.as_deref(),
        args.launch.iox_root.as_deref(),
    )?;
    let (prefix, root) = (place.prefix.clone(), place.root.clone());
    // The service's settings, checked here so a bad value fails before anything starts.
    let table = settings::replay_service_table(args.config.as_deref(), &profile, plan.association)?;
    let overrides = Overrides {
        particles: args.particles,
        seed: Some(args.seed),
        choice: args.choice.clone(),
    };
    let method = ServiceConfig::parse("the replay's service settings", &toml::to_string(&table)?)?
        .with_overrides(&overrides)
        .context("service settings")?
        .method();
    let out = args.out.clone().unwrap_or_else(|| {
        args.launch
            .runs_dir
            .join(format!("{}_{method}_seed{}", plan.label, args.seed))
    });
    let logs = prepare(&out)?;
    let config = out.join("service.toml");
    std::fs::write(&config, toml::to_string_pretty(&table)?)?;
    let exe = std::env::current_exe().context("locating the launcher's own executable")?;

    let stack_flags = vec![
        "--prefix".to_string(),
        prefix.clone(),
        "--iox-root".into(),
        root.display().to_string(),
    ];
    let mut service_flags = stack_flags.clone();
    service_flags.extend(overrides.flags());
    service_flags.extend(["--config".into(), config.display().to_string()]);
    if !args.launch.pace.realtime {
        service_flags.push("--as-fast-as-possible".into());
    }
    let mut client = stack_flags.clone();
    client.extend(["--out".into(), out.display().to_string()]);
    client.extend(["--service-config".into(), config.display().to_string()]);
    client.extend(profile.client.flags.iter().cloned());
    client.extend(args.launch.judge.flags());
    let mut replay = stack_flags.clone();
    replay.extend([
        "--data".into(),
        std::fs::canonicalize(plan.data)?.display().to_string(),
        "--profile".into(),
        profile_arg_for_child(&profile_arg),
    ]);
    replay.extend(plan.flags.iter().cloned());
    replay.extend(args.launch.pace.flags());

    let stop = stop_flag()?;
    let started = Instant::now();
    let mut stack = Supervisor::default();
    eprintln!(
        "stack {prefix}: {method} on {} ({})",
        plan.label, profile.name
    );
    place.announce();
    args.launch
        .split
        .spawn_bridge(&mut stack, &exe, &stack_flags, &logs)?;
    args.launch
        .live
        .spawn(&mut stack, &exe, &stack_flags, &logs)?;
    for role in topology::REPLAY
        .iter()
        .filter(|role| args.launch.split.runs_here(role.name))
    {
        let (name, flags) = match role.name {
            "client" => ("client", client.clone()),
            "service" => ("service", service_flags.clone()),
            _ => (plan.process, replay.clone()),
        };
        let mut argv = vec![name.to_string()];
        argv.extend(flags);
        argv.extend(role.wait_flags(args.launch.live.live));
        stack.spawn(name, &exe, &argv, &logs.join(format!("{name}.log")))?;
    }
    let outcome = stack.wait(&stop, args.launch.timeout_s.map(Duration::from_secs_f64));
    drop(stack);
    place.remove();
    if let Some(code) = args.launch.split.conclusion(&outcome, &logs) {
        return Ok(code);
    }
    let ended = Ended {
        outcome,
        out: &out,
        logs: &logs,
        wall: started.elapsed(),
    };
    conclude(ended, &args.launch.judge, &expectations)
}

/// A built-in profile is passed by name, a file by absolute path.
fn profile_arg_for_child(profile: &str) -> String {
    if fastslam_replay::profile::BUILT_IN
        .iter()
        .any(|(n, _)| *n == profile)
    {
        return profile.to_string();
    }
    std::fs::canonicalize(profile).map_or_else(|_| profile.to_string(), |p| p.display().to_string())
}
