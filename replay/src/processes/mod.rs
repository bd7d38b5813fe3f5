//! The replay processes. Each is `Args` (its flags) plus `run(args)`, called by its own
//! binary and, through its `PROCESS`, by the launcher's hidden subcommand of the same
//! name; each file also holds the [`crate::registry`] rows of the data sets it replays.

pub mod mrclam;
pub mod recording;
pub mod victoria_park;
