//! Grid FastSLAM as the service runs it (`[map] kind = "grid"`): the filter as the front
//! end, and, with `[loop_closure] enabled`, the loop-closing back-end behind it
//! ([`LoopClosing`]), whose correction moves what is published — the pose, the cloud —
//! into the map frame, and whose keyframes make the published grid.

use crate::config::ServiceConfig;
use crate::loop_closing::LoopClosing;
use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::PoseEstimate;
use fastslam_estimation::graph::Solution;
use fastslam_estimation::grid::{GridConfig, OccupancyGrid};
use fastslam_estimation::gridslam::{GridFastSlam, GridStep};
use fastslam_estimation::loop_closure::Keyframe;
use fastslam_estimation::motion::Control;
use fastslam_estimation::moves::MoveStats;
use fastslam_estimation::scan::{Beam, RangeScan};
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
}

impl GridSlam {
    /// The filter as `config` sets it up; the back-end starts with
    /// [`start_back_end`](Self::start_back_end).
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
        })
    }

    /// Starts the loop-closing back-end when `[loop_closure] enabled`.
    ///
    /// # Errors
    /// When its configuration is invalid or its thread cannot start.
    pub fn start_back_end(&mut self, config: &ServiceConfig) -> anyhow::Result<()> {
        if config.loop_closure.enabled {
            self.back_end = Some(LoopClosing::start(config.loop_closure.clone())?);
        }
        Ok(())
    }

    /// Moves the particles by `control` over `dt` (s).
    ///
    /// # Errors
    /// As [`GridFastSlam::predict`].
    pub fn predict(&mut self, control: &Control, dt: f64) -> fastslam_estimation::Result<()> {
        self.filter.predict(control, dt)
    }

    /// One scan stamped `stamp_ns` through the filter (matched and mapped when it is a
    /// keyframe) and, for a keyframe, to the back-end; the estimate in the map frame and
    /// what the filter did.
    ///
    /// # Errors
    /// As [`GridFastSlam::observe`]; nothing reaches the back-end then.
    pub fn observe(
        &mut self,
        stamp_ns: u64,
        scan: &RangeScan<'_>,
    ) -> fastslam_estimation::Result<(PoseEstimate, GridStep)> {
        let step = self.filter.observe(scan)?;
        let estimate = self.filter.estimate();
        if self.back_end.is_none() {
            return Ok((estimate, step));
        }
        let keyframe = step.keyframe.then(|| Keyframe {
            stamp_ns,
            pose: estimate.mean,
            covariance: estimate.covariance,
            points: self.points(scan),
            beams: self.grid.kept_beams(scan),
            sensor: self.mount,
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

    /// The newest loop-closure solution not yet published, as a smoothed trajectory with
    /// a pose for every scan (`None` without a back-end or when none is new).
    pub fn smoothed(&mut self) -> Option<Solution> {
        self.back_end.as_mut().and_then(LoopClosing::latest)
    }

    /// Ends the back-end's input and waits for its last solve: the final trajectory.
    pub fn finish(&mut self) -> Option<Solution> {
        self.back_end.as_mut().and_then(LoopClosing::finish)
    }

    /// The map: rendered from the keyframes at their optimised poses with a back-end,
    /// else the best particle's grid; `None` before the first scan.
    pub fn occupancy(&mut self) -> Option<OccupancyGrid> {
        match &mut self.back_end {
            Some(back_end) => back_end.render(&self.grid),
            None => self.filter.occupancy(),
        }
    }

    /// Each particle's pose (its prediction `x̂`, in the map frame) and normalised weight.
    pub fn cloud(&self) -> impl Iterator<Item = (Pose2, f64)> + '_ {
        let correction = self.back_end.as_ref().map(LoopClosing::correction);
        let particles = self.filter.particles().iter();
        particles
            .zip(self.filter.weights().as_slice())
            .map(move |(p, &w)| {
                let pose = correction.map_or(p.predicted, |c| c.compose(&p.predicted));
                (pose, w)
            })
    }

    /// Number of particles.
    pub fn particles(&self) -> usize {
        self.filter.particles().len()
    }

    /// What the scan matcher did so far (`None` without an optimiser).
    pub fn move_stats(&self) -> Option<MoveStats> {
        self.filter.move_stats()
    }

    /// The particles' grids in memory (bytes; shared tiles once).
    pub fn grid_bytes(&self) -> usize {
        self.filter.grid_bytes()
    }
}

/// The rotation of `(x, y)` by `theta`, heading unchanged.
fn rotation(theta: f64) -> Matrix3<f64> {
    let (s, c) = theta.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}
