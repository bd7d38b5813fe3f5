//! The metrics client: records what the stack publishes — ground truth, odometry, pose
//! estimates, maps, occupancy grids, the service's status — and scores the estimates
//! against the truth. Accuracy numbers come from what crossed IPC, never from the
//! service's opinion of itself; filter health and step time are the service's own
//! account (its status topic) and are reported as such. The run folder (files,
//! pictures) is described in `METRICS.md`.

pub mod account;
pub mod align;
pub mod expect;
pub mod foxglove_log;
pub mod inputs;
pub mod journal;
pub mod json_number;
pub mod latency;
pub mod lidar_count;
pub mod mcap;
pub mod metrics;
pub mod metrics_json;
pub mod occupancy;
pub mod plot;
pub mod process;
pub mod progress;
pub mod recording;
pub mod reference;
pub mod relations;
pub mod report;
pub mod resources;
pub mod rpe;
pub mod scoring;
pub mod stats;
pub mod timeline;
pub mod viewer;
pub mod warnings;

pub use metrics::Metrics;
pub use recording::Recording;
