//! Grid FastSLAM as the service runs it (`[map] kind = "grid"`): the filter as the front
//! end, and, with `[loop_closure] enabled`, the loop-closing back-end behind it
//! ([`LoopClosing`]), whose correction moves what is published — the pose, the cloud —
//! into the map frame, and whose keyframes make the published grid.
//!
//! A checkpoint holds the filter's state and what the back-end was handed
//! ([`GridState`]); a resumed run restores the one and hands the other to a fresh
//! back-end again.

use crate::config::ServiceConfig;
use crate::estimator::{Estimator, PoseSink, Step, message, particle};
use crate::loop_closing::{BackEndState, LoopClosing};
use crate::state::{EstimatorState, GridState};
use anyhow::bail;
use fastslam_estimation::fastslam::{PoseEstimate, StepReport};
use fastslam_estimation::graph::{Feed, Solution};
use fastslam_estimation::grid::{GridConfig, OccupancyGrid};
use fastslam_estimation::gridslam::{GridFastSlam, GridStep};
use fastslam_estimation::loop_closure::{self, Keyframe};
use fastslam_estimation::motion::Control;
use fastslam_estimation::moves::MoveStats;
use fastslam_estimation::scan::{Beam, RangeScan};
use fastslam_estimation::{Error, Pose2};
use fastslam_protocol::{LaserScanHeader, MapLandmark, ObservationsHeader, Particle};
use nalgebra::Matrix3;

/// The grid filter, and its loop-closing back-end when one runs.
#[derive(Debug)]
pub struct GridSlam {
    filter: GridFastSlam,
    /// `[grid]` with every beam kept: the back-end's submaps and map take each beam (the
    /// filter's `beam_stride` thins only what it matches and maps per particle; submaps
    /// with gaps between beams score true matches lower).
    grid: GridConfig,
    /// The laser's pose in the base frame.
    mount: Pose2,
    /// Scan points farther than this from the base are not handed to the back-end (m).
    points_range: f64,
    back_end: Option<LoopClosing>,
    /// Resumed from a checkpoint: what its back-end was handed, for
    /// [`Estimator::start_back_end`] to hand over again.
    resumed: Option<Option<BackEndState>>,
}

impl GridSlam {
    /// The filter as `config` sets it up; the back-end starts with
    /// [`Estimator::start_back_end`].
    ///
    /// # Errors
    /// When a filter, grid, matcher or optimiser setting is invalid.
    pub fn new(config: &ServiceConfig) -> fastslam_estimation::Result<Self> {
        let mut filter = GridFastSlam::new(
            config.filter_config(),
            config.grid.clone(),
            config.map.matching.clone(),
            &config.optimizer,
            config.moves.clone(),
        )?;
        let mount = config.laser.mount();
        filter.set_laser_mount(mount);
        Ok(Self {
            filter,
            grid: GridConfig {
                beam_stride: 1,
                ..config.grid.clone()
            },
            mount,
            points_range: config.loop_closure.max_range,
            back_end: None,
            resumed: None,
        })
    }

    /// The filter `config` sets up, continuing from `state` (a checkpoint's); its
    /// back-end is handed what it was when it starts.
    ///
    /// # Errors
    /// As [`new`](Self::new), and when the state does not fit the configuration.
    pub fn resume(config: &ServiceConfig, state: &GridState) -> fastslam_estimation::Result<Self> {
        let mut slam = Self::new(config)?;
        slam.filter.restore(&state.filter)?;
        slam.resumed = Some(state.back_end.clone());
        Ok(slam)
    }

    /// One scan stamped `stamp_ns` through the filter (matched and mapped when it is a
    /// keyframe) and, for a keyframe, to the back-end; the estimate in the map frame and
    /// what the filter did.
    ///
    /// # Errors
    /// As [`GridFastSlam::observe`]; nothing reaches the back-end then.
    fn step(
        &mut self,
        stamp_ns: u64,
        scan: &RangeScan<'_>,
    ) -> fastslam_estimation::Result<(PoseEstimate, GridStep)> {
        // The odometry's account of the stretch, which matching the scan replaces.
        let odometry = self.back_end.is_some().then(|| loop_closure::Odometry {
            predicted: self.filter.estimate().mean,
            covariance: self.filter.motion_prior(),
        });
        let step = self.filter.observe(scan)?;
        let estimate = self.filter.estimate();
        let Some(odometry) = odometry else {
            return Ok((estimate, step));
        };
        let keyframe = step.keyframe.then(|| Keyframe {
            stamp_ns,
            pose: estimate.mean,
            covariance: estimate.covariance,
            points: self.points(scan),
            beams: self.grid.kept_beams(scan),
            sensor: self.mount,
            odometry: Some(odometry),
        });
        let back_end = self.back_end.as_mut().expect("checked above");
        let mean = back_end.scan(stamp_ns, estimate.mean, keyframe);
        let turn = rotation(back_end.correction().theta);
        let covariance = turn * estimate.covariance * turn.transpose();
        Ok((PoseEstimate { mean, covariance }, step))
    }

    /// The scan's returns within `points_range` of the base, in the base frame (m).
    fn points(&self, scan: &RangeScan<'_>) -> Vec<[f64; 2]> {
        (0..scan.len())
            .filter_map(|i| match scan.beam(i) {
                Beam::Hit(r) => {
                    let a = scan.angle(i);
                    let [x, y] = self.mount.transform_point([r * a.cos(), r * a.sin()]);
                    (x.hypot(y) <= self.points_range).then_some([x, y])
                }
                Beam::NoReturn | Beam::Invalid => None,
            })
            .collect()
    }
}

impl Estimator for GridSlam {
    fn predict(
        &mut self,
        control: &Control,
        from_ns: u64,
        to_ns: u64,
    ) -> fastslam_estimation::Result<()> {
        let dt = to_ns.saturating_sub(from_ns) as f64 * 1e-9;
        self.filter.predict(control, dt)
    }

    /// Refused: a grid is mapped from raw scans.
    fn observe(
        &mut self,
        _header: &ObservationsHeader,
        _observations: &[fastslam_protocol::Observation],
        _publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        Err(Error::InvalidInput {
            what: "observations",
            reason: "[map] kind = \"grid\" maps raw scans (topic `scan`), not landmark \
                     observations"
                .into(),
        })
    }

    /// Matched and mapped when it is a keyframe; the pose (the predicted cloud's
    /// mixture, in the map frame) published either way.
    fn observe_raw(
        &mut self,
        h: &LaserScanHeader,
        scan: &RangeScan<'_>,
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        let (estimate, step) = self.step(h.header.stamp_ns, scan)?;
        let pose = message(h.header, &estimate);
        publish(pose);
        let report = StepReport {
            neff: step.ess,
            resampled: step.resampled,
            distinct: step.distinct,
            matched: 0,
            new_landmarks: 0,
            ignored: 0,
            removed: 0,
            rejected: 0,
            innovations: Default::default(),
        };
        Ok(Step {
            pose,
            report,
            observations: 0,
        })
    }

    /// The loop-closing back-end, when `[loop_closure] enabled`, handed again what it
    /// was in a resumed run; the smoothing back-end needs landmarks and stays off.
    fn start_back_end(&mut self, config: &ServiceConfig, _feed: Vec<Feed>) -> anyhow::Result<()> {
        if config.smoother.enabled {
            tracing::warn!(
                "the smoothing back-end needs landmarks: with [map] kind = \"grid\" \
                 [loop_closure] is the back-end"
            );
        }
        let enabled = config.loop_closure.enabled;
        let replay = match self.resumed.take() {
            Some(back_end) if back_end.is_some() != enabled => bail!(
                "the checkpoint was written {} a loop-closing back-end, this run has \
                 [loop_closure] enabled = {enabled}",
                if enabled { "without" } else { "with" }
            ),
            Some(back_end) => back_end,
            None => None,
        };
        if enabled {
            let mut back_end =
                LoopClosing::start(config.loop_closure.clone(), config.filter.motion.clone())?;
            if let Some(state) = &replay {
                back_end.replay(state)?;
            }
            self.back_end = Some(back_end);
        }
        Ok(())
    }

    /// The newest loop-closure solution not yet published, as a smoothed trajectory with
    /// a pose for every scan.
    fn smoothed(&mut self) -> Option<Solution> {
        self.back_end.as_mut().and_then(LoopClosing::latest)
    }

    fn finish_back_end(&mut self) -> Option<Solution> {
        self.back_end.as_mut().and_then(LoopClosing::finish)
    }

    fn state(&self) -> EstimatorState {
        EstimatorState::Grid(Box::new(GridState {
            filter: self.filter.state(),
            back_end: self.back_end.as_ref().map(LoopClosing::state),
        }))
    }

    fn fix_map(&mut self) -> anyhow::Result<()> {
        anyhow::bail!("[map] kind = \"grid\" cannot hold its map fixed")
    }

    /// Rendered from the keyframes at their optimised poses with a back-end, else the
    /// best particle's grid.
    fn occupancy(&mut self) -> Option<OccupancyGrid> {
        match &mut self.back_end {
            Some(back_end) => back_end.render(&self.grid),
            None => self.filter.occupancy(),
        }
    }

    /// Empty: the map is the grid.
    fn map(&self) -> Vec<MapLandmark> {
        Vec::new()
    }

    fn landmarks(&self) -> usize {
        0
    }

    /// Each particle's prediction `x̂`, moved into the map frame.
    fn cloud(&self) -> Vec<Particle> {
        let correction = self.back_end.as_ref().map(LoopClosing::correction);
        let weights = self.filter.weights().as_slice();
        (self.filter.particles().iter().zip(weights))
            .map(|(p, &w)| {
                let pose = correction.map_or(p.predicted, |c| c.compose(&p.predicted));
                particle(&pose, w)
            })
            .collect()
    }

    fn move_stats(&self) -> Option<MoveStats> {
        self.filter.move_stats()
    }

    fn particles(&self) -> usize {
        self.filter.particles().len()
    }

    fn grid_bytes(&self) -> Option<usize> {
        Some(self.filter.grid_bytes())
    }
}

/// The rotation of `(x, y)` by `theta`, heading unchanged.
fn rotation(theta: f64) -> Matrix3<f64> {
    let (s, c) = theta.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}
