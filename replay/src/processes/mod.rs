//! The replay processes. Each is `Args` (its flags) plus `run(args)`, called by its own
//! binary and by the launcher's hidden subcommand of the same name.

pub mod mrclam;
pub mod recording;
pub mod victoria_park;
