//! The FastSLAM estimator as a plain library: motion and observation models, particle
//! weights and resampling, FastSLAM 1.0 and 2.0 with per-particle landmark EKFs, the
//! particle optimisers of the papers and the moves that run them inside a filter, a generic
//! particle filter with the UNGM benchmark, run statistics, landmark extraction from raw
//! scans and occupancy grid mapping. No IPC, no threads it did not ask for, no I/O — so it
//! is testable and benchmarkable on its own. See docs/ALGORITHMS.md for every formula.

mod check;
pub mod error;
pub mod fastslam;
pub mod features;
pub mod graph;
pub mod grid;
pub mod gridslam;
pub mod laser_odometry;
pub mod loop_closure;

pub mod motion;
pub mod moves;
pub mod observation;
pub mod optimise;
mod parallel;
pub mod pf;
pub mod pose;
pub mod resample;
pub mod rng;
pub mod scan;
pub mod stats;
pub mod ungm;
pub mod weights;
pub mod workload;

pub use error::{Error, Result};
pub use pose::{Pose2, wrap_angle};
