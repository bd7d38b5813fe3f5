//! The simulated world and its sensors.
//!
//! A scenario file describes the world (point landmarks, poles, walls), the vehicle and
//! its route, and the sensors' rates and noise. Three processes share this library:
//! - `truth-sim` drives the vehicle along the route and publishes ground truth (and the
//!   true landmark map);
//! - `odometry-sim` turns ground truth into noisy odometry;
//! - `lidar-sim` turns ground truth into raw scans ray-cast against the world's walls and
//!   poles or, for worlds of point landmarks, noisy range–bearing landmark observations.
//!
//! [`offline`] runs the three in one loop without IPC, message for message, for in-process
//! runs of the estimator (Monte Carlo comparisons).
//!
//! The vehicle kinematics here are the *world's*, written independently of the
//! estimator's motion models, so a mistake in one is not hidden by the other.

pub mod args;
pub mod ground_truth;
pub mod landmark_sensor;
pub mod lidar_sensor;
pub mod odometry_sensor;
pub mod offline;
pub mod processes;
pub mod relay;
pub mod scenario;
pub mod vehicle;

pub use scenario::Scenario;
