//! The one interface the service drives a filter through ([`Estimator`]): landmark
//! FastSLAM with its smoothing back-end ([`crate::landmark_slam`]) and grid FastSLAM
//! with its loop-closing back-end ([`crate::grid_slam`]). [`crate::slam::Slam`] turns
//! odometry into controls and hands every input to the estimator; nothing outside the
//! estimators asks which one runs.

use crate::config::ServiceConfig;
use crate::smoothing::TornSolves;
use crate::state::EstimatorState;
use fastslam_estimation::fastslam::{self, StepReport};
use fastslam_estimation::graph::{Feed, Solution, VarianceComponents};
use fastslam_estimation::grid::OccupancyGrid;
use fastslam_estimation::motion::Control;
use fastslam_estimation::moves::MoveStats;
use fastslam_estimation::scan::RangeScan;
use fastslam_protocol::{
    Header, LaserScanHeader, MapLandmark, Observation, ObservationsHeader, Particle, PoseEstimate,
};

/// Where an observation step sends its pose the moment the filter has it, before the
/// maps are updated; the service publishes it.
pub type PoseSink<'a> = &'a mut dyn FnMut(PoseEstimate);

/// What an observation step produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The pose estimate, stamped with the scan's stamp (`seq` left to the publisher).
    pub pose: PoseEstimate,
    /// The filter's account of the step.
    pub report: StepReport,
    /// Observations the step used (extracted poles for a raw scan).
    pub observations: usize,
}

/// A filter as the service runs it: predicted by controls, updated by scans, with its
/// map outputs and its back-end.
pub trait Estimator: std::fmt::Debug + Send {
    /// Moves the estimate by `control` over the interval from stamp `from_ns` to `to_ns`
    /// (ns, `to_ns` later).
    ///
    /// # Errors
    /// The filter's error for a control it cannot use; the filter is then unchanged.
    fn predict(
        &mut self,
        control: &Control,
        from_ns: u64,
        to_ns: u64,
    ) -> fastslam_estimation::Result<()>;

    /// One step on a scan's landmark observations; the pose goes to `publish` as soon as
    /// it is known.
    ///
    /// # Errors
    /// Bad input, degenerate weights, or observations this estimator does not map.
    fn observe(
        &mut self,
        header: &ObservationsHeader,
        observations: &[Observation],
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step>;

    /// One step on a raw scan; the pose goes to `publish` as soon as it is known.
    ///
    /// # Errors
    /// Bad input or degenerate weights; the filter is then unchanged.
    fn observe_raw(
        &mut self,
        header: &LaserScanHeader,
        scan: &RangeScan<'_>,
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step>;

    /// Starts the back-end `config` asks for, first fed with `feed` (a resumed run's
    /// inputs so far).
    ///
    /// # Errors
    /// When the back-end's configuration is invalid or its thread cannot start.
    fn start_back_end(&mut self, config: &ServiceConfig, feed: Vec<Feed>) -> anyhow::Result<()>;

    /// Hands the back-end what was collected since the last call (the service calls it
    /// once per wake-up, after the pose went out).
    fn flush_back_end(&mut self) {}

    /// The back-end's newest solution not yet taken (`None` without one, or none new).
    fn smoothed(&mut self) -> Option<Solution>;

    /// Ends the back-end's input and waits for its last solve: the newest solution not
    /// yet taken.
    fn finish_back_end(&mut self) -> Option<Solution>;

    /// The back-end's solves withheld as torn (none without a back-end that gates them).
    fn torn_solves(&self) -> TornSolves {
        TornSolves::default()
    }

    /// The variance components of the back-end's newest whole solve (none without a
    /// back-end that fits them).
    fn noise_components(&self) -> Option<VarianceComponents> {
        None
    }

    /// What the back-end was fed so far, for a checkpoint (empty without one).
    fn back_end_feed(&self) -> Vec<Feed> {
        Vec::new()
    }

    /// The filter's state for a checkpoint.
    fn state(&self) -> EstimatorState;

    /// Localisation only from now on: the map stays as it is.
    ///
    /// # Errors
    /// When this estimator's map cannot be held fixed.
    fn fix_map(&mut self) -> anyhow::Result<()>;

    /// The occupancy grid to publish (`None` before the first raw scan).
    fn occupancy(&mut self) -> Option<OccupancyGrid>;

    /// The landmark map to publish (empty for a grid map).
    fn map(&self) -> Vec<MapLandmark>;

    /// Landmarks in the published map.
    fn landmarks(&self) -> usize;

    /// Each particle's pose in the map frame and its normalised weight.
    fn cloud(&self) -> Vec<Particle>;

    /// What the optimiser's moves did so far (`None` without an optimiser).
    fn move_stats(&self) -> Option<MoveStats>;

    /// Number of particles.
    fn particles(&self) -> usize;

    /// The noise profile beside the noise fitted from the innovations (`None` for an
    /// estimator without a noise fit).
    fn noise(&self) -> Option<fastslam::NoiseReport> {
        None
    }

    /// Bytes the particles' grids hold (`None` for an estimator without them).
    fn grid_bytes(&self) -> Option<usize> {
        None
    }
}

/// A filter's estimate as the `pose` message, stamped with `header` (`seq` left to the
/// publisher).
pub fn message(header: Header, estimate: &fastslam::PoseEstimate) -> PoseEstimate {
    let c = estimate.covariance;
    PoseEstimate {
        header,
        x: estimate.mean.x,
        y: estimate.mean.y,
        theta: estimate.mean.theta,
        covariance: std::array::from_fn(|k| c[(k / 3, k % 3)]),
    }
}

/// A particle of the cloud message.
pub fn particle(pose: &fastslam_estimation::Pose2, weight: f64) -> Particle {
    Particle {
        x: pose.x,
        y: pose.y,
        theta: pose.theta,
        weight,
    }
}
