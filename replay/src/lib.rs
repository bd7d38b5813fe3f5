//! Replay publishers: recorded data sets published with the stack's message types, so the
//! service and the client run on real data exactly as on a live robot.
//!
//! The pieces read top to bottom: [`text`] (the data files, plain or gzipped, every error
//! with file and line), [`dataset`] (the messages a data set becomes, and the conventions
//! for stamps, odometry intervals and dead reckoning), one reader per data set
//! ([`mrclam`], [`victoria_park`]: which file becomes which message, in which frame),
//! [`profile`] (sensor description and filter settings per data set), [`player`]
//! (publishing in stamp order, real time or as fast as possible) and the [`processes`].

pub mod args;
pub mod dataset;
pub mod mrclam;
pub mod player;
pub mod processes;
pub mod profile;
pub mod text;
pub mod victoria_park;
