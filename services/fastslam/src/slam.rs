//! Turns stamp-ordered inputs into estimator calls, and the estimator's results into
//! messages: odometry becomes controls (velocities, or pose increments under the
//! increment motion model, with coasting through odometry gaps), and every control and
//! scan goes to the [`Estimator`] the configuration names — landmark FastSLAM
//! ([`LandmarkSlam`]) or grid FastSLAM ([`GridSlam`]). No IPC here, so it is testable on
//! its own.

use crate::config::{MapKind, ServiceConfig};
use crate::estimator::Estimator;
pub use crate::estimator::{PoseSink, Step};
use crate::grid_slam::GridSlam;
use crate::landmark_slam::LandmarkSlam;
use crate::sequencer::Input;
use crate::smoothing::TornSolves;
use crate::state::EstimatorState;
use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::{self, FastSlam};
use fastslam_estimation::graph::{Feed, Solution, VarianceComponents};
use fastslam_estimation::motion::Control;
use fastslam_estimation::moves::MoveStats;
use fastslam_estimation::scan::RangeScan;
use fastslam_protocol::{
    Header, LandmarkMapHeader, LaserScanHeader, MapLandmark, ObservationsHeader,
    OccupancyGridHeader, Particle, ParticlesHeader, TrajectoryHeader, TrajectoryPose,
};
use nalgebra::{Matrix2, Vector2};

/// The estimator and the service's odometry bookkeeping around it.
#[derive(Debug)]
pub struct Slam {
    estimator: Box<dyn Estimator>,
    /// The motion model is driven by the odometry's pose increments.
    increments: bool,
    last_odometry_ns: Option<u64>,
    /// The last odometry's pose in the odometry frame: the increment model's start.
    last_odometry_pose: Option<Pose2>,
    /// The last odometry's control, for coasting.
    last_control: Option<Control>,
    /// Odometry is quiet: scans first predict with the last control (see
    /// [`Slam::set_coasting`]).
    coasting: bool,
}

/// A smoothing back-end's solution as messages: the trajectory and the map.
#[derive(Debug, Clone, PartialEq)]
pub struct Smoothed {
    /// `smoothed/trajectory`'s header and poses.
    pub trajectory: (TrajectoryHeader, Vec<TrajectoryPose>),
    /// `smoothed/map`'s header and landmarks (marginal covariances).
    pub map: (LandmarkMapHeader, Vec<MapLandmark>),
}

impl Smoothed {
    /// `solution` as messages under `header`.
    pub fn of(solution: &Solution, header: Header) -> Self {
        let poses: Vec<TrajectoryPose> = (solution.poses.iter())
            .map(|&(stamp_ns, p)| TrajectoryPose {
                stamp_ns,
                x: p.x,
                y: p.y,
                theta: p.theta,
            })
            .collect();
        let map: Vec<MapLandmark> = (solution.landmarks.iter())
            .map(|&(id, at, cov)| MapLandmark {
                id,
                x: at.x,
                y: at.y,
                cov_xx: cov[(0, 0)],
                cov_xy: cov[(0, 1)],
                cov_yy: cov[(1, 1)],
                observations: 0,
            })
            .collect();
        Self {
            trajectory: (
                TrajectoryHeader {
                    header,
                    count: u32::try_from(poses.len()).unwrap_or(u32::MAX),
                    solves: solution.solves,
                    chi2_per_dof: solution.fit.chi2_per_dof,
                },
                poses,
            ),
            map: (
                LandmarkMapHeader {
                    header,
                    count: u32::try_from(map.len()).unwrap_or(u32::MAX),
                    reserved: 0,
                },
                map,
            ),
        }
    }
}

impl Slam {
    /// The estimator `config` names ([`ServiceConfig::filter_config`]), starting at the
    /// map origin (the map frame is the start pose).
    ///
    /// # Errors
    /// When the filter, optimiser or move configuration is invalid.
    pub fn new(config: &ServiceConfig) -> fastslam_estimation::Result<Self> {
        let estimator: Box<dyn Estimator> = match config.map.kind {
            MapKind::Landmarks => {
                let filter = FastSlam::new(config.filter_config(), Pose2::default())?;
                Box::new(LandmarkSlam::new(config, filter)?)
            }
            MapKind::Grid => Box::new(GridSlam::new(config)?),
        };
        Ok(Self::around(config, estimator))
    }

    /// The landmark filter, every particle starting with `map` (a saved map, in the frame
    /// of the run that made it: the start pose is its origin).
    ///
    /// # Errors
    /// As [`new`](Self::new), and when a landmark is not finite, has a covariance that is
    /// not symmetric positive definite, or repeats an id.
    pub fn with_map(
        config: &ServiceConfig,
        map: &[MapLandmark],
    ) -> fastslam_estimation::Result<Self> {
        let prior: Vec<fastslam::MapLandmark> = map
            .iter()
            .map(|l| fastslam::MapLandmark {
                id: l.id,
                mean: Vector2::new(l.x, l.y),
                covariance: Matrix2::new(l.cov_xx, l.cov_xy, l.cov_xy, l.cov_yy),
                hits: u32::try_from(l.observations).unwrap_or(u32::MAX),
            })
            .collect();
        let filter = FastSlam::with_prior_map(config.filter_config(), Pose2::default(), &prior)?;
        Ok(Self::around(
            config,
            Box::new(LandmarkSlam::new(config, filter)?),
        ))
    }

    /// The filter continuing from `state`, the last odometry being at `last_odometry_ns`
    /// with pose `last_odometry_pose` (a checkpoint's contents).
    ///
    /// # Errors
    /// As [`new`](Self::new), and when the state does not fit the configuration (another
    /// map kind, particle count or grid resolution).
    pub fn resume(
        config: &ServiceConfig,
        state: &EstimatorState,
        last_odometry_ns: Option<u64>,
        last_odometry_pose: Option<Pose2>,
    ) -> fastslam_estimation::Result<Self> {
        let estimator: Box<dyn Estimator> = match (state, config.map.kind) {
            (EstimatorState::Landmarks(state), MapKind::Landmarks) => {
                let filter = FastSlam::from_state(config.filter_config(), state)?;
                Box::new(LandmarkSlam::new(config, filter)?)
            }
            (EstimatorState::Grid(state), MapKind::Grid) => {
                Box::new(GridSlam::resume(config, state)?)
            }
            (_, kind) => {
                return Err(fastslam_estimation::Error::InvalidInput {
                    what: "checkpoint",
                    reason: format!(
                        "written for another [map] kind than this run's \"{}\"",
                        kind.name()
                    ),
                });
            }
        };
        let mut slam = Self::around(config, estimator);
        slam.last_odometry_ns = last_odometry_ns;
        slam.last_odometry_pose = last_odometry_pose;
        Ok(slam)
    }

    /// The service's bookkeeping around `estimator`.
    fn around(config: &ServiceConfig, estimator: Box<dyn Estimator>) -> Self {
        Self {
            estimator,
            increments: config.filter.motion.uses_increments(),
            last_odometry_ns: None,
            last_odometry_pose: None,
            last_control: None,
            coasting: false,
        }
    }

    /// Starts the estimator's back-end the configuration asks for — the smoothing
    /// back-end for landmarks, first fed with `feed` (a resumed run's inputs so far, from
    /// its checkpoint), or the loop-closing back-end for grid maps.
    ///
    /// # Errors
    /// When the back-end's configuration is invalid or its thread cannot start.
    pub fn start_smoother(
        &mut self,
        config: &ServiceConfig,
        feed: Vec<Feed>,
    ) -> anyhow::Result<()> {
        self.estimator.start_back_end(config, feed)
    }

    /// Hands the back-end what the filter applied since the last call (one message; the
    /// service calls it once per wake-up, after the pose went out).
    pub fn flush_smoother(&mut self) {
        self.estimator.flush_back_end();
    }

    /// The newest smoothed solution finished since the last call (`None` without a
    /// back-end or when none is new).
    pub fn smoothed(&mut self) -> Option<Solution> {
        self.estimator.smoothed()
    }

    /// Ends the back-end's input and waits for its last solve: the newest solution not
    /// yet taken.
    pub fn finish_smoothing(&mut self) -> Option<Solution> {
        self.estimator.finish_back_end()
    }

    /// The back-end's solves withheld as torn so far.
    pub fn torn_solves(&self) -> TornSolves {
        self.estimator.torn_solves()
    }

    /// The variance components of the back-end's newest whole solve, as far as it
    /// reported (`None` without a back-end or before its first whole solve).
    pub fn noise_components(&self) -> Option<VarianceComponents> {
        self.estimator.noise_components()
    }

    /// What the back-end was fed so far, for a checkpoint (empty without one).
    pub fn smoother_feed(&self) -> Vec<Feed> {
        self.estimator.back_end_feed()
    }

    /// Localisation only from now on: the map stays as it is, only the pose is estimated.
    ///
    /// # Errors
    /// When the estimator cannot hold its map fixed (a grid map).
    pub fn fix_map(&mut self) -> anyhow::Result<()> {
        self.estimator.fix_map()
    }

    /// The noise profile beside the fitted noise (`None` for an estimator without a fit).
    pub fn noise(&self) -> Option<fastslam::NoiseReport> {
        self.estimator.noise()
    }

    /// The filter's state, for a checkpoint.
    pub fn state(&self) -> EstimatorState {
        self.estimator.state()
    }

    /// Stamp of the odometry the filter last predicted to (ns), for a checkpoint.
    pub fn last_odometry_ns(&self) -> Option<u64> {
        self.last_odometry_ns
    }

    /// Pose of the odometry the filter last predicted to (odometry frame), for a
    /// checkpoint.
    pub fn last_odometry_pose(&self) -> Option<Pose2> {
        self.last_odometry_pose
    }

    /// Applies one input: odometry predicts over the interval since the previous odometry
    /// (with the velocities it reports, or with its pose increment under the increment
    /// motion model); a scan updates, hands its pose to `publish` as soon as it is known,
    /// and yields a [`Step`].
    ///
    /// # Errors
    /// The filter's error (bad input, degenerate weights); the filter is then unchanged,
    /// nothing is published, and the service carries on with the next input.
    pub fn apply(
        &mut self,
        input: &Input,
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Option<Step>> {
        match input {
            Input::Odometry(m) => {
                let now = m.header.stamp_ns;
                let pose = Pose2::new(m.x, m.y, m.theta);
                let previous_pose = self.last_odometry_pose.replace(pose);
                if let Some(previous) = self.last_odometry_ns.replace(now) {
                    let control = match previous_pose {
                        Some(from) if self.increments => {
                            Control::between_poses(&from, &pose, m.v, m.omega)
                        }
                        _ => Control {
                            v: m.v,
                            omega: m.omega,
                            steering: m.steering,
                            ..Control::ZERO
                        },
                    };
                    self.predict(&control, previous, now)?;
                    self.last_control = Some(control);
                }
                Ok(None)
            }
            Input::Scan(scan) => self.observe(&scan.header, &scan.items, publish).map(Some),
            Input::RawScan(raw) => self.observe_raw(&raw.header, &raw.items, publish).map(Some),
        }
    }

    /// One observation step on a scan's observations, read straight from the message (a
    /// slice of shared memory, or a sequenced copy).
    ///
    /// # Errors
    /// As [`Slam::apply`].
    pub fn observe(
        &mut self,
        header: &ObservationsHeader,
        observations: &[fastslam_protocol::Observation],
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        self.coast_to(header.header.stamp_ns)?;
        self.estimator.observe(header, observations, publish)
    }

    /// One observation step on a raw scan, its ranges read straight from the message (a
    /// slice of shared memory, or a sequenced copy).
    ///
    /// # Errors
    /// As [`Slam::apply`].
    pub fn observe_raw(
        &mut self,
        h: &LaserScanHeader,
        ranges: &[f32],
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        self.coast_to(h.header.stamp_ns)?;
        let scan = RangeScan {
            angle_min: h.angle_min.into(),
            angle_increment: h.angle_increment.into(),
            range_min: h.range_min.into(),
            range_max: h.range_max.into(),
            ranges,
        };
        self.estimator.observe_raw(h, &scan, publish)
    }

    /// Odometry went quiet (`true`) or is back: while quiet, every scan first predicts
    /// from the last odometry (or coasted) stamp to its own with the last control, so the
    /// estimate keeps moving as the vehicle did (constant velocity); the odometry that
    /// returns then predicts only from there.
    pub fn set_coasting(&mut self, on: bool) {
        self.coasting = on;
    }

    /// While coasting, predicts up to `stamp_ns` with the last control (a velocity model
    /// only: odometry that reports poses carries the whole motion of a gap in the
    /// increment of the message that ends it, so nothing is guessed).
    fn coast_to(&mut self, stamp_ns: u64) -> fastslam_estimation::Result<()> {
        if !self.coasting || self.increments {
            return Ok(());
        }
        if let (Some(previous), Some(control)) = (self.last_odometry_ns, self.last_control)
            && self.predict(&control, previous, stamp_ns)?
        {
            self.last_odometry_ns = Some(stamp_ns);
        }
        Ok(())
    }

    /// Predicts with `control` from stamp `from` to `to` (ns); false when `to` is not
    /// later (nothing to predict).
    fn predict(
        &mut self,
        control: &Control,
        from: u64,
        to: u64,
    ) -> fastslam_estimation::Result<bool> {
        let later = to > from;
        if later {
            self.estimator.predict(control, from, to)?;
        }
        Ok(later)
    }

    /// The occupancy grid to publish — grid FastSLAM's (the loop-closing back-end's
    /// rendered map, or the best particle's grid), or the landmark filter's best
    /// particle's, rebuilt from its trajectory and the kept raw scans; `None` before the
    /// first raw scan.
    pub fn grid(&mut self, header: Header) -> Option<(OccupancyGridHeader, Vec<i8>)> {
        let grid = self.estimator.occupancy()?;
        let h = OccupancyGridHeader {
            header,
            resolution: grid.resolution,
            origin_x: grid.origin[0],
            origin_y: grid.origin[1],
            origin_theta: 0.0,
            width: u32::try_from(grid.width).unwrap_or(u32::MAX),
            height: u32::try_from(grid.height).unwrap_or(u32::MAX),
        };
        Some((h, grid.cells))
    }

    /// What the optimiser's moves did so far (`None` without an optimiser).
    pub fn move_stats(&self) -> Option<MoveStats> {
        self.estimator.move_stats()
    }

    /// Number of particles.
    pub fn particles(&self) -> usize {
        self.estimator.particles()
    }

    /// The particle cloud as it stands after the last step, as a message: each particle's
    /// pose (grid FastSLAM's: its prediction `x̂`) and normalised weight.
    pub fn cloud(&self, header: Header) -> (ParticlesHeader, Vec<Particle>) {
        let particles = self.estimator.cloud();
        let h = ParticlesHeader {
            header,
            count: particles.len() as u32,
            reserved: 0,
        };
        (h, particles)
    }

    /// Grid FastSLAM's particle grids in memory (bytes; shared tiles once), `None` for the
    /// landmark filter.
    pub fn grid_bytes(&self) -> Option<usize> {
        self.estimator.grid_bytes()
    }

    /// Landmarks in the published map (the best particle's, provisional ones left out).
    pub fn landmarks(&self) -> usize {
        self.estimator.landmarks()
    }

    /// The best particle's map as a message.
    pub fn map(&self, header: Header) -> (LandmarkMapHeader, Vec<MapLandmark>) {
        let map = self.estimator.map();
        (
            LandmarkMapHeader {
                header,
                count: map.len() as u32,
                reserved: 0,
            },
            map,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequencer::{RawScan, Scan};
    use fastslam_protocol::Odometry;
    use std::f64::consts::{PI, TAU};

    fn odometry(t_ns: u64, v: f64) -> Input {
        Input::Odometry(Odometry {
            header: Header {
                stamp_ns: t_ns,
                seq: 0,
            },
            v,
            ..Default::default()
        })
    }

    /// A scan at 2 s with no landmarks, after odometry at 2 m/s up to 1 s.
    fn pose_after_a_gap(coasting: bool) -> f64 {
        let mut config = ServiceConfig::default();
        config.filter.particles = 20;
        // Publish a landmark from its first sighting (no provisional period).
        config.filter.negative_evidence.min_hits = 0;
        let mut slam = Slam::new(&config).unwrap();
        for k in 0..=40 {
            slam.apply(&odometry(k * 25_000_000, 2.0), &mut |_| {})
                .unwrap();
        }
        slam.set_coasting(coasting);
        let header = ObservationsHeader {
            header: Header {
                stamp_ns: 2_000_000_000,
                seq: 0,
            },
            max_range: 30.0,
            min_bearing: -1.6,
            max_bearing: 1.6,
            ..Default::default()
        };
        let scan = Input::Scan(Scan {
            header,
            items: Vec::new(),
        });
        slam.apply(&scan, &mut |_| {}).unwrap().unwrap().pose.x
    }

    #[test]
    fn coasting_keeps_moving_through_an_odometry_gap() {
        let (still, coasted) = (pose_after_a_gap(false), pose_after_a_gap(true));
        assert!((still - 2.0).abs() < 0.5, "no prediction past 1 s: {still}");
        assert!((coasted - 4.0).abs() < 0.5, "2 m/s for 2 s: {coasted}");
    }

    #[test]
    fn odometry_then_a_scan_moves_the_estimate_and_maps_the_landmark() {
        let mut config = ServiceConfig::default();
        config.filter.particles = 20;
        // Publish a landmark from its first sighting (no provisional period).
        config.filter.negative_evidence.min_hits = 0;
        let mut slam = Slam::new(&config).unwrap();
        assert_eq!(slam.apply(&odometry(0, 0.0), &mut |_| {}).unwrap(), None);
        for k in 1..=40 {
            assert_eq!(
                slam.apply(&odometry(k * 25_000_000, 2.0), &mut |_| {})
                    .unwrap(),
                None
            );
        }
        let header = ObservationsHeader {
            header: Header {
                stamp_ns: 1_000_000_000,
                seq: 0,
            },
            count: 1,
            max_range: 30.0,
            min_bearing: -1.6,
            max_bearing: 1.6,
            ..Default::default()
        };
        let obs = fastslam_protocol::Observation {
            range: 8.0,
            bearing: 0.0,
            diameter: 0.0,
            id: -1,
        };
        let mut published = Vec::new();
        let step = slam
            .apply(
                &Input::Scan(Scan {
                    header,
                    items: vec![obs],
                }),
                &mut |pose| published.push(pose),
            )
            .unwrap()
            .unwrap();
        assert_eq!(published, [step.pose], "the step's pose, published once");
        assert_eq!(step.pose.header.stamp_ns, 1_000_000_000);
        assert!(
            (step.pose.x - 2.0).abs() < 0.5,
            "moved about 2 m in 1 s: {}",
            step.pose.x
        );
        let (h, map) = slam.map(step.pose.header);
        assert_eq!((h.count, map.len()), (1, 1));
        assert!(
            (map[0].x - 10.0).abs() < 1.0,
            "landmark near x = 10: {}",
            map[0].x
        );
        assert!(
            step.pose.covariance[0] > 0.0 && step.pose.covariance[1] == step.pose.covariance[3]
        );
        let (h, cloud) = slam.cloud(step.pose.header);
        assert_eq!((h.header, h.count, cloud.len()), (step.pose.header, 20, 20));
        fastslam_protocol::validate::particles(&h, &cloud).unwrap();
        let total: f64 = cloud.iter().map(|p| p.weight).sum();
        assert!((total - 1.0).abs() < 1e-9, "weights sum to {total}");
        let mean_x: f64 = cloud.iter().map(|p| p.weight * p.x).sum();
        assert!(
            (mean_x - 2.0).abs() < 0.5,
            "the cloud moved with the estimate: {mean_x}"
        );
    }

    /// Inputs `from..to` of a drive along x at 2 m/s past a row of landmarks (known ids),
    /// odometry every 25 ms and a scan every 250 ms.
    fn drive(slam: &mut Slam, steps: std::ops::Range<u64>) -> Option<Step> {
        let mut last = None;
        for k in steps {
            let t_ns = k * 25_000_000;
            slam.apply(&odometry(t_ns, 2.0), &mut |_| {}).unwrap();
            if k % 10 == 0 {
                let x = 2.0 * t_ns as f64 * 1e-9;
                let observations: Vec<fastslam_protocol::Observation> = (0..40)
                    .filter_map(|id| {
                        let (dx, dy) = (
                            f64::from(id) * 5.0 - x,
                            if id % 2 == 0 { 4.0 } else { -4.0 },
                        );
                        let range = dx.hypot(dy);
                        (range < 15.0).then_some(fastslam_protocol::Observation {
                            range,
                            bearing: dy.atan2(dx),
                            diameter: 0.0,
                            id: i64::from(id),
                        })
                    })
                    .collect();
                let header = ObservationsHeader {
                    header: Header {
                        stamp_ns: t_ns,
                        seq: k / 10,
                    },
                    count: observations.len() as u32,
                    max_range: 30.0,
                    min_bearing: -PI,
                    max_bearing: PI,
                    ..Default::default()
                };
                let scan = Input::Scan(Scan {
                    header,
                    items: observations,
                });
                last = slam.apply(&scan, &mut |_| {}).unwrap();
            }
        }
        last
    }

    #[test]
    fn a_resumed_smoother_rebuilds_the_same_graph_from_its_feed() {
        let mut config = ServiceConfig::default();
        config.filter.particles = 10;
        config.filter.association.mode = fastslam_estimation::fastslam::AssociationMode::Known;
        config.smoother.enabled = true;
        config.smoother.loop_gap_s = 1.0;
        config.smoother.min_poses_between_solves = 5;
        let mut whole = Slam::new(&config).unwrap();
        whole.start_smoother(&config, Vec::new()).unwrap();
        drive(&mut whole, 0..800);
        let expected = whole.finish_smoothing().expect("a solution");

        let mut first = Slam::new(&config).unwrap();
        first.start_smoother(&config, Vec::new()).unwrap();
        drive(&mut first, 0..400);
        let (state, feed) = (first.state(), first.smoother_feed());
        assert!(!feed.is_empty());
        let mut resumed = Slam::resume(
            &config,
            &state,
            first.last_odometry_ns(),
            first.last_odometry_pose(),
        )
        .unwrap();
        resumed.start_smoother(&config, feed).unwrap();
        drive(&mut resumed, 400..800);
        let solution = resumed.finish_smoothing().expect("a solution");
        assert_eq!(solution.poses, expected.poses);
        assert_eq!(solution.landmarks, expected.landmarks);
        assert!(expected.poses.len() > 70 && expected.landmarks.len() > 10);
        let worst = expected
            .poses
            .iter()
            .map(|(t, p)| (p.x - 2.0 * *t as f64 * 1e-9).hypot(p.y))
            .fold(0.0, f64::max);
        assert!(worst < 0.5, "smoothed drive off by {worst} m");
    }

    #[test]
    fn a_grid_map_refuses_landmarks_and_a_fixed_map_and_checkpoints_as_a_grid() {
        let mut config = ServiceConfig::default();
        config.filter.particles = 5;
        config.map.kind = MapKind::Grid;
        let mut slam = Slam::new(&config).unwrap();
        let header = ObservationsHeader::default();
        let refused = slam.observe(&header, &[], &mut |_| panic!("nothing published"));
        assert!(
            matches!(
                refused,
                Err(fastslam_estimation::Error::InvalidInput {
                    what: "observations",
                    ..
                })
            ),
            "{refused:?}"
        );
        assert!(matches!(slam.state(), EstimatorState::Grid(_)));
        let landmarks = Slam::new(&ServiceConfig::default()).unwrap().state();
        let refused = Slam::resume(&config, &landmarks, None, None).unwrap_err();
        assert!(refused.to_string().contains("[map] kind"), "{refused}");
        assert!(slam.fix_map().is_err());
        assert_eq!(slam.map(Header::default()).1, []);
        assert_eq!(slam.cloud(Header::default()).1.len(), 5);
    }

    #[test]
    fn a_raw_scan_becomes_pole_observations_and_a_grid() {
        let mut config = ServiceConfig::default();
        config.filter.particles = 10;
        // Publish a landmark from its first sighting (no provisional period).
        config.filter.negative_evidence.min_hits = 0;
        let mut slam = Slam::new(&config).unwrap();
        assert_eq!(slam.apply(&odometry(0, 0.0), &mut |_| {}).unwrap(), None);
        // A full turn of 720 beams: a pole of radius 0.2 m at (4, 0) inside a round wall
        // of radius 8 m.
        let increment = TAU / 720.0;
        let ranges: Vec<f32> = (0..720)
            .map(|i| {
                let a = -PI + i as f64 * increment;
                let across = 4.0 * a.sin();
                let hits_pole = a.cos() > 0.0 && across.abs() <= 0.2;
                let pole = 4.0 * a.cos() - (0.04 - across * across).max(0.0).sqrt();
                (if hits_pole { pole } else { 8.0 }) as f32
            })
            .collect();
        let header = LaserScanHeader {
            header: Header {
                stamp_ns: 100_000_000,
                seq: 0,
            },
            angle_min: -PI as f32,
            angle_increment: increment as f32,
            range_min: 0.1,
            range_max: 30.0,
            ranges: 720,
            ..Default::default()
        };
        let step = slam
            .apply(
                &Input::RawScan(RawScan {
                    header,
                    items: ranges,
                }),
                &mut |_| {},
            )
            .unwrap()
            .unwrap();
        assert_eq!(step.observations, 1, "one pole, no wall");
        let (_, map) = slam.map(step.pose.header);
        assert_eq!(map.len(), 1);
        assert!(
            (map[0].x - 4.0).abs() < 0.05 && map[0].y.abs() < 0.05,
            "{map:?}"
        );
        let (h, cells) = slam.grid(step.pose.header).unwrap();
        assert_eq!(cells.len(), (h.width * h.height) as usize);
        assert!(
            cells.iter().any(|&c| c > 65),
            "the wall and the pole are occupied"
        );
        assert!(
            cells.iter().any(|&c| (0..45).contains(&c)),
            "the inside is free"
        );
    }
}
