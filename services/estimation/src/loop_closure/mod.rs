//! Loop closure for grid SLAM (docs/ALGORITHMS.md §9.1): a pose-graph back-end fed with
//! the front end's keyframes, which finds where the robot has been before by matching
//! scans against submaps, and optimises every keyframe pose with those matches.
//!
//! - **Keyframes** ([`Keyframe`]): the front end's pose, the covariance of its motion
//!   since the previous keyframe, the scan's end points (base frame) and beams. Each is a
//!   pose of a [`Graph`](crate::graph::Graph), tied to the previous one by the front
//!   end's relative motion with its covariance floored.
//! - **Submaps** ([`Submap`]): `keyframes_per_submap` consecutive keyframes' beams in a
//!   local log-odds grid in the frame of the first of them, which is the submap's node in
//!   the graph. A finished submap keeps only bytes of probability and their max-pooled
//!   levels ([`MatchGrid`]).
//! - **Matching** ([`MatchGrid::match_scan`]): a keyframe's scan against every finished
//!   submap nearby, by branch and bound over `(x, y, θ)` in a window of `3σ` of the
//!   uncertainty accumulated along the keyframes ([`SearchWindow`]), then refined off the
//!   lattice. A match scoring at least `min_score` becomes a loop-closure constraint from
//!   the submap's first keyframe to the keyframe ([`LoopClosure`]).
//! - **Solving** ([`PoseGraphMapper::solve`]): Levenberg–Marquardt with the loop closures
//!   reweighted outside the solver (Cauchy on their χ²) and gated; the result is every
//!   keyframe's pose and the correction `optimised ∘ front-end⁻¹` of the newest keyframe
//!   (map → front-end map).
//! - **The last solve** ([`PoseGraphMapper::finish`]): at the end of the data the
//!   odometry constraints are weighted by their variance factor against the other
//!   constraints' ([`PoseGraphMapper::fit_odometry_weight`]) before the graph is solved
//!   a last time.
//! - **Gauge** ([`local_gauge`]): the rigid motion that puts a solve's keyframes near the
//!   robot where their poses were published, so that the real-time pose of a place
//!   revisited is where it was published before.
//! - **Map** ([`PoseGraphMapper::render`]): every keyframe's beams at its optimised pose,
//!   moved by the gauge.
//! - **Trajectory** ([`place_scans`]): every scan between two optimised keyframes,
//!   carrying the share of their correction that the odometry noise up to it holds.
//!
//! A caller adds keyframes ([`PoseGraphMapper::add_keyframe`]), solves when
//! [`PoseGraphMapper::solve_due`] says so, publishes `gauge ∘ correction ∘ front-end
//! pose` as the real-time pose, renders the map when it wants one, and calls
//! [`PoseGraphMapper::finish`] when the data ends.
//!
//! # Determinism
//! Matching runs on rayon's threads one submap per task, each sequential, and the
//! results are gathered in submap order; nothing iterates a hash map. The same keyframes
//! give the same poses, bit for bit, on any number of threads.

mod config;
mod gauge;
mod mapper;
mod matcher;
#[cfg(test)]
mod odometry_weight_tests;
mod probability;
mod pyramid;
mod refine;
mod render;
mod robust;
mod search;
mod submap;
mod trajectory;

pub use config::{LoopClosureConfig, MAX_DEPTH};
pub use gauge::local_gauge;
pub use mapper::{
    Finished, Keyframe, KeyframeReport, LoopClosure, Odometry, OdometryFit, OdometryWeight,
    PoseGraphMapper, Solution,
};
pub use matcher::{MatchPrior, ScanMatch, SearchWindow};
pub use probability::{FULL, ProbabilityGrid};
pub use pyramid::MatchGrid;
pub use robust::{LoopEdge, WEIGHT_TOLERANCE};
pub use submap::Submap;
pub use trajectory::place_scans;
