//! Replay publishers: recorded data sets published with the stack's message types, so the
//! service and the client run on real data exactly as on a live robot.
//!
//! The pieces read top to bottom: [`text`] (the data files, plain or gzipped, every error
//! with file and line), [`dataset`] (the messages a data set becomes, and the conventions
//! for stamps, odometry intervals and dead reckoning), one reader per data set
//! ([`mrclam`], [`victoria_park`], [`carmen`] for the CARMEN logs of the Freiburg
//! benchmark, [`rosbag`] for ROS 2 bags: which file or topic becomes which message, in
//! which frame), [`recording`] (a user's own bag or log, read by its format, and the
//! settings derived from its laser),
//! [`profile`] (sensor description and filter settings per data set), [`player`]
//! (publishing in stamp order, real time or as fast as possible), the [`processes`] and
//! the [`registry`] of data sets (each one's `replay` subcommand, profile, process and
//! in-process reader), which the launcher reads.

pub mod args;
pub mod carmen;
pub mod dataset;
pub mod laser_odometry;
pub mod mrclam;
pub mod player;
pub mod processes;
pub mod profile;
pub mod recording;
pub mod registry;
pub mod rosbag;
pub mod text;
pub mod victoria_park;
