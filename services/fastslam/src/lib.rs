//! The FastSLAM service: subscribes to odometry and landmark observations, runs the
//! estimator of `fastslam-estimation` on them in stamp order, and publishes the pose
//! estimate after every observation step and the best particle's landmark map.
//!
//! The pieces read top to bottom: [`config`] (what to run), [`sequencer`] (inputs of
//! any number of streams in stamp order, deterministic whatever the scheduling), [`slam`] (inputs
//! to filter calls, filter results to messages), [`process`] (flags and set-up) with
//! `service` (the wake loop, stage by stage), `inputs` (the subscribers) and `outputs`
//! (the publishers). Around them: [`per_stream`] (a value per input stream), [`admit`]
//! (input checks with their per-stream state), [`health`] (rejection counters, their
//! rate-limited log, the status) and [`deadline`] (sensors that went quiet); [`persist`]
//! with [`checkpoint`] ([`state`]: the estimator's part) and [`map_file`] keep the state
//! across runs; [`memory`] checks the filter's estimated memory before it is built.

pub mod admit;
pub mod checkpoint;
pub mod config;
pub mod deadline;
pub mod estimator;
pub mod grid_slam;
pub mod health;
mod inputs;
pub mod landmark_slam;
pub mod loop_closing;
pub mod map_file;
pub mod memory;
mod outputs;
pub mod per_stream;
pub mod persist;
pub mod process;
pub mod sequencer;
mod service;
pub mod slam;
pub mod smoothing;
pub mod state;
