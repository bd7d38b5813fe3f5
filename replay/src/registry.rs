//! The data sets the stack replays, one row each in [`DATA_SETS`]: a row names the data
//! set's `replay` subcommand (name, about text, flags, and what the launcher starts from
//! them), its default profile, its replay process and, where it has one, how an
//! in-process run reads it. The launcher's `replay` subcommands, its hidden replay-process
//! subcommands ([`ProcessCommand`]) and the data sets of `monte-carlo --replay` and
//! `fit-noise` are all read from this table.
//!
//! A data set is one file holding its reader, its process and its row, plus that row's
//! line in [`DATA_SETS`].

use crate::dataset::{Association, DataSet};
use crate::processes::{mrclam, recording, victoria_park};
use crate::profile::Profile;
use crate::recording::Recording;
use anyhow::Context;
use clap::{ArgMatches, Command};
use std::path::Path;

/// Every data set the stack replays, in the order `replay --help` lists them.
pub static DATA_SETS: &[DataSetKind] = &[
    mrclam::DATA_SET,
    victoria_park::DATA_SET,
    recording::ROSBAG,
    recording::CARMEN,
];

/// One data set: its `replay` subcommand, default profile, replay process and in-process
/// reader.
#[derive(Debug)]
pub struct DataSetKind {
    /// Name of its `replay` subcommand (and of its `monte-carlo --replay` value).
    pub name: &'static str,
    /// What `replay --help` says about it.
    pub about: &'static str,
    /// Adds its own flags (the data's path first) to its `replay` subcommand.
    pub flags: fn(Command) -> Command,
    /// What the launcher starts from those flags, once parsed.
    pub plan: fn(&ArgMatches) -> anyhow::Result<Plan>,
    /// The built-in profile it is replayed with unless `--profile` names another.
    pub profile: &'static str,
    /// The process that replays it.
    pub process: &'static Process,
    /// How an in-process run reads it; `None`: through the processes only.
    pub in_process: Option<InProcess>,
}

/// What the launcher's `replay` starts for one data set, beyond the flags every replay
/// takes.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Name of the run folder's data part (the data set, robot and association).
    pub label: String,
    /// What the observations carry: landmark ids or none.
    pub association: Association,
    /// The replay process's own flags, the data's path first.
    pub flags: Vec<String>,
    /// The recording, when it is a user's bag or log (read by the launcher first).
    pub recording: Option<Recording>,
}

/// A replay process: the launcher's hidden subcommand of the same name runs it.
#[derive(Debug)]
pub struct Process {
    /// Its name: the hidden subcommand, the log and the node name.
    pub name: &'static str,
    /// What the hidden subcommand's `--help` says about it.
    pub about: &'static str,
    /// Adds its flags to a command.
    pub args: fn(Command) -> Command,
    /// Runs it with its flags parsed.
    pub run: fn(&ArgMatches) -> anyhow::Result<()>,
}

/// How an in-process run (`monte-carlo --replay`, `fit-noise`) reads a data set.
#[derive(Debug)]
pub struct InProcess {
    /// The data set's title in `--replay`'s help.
    pub title: &'static str,
    /// The folder read when none is given.
    pub default_data: &'static str,
    /// Reads it: its name for tables, its association and its messages.
    pub load: fn(&Request<'_>) -> anyhow::Result<(String, Association, DataSet)>,
}

/// What an in-process run asks of a data set's reader.
#[derive(Debug)]
pub struct Request<'a> {
    /// The data set's folder.
    pub dir: &'a Path,
    /// That folder's own name.
    pub folder: &'a str,
    /// Robot number, for a data set of several robots.
    pub robot: u32,
    /// Association, for a data set whose observations carry landmark ids.
    pub association: Association,
    /// The profile it is read with.
    pub profile: &'a Profile,
}

/// The data set whose `replay` subcommand is `name`.
pub fn find(name: &str) -> Option<&'static DataSetKind> {
    DATA_SETS.iter().find(|kind| kind.name == name)
}

/// The subcommand `matches` holds, looked up by its name with `find`, and its own matches.
///
/// # Errors
/// No subcommand, or one `find` does not know.
pub fn chosen<T>(
    matches: &ArgMatches,
    find: impl FnOnce(&str) -> Option<T>,
) -> Result<(T, &ArgMatches), clap::Error> {
    use clap::error::ErrorKind;
    let (name, sub) = matches
        .subcommand()
        .ok_or_else(|| clap::Error::new(ErrorKind::MissingSubcommand))?;
    let found = find(name).ok_or_else(|| clap::Error::new(ErrorKind::InvalidSubcommand))?;
    Ok((found, sub))
}

/// Every replay process of [`DATA_SETS`], once each, in the table's order.
fn processes() -> impl Iterator<Item = &'static Process> {
    DATA_SETS
        .iter()
        .enumerate()
        .filter(|(i, kind)| {
            !DATA_SETS[..*i]
                .iter()
                .any(|k| k.process.name == kind.process.name)
        })
        .map(|(_, kind)| kind.process)
}

/// The launcher's hidden subcommand of one replay process (`replay-mrclam`…), with its
/// flags: one subcommand per process of [`DATA_SETS`].
#[derive(Debug, Clone)]
pub struct ProcessCommand {
    process: &'static Process,
    matches: ArgMatches,
}

impl ProcessCommand {
    /// The process's name.
    pub fn name(&self) -> &'static str {
        self.process.name
    }

    /// Runs the process.
    ///
    /// # Errors
    /// The process's own errors.
    pub fn run(self) -> anyhow::Result<()> {
        (self.process.run)(&self.matches)
    }
}

impl clap::FromArgMatches for ProcessCommand {
    fn from_arg_matches(matches: &ArgMatches) -> Result<Self, clap::Error> {
        let (process, sub) = chosen(matches, |name| processes().find(|p| p.name == name))?;
        Ok(Self {
            process,
            matches: sub.clone(),
        })
    }

    fn update_from_arg_matches(&mut self, matches: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

impl clap::Subcommand for ProcessCommand {
    fn augment_subcommands(command: Command) -> Command {
        processes().fold(command, |command, p| {
            command.subcommand((p.args)(Command::new(p.name)).about(p.about).hide(true))
        })
    }

    fn augment_subcommands_for_update(command: Command) -> Command {
        Self::augment_subcommands(command)
    }

    fn has_subcommand(name: &str) -> bool {
        processes().any(|p| p.name == name)
    }
}

/// The name of data set folder `data`, which must exist.
///
/// # Errors
/// A folder that cannot be found.
pub(crate) fn folder(data: &Path) -> anyhow::Result<String> {
    let name = std::fs::canonicalize(data).with_context(|| {
        format!(
            "data set folder {} (run from the repository root or pass --data)",
            data.display()
        )
    })?;
    Ok(name
        .file_name()
        .map_or_else(|| "data".to_string(), |n| n.to_string_lossy().into_owned()))
}

/// `path` made absolute, for a process that may run elsewhere.
///
/// # Errors
/// A path that cannot be found.
pub(crate) fn canonical(path: &Path) -> anyhow::Result<String> {
    std::fs::canonicalize(path)
        .with_context(|| format!("{}", path.display()))
        .map(|p| p.display().to_string())
}

/// The file name of `path` up to its first dot (`recording` without one).
pub(crate) fn stem(path: &Path) -> String {
    let name = path.file_name().map_or_else(
        || "recording".to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    name.split('.').next().unwrap_or("recording").to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_default_profiles_are_built_in() {
        for (i, kind) in DATA_SETS.iter().enumerate() {
            assert!(
                DATA_SETS[..i].iter().all(|k| k.name != kind.name),
                "{} listed twice",
                kind.name
            );
            assert!(
                crate::profile::BUILT_IN
                    .iter()
                    .any(|(name, _)| *name == kind.profile),
                "{}: profile {} is not built in",
                kind.name,
                kind.profile
            );
        }
    }

    #[test]
    fn each_process_is_one_hidden_subcommand() {
        use clap::Subcommand;
        let command = ProcessCommand::augment_subcommands(Command::new("launcher"));
        let names: Vec<&str> = command.get_subcommands().map(|c| c.get_name()).collect();
        assert_eq!(
            names,
            ["replay-mrclam", "replay-victoria-park", "replay-recording"]
        );
        assert!(command.get_subcommands().all(Command::is_hide_set));
    }

    #[test]
    fn stems_stop_at_the_first_dot() {
        assert_eq!(stem(Path::new("logs/intel.clf.gz")), "intel");
        assert_eq!(stem(Path::new("/")), "recording");
    }
}
