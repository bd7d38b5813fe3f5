//! `fastslam-stack replay <data set>`: a recorded data set through the whole stack — the
//! data set's replay process, the FastSLAM service and the metrics client, each its own
//! process — under a fresh stack prefix, with a run folder at the end.

use crate::commands::launch::{Ended, LaunchArgs, Place, conclude, prepare};
use crate::supervisor::{Supervisor, stop_flag};
use anyhow::Context;
use clap::Args;
use fastslam_client::relations::RelationsFrame;
use fastslam_replay::profile::Profile;
use fastslam_replay::recording::{Recording, merge_tables, planar_laser_settings};
use fastslam_replay::registry::{self, DataSetKind};
use fastslam_service::config::{EstimatorChoice, Overrides, ServiceConfig};
use fastslam_stack::settings;
use fastslam_stack::topology;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The data set to replay, with its own flags: one subcommand per data set of the
/// [`registry`](fastslam_replay::registry).
#[derive(Debug)]
pub struct DataSet {
    /// Its row of the registry.
    kind: &'static DataSetKind,
    /// Its subcommand's flags, which the row's plan reads.
    matches: clap::ArgMatches,
    /// The flags every replay takes.
    run: ReplayRunArgs,
}

impl clap::FromArgMatches for DataSet {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let (kind, sub) = registry::chosen(matches, registry::find)?;
        Ok(Self {
            kind,
            matches: sub.clone(),
            run: ReplayRunArgs::from_arg_matches(sub)?,
        })
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

impl clap::Subcommand for DataSet {
    fn augment_subcommands(command: clap::Command) -> clap::Command {
        registry::DATA_SETS.iter().fold(command, |command, kind| {
            let own = (kind.flags)(clap::Command::new(kind.name));
            command.subcommand(ReplayRunArgs::augment_args(own).about(kind.about))
        })
    }

    fn augment_subcommands_for_update(command: clap::Command) -> clap::Command {
        Self::augment_subcommands(command)
    }

    fn has_subcommand(name: &str) -> bool {
        registry::find(name).is_some()
    }
}

/// Flags of `replay` common to every data set.
#[derive(Debug, Clone, clap::Args)]
pub struct ReplayRunArgs {
    /// Profile: a built-in name (mrclam, victoria-park, victoria-park-scans,
    /// planar-laser) or a TOML file. Default: the data set's own (planar-laser for a bag
    /// or a log).
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
    /// mode is set from the data set's flags either way. For a bag or a log it goes over
    /// the settings derived from the recording's laser.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Score every trajectory against this relations file (the Freiburg benchmark's
    /// format: `t1 t2 x y z roll pitch yaw`); a bag or a log only.
    #[arg(long)]
    pub relations: Option<PathBuf>,
    /// Whose motions the relations are: the recording's laser (relations measured by
    /// aligning scans, as the Freiburg benchmark's; each trajectory is moved onto the
    /// laser's mount before scoring) or its base. The same where the laser sits at the base.
    #[arg(long, value_enum, default_value_t, requires = "relations")]
    pub relations_frame: RelationsFrame,
    /// Run folder (default: <runs-dir>/<data>_<method>_seed<seed>, the method as `run`
    /// names it).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Where the stack runs, how fast, for how long, what is judged, the live view.
    #[command(flatten)]
    pub launch: LaunchArgs,
}

/// Runs the replay, the service and the client; returns the process exit code (0
/// finished, 1 failed, 130 interrupted).
///
/// # Errors
/// When the data set folder, profile or settings are invalid, or a process cannot start.
pub fn replay(data_set: DataSet) -> anyhow::Result<u8> {
    let kind = data_set.kind;
    let plan = (kind.plan)(&data_set.matches)?;
    let args = &data_set.run;
    let expectations = args.launch.judge.expectations()?;
    args.launch.split.check(args.launch.live.live)?;
    let profile_arg = args
        .profile
        .clone()
        .unwrap_or_else(|| kind.profile.to_string());
    let profile = Profile::load(&profile_arg)?;
    let place = Place::claim(
        args.launch.prefix.as_deref(),
        args.launch.iox_root.as_deref(),
    )?;
    let (prefix, root) = (place.prefix.clone(), place.root.clone());
    // A user's recording is read here first: a bad file fails before anything starts,
    // and its laser gives the settings derived from it and its epoch the relations'.
    if args.relations.is_some() && plan.recording.is_none() {
        anyhow::bail!(
            "--relations scores a bag or a log (replay rosbag, replay carmen): the relation \
             times are on the recording's own clock"
        );
    }
    // The odometry made from the scans (`--odometry laser`) is left to the replay process.
    let loaded = plan.recording.as_ref().map(Recording::read).transpose()?;
    if let Some(loaded) = &loaded {
        for warning in &loaded.warnings {
            eprintln!("warning: {warning}");
        }
    }
    // The service's settings, checked here so a bad value fails before anything starts.
    let mut table =
        settings::replay_service_table(args.config.as_deref(), &profile, plan.association)?;
    if let Some(loaded) = &loaded {
        let mut derived = planar_laser_settings(&loaded.data)?;
        merge_tables(&mut derived, &table);
        table = derived;
    }
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
    if let Some(loaded) = &loaded {
        client.push("--no-truth".into());
        if let Some(relations) = &args.relations {
            client.extend([
                "--relations".into(),
                std::fs::canonicalize(relations)
                    .with_context(|| format!("relations file {}", relations.display()))?
                    .display()
                    .to_string(),
                "--relations-epoch-s".into(),
                format!("{:?}", loaded.data.epoch_s),
            ]);
            let body = args.relations_frame.body(loaded.data.laser_mount.into());
            client.push(format!(
                "--relations-mount={:?},{:?},{:?}",
                body.x, body.y, body.theta
            ));
        }
    }
    client.extend(args.launch.judge.flags());
    let mut replay = stack_flags.clone();
    replay.extend(["--profile".into(), profile_arg_for_child(&profile_arg)]);
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
            _ => (kind.process.name, replay.clone()),
        };
        let mut argv = vec![name.to_string()];
        argv.extend(flags);
        argv.extend(role.wait_flags(args.launch.live.live));
        let log = logs.join(format!("{name}.log"));
        stack.spawn(name, &exe, &argv, &log)?;
        if name == "client" {
            // A client that dies is started again and resumes the run from its journal.
            stack.restart_when_killed(name, "--resume");
        }
    }
    let outcome = stack.wait(&stop, args.launch.timeout_s.map(Duration::from_secs_f64));
    drop(stack);
    place.remove();
    if loaded.is_none() {
        // A recording's warnings were printed when the launcher read it; a data set is
        // read by its replay process alone.
        for warning in logged_warnings(&logs.join(format!("{}.log", kind.process.name))) {
            eprintln!("warning: {warning}");
        }
    }
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

/// The messages of the warnings in a process's log (what the replay skipped reading
/// the data set), without their time and span.
fn logged_warnings(log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    (text.lines())
        .filter_map(|line| line.split_once(" WARN ").map(|(_, rest)| rest))
        .map(|rest| rest.split_once("}: ").map_or(rest, |(_, message)| message))
        .map(str::to_string)
        .collect()
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
