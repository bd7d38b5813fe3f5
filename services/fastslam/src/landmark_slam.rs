//! Landmark FastSLAM as the service runs it (`[map] kind = "landmarks"`): the filter and
//! its particle optimiser, poles extracted from raw scans, the occupancy grid rebuilt
//! from the best particle's keyframes, and the smoothing back-end with re-anchoring
//! (docs/ALGORITHMS.md §8.1).

use crate::config::ServiceConfig;
use crate::estimator::{Estimator, PoseSink, Step, message, particle};
use crate::smoothing::{Backend, Takes, TornSolves};
use crate::state::EstimatorState;
use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::association::AssociationMode;
use fastslam_estimation::fastslam::{Adapt, FastSlam, OptimiserRefiner, PoseRefiner, Proposal};
use fastslam_estimation::features::{ExtractorConfig, extract};
use fastslam_estimation::graph::{Feed, NoiseModel, SmootherConfig, Solution, VarianceComponents};
use fastslam_estimation::grid::{GridMapper, OccupancyGrid};
use fastslam_estimation::motion::Control;
use fastslam_estimation::moves::MoveStats;
use fastslam_estimation::observation::{Observation, Sensor};
use fastslam_estimation::scan::RangeScan;
use fastslam_protocol::{
    Header, LaserScanHeader, MapLandmark, ObservationsHeader, Particle, PoseEstimate,
};
use std::collections::VecDeque;
use std::f64::consts::TAU;

/// The landmark filter, its optimiser, and the bookkeeping around them.
#[derive(Debug)]
pub struct LandmarkSlam {
    filter: FastSlam,
    refiner: Option<OptimiserRefiner>,
    extractor: ExtractorConfig,
    mapper: GridMapper,
    /// The current scan's observations in the filter's type, reused from scan to scan so
    /// a step allocates no buffer of its own.
    observations: Vec<Observation>,
    /// The smoothing back-end, when `[smoother] enabled`.
    backend: Option<Backend>,
    /// The scans between a back-end's report and the filter taking it over (what it
    /// takes: [`Takes`]).
    handover_delay: u64,
    /// With re-anchoring: the estimates of the last scans (stamp, mean), to compare a
    /// solution's last pose with what the filter said then.
    recent: Option<VecDeque<(u64, Pose2)>>,
    /// The laser's pose in the base frame (`[laser] mount`); `None` at the origin.
    mount: Option<Pose2>,
}

impl LandmarkSlam {
    /// `filter` (fresh, from a saved map or a checkpoint) with the optimiser, extractor
    /// and grid `config` sets up.
    ///
    /// # Errors
    /// When the optimiser, move, extractor or grid configuration is invalid.
    pub fn new(config: &ServiceConfig, filter: FastSlam) -> fastslam_estimation::Result<Self> {
        config.features.validate()?;
        let mount = config.laser.mount();
        let refiner =
            OptimiserRefiner::new(&config.optimizer, config.moves.clone(), config.filter.seed)?;
        // Plain FastSLAM 1.0 never reads the motion prior: skip propagating it. An
        // optimiser in a corrected mode targets the Gaussian prior: sampling is deferred.
        let filter = if refiner.is_none() && filter.config().proposal == Proposal::Motion {
            filter.without_motion_prior()?
        } else if refiner.as_ref().is_some_and(|r| r.needs_gaussian_prior()) {
            filter.defer_sampling()?
        } else {
            filter
        };
        Ok(Self {
            filter,
            refiner,
            extractor: config.features.clone(),
            mapper: GridMapper::new(config.grid.clone())?,
            observations: Vec::new(),
            backend: None,
            handover_delay: 0,
            recent: None,
            mount: (mount != Pose2::default()).then_some(mount),
        })
    }

    /// A scan's sensor: noise from the configuration, range and field of view from the
    /// message. The filter's field of view is centred on the heading, so an asymmetric
    /// one is widened to the larger side (negative evidence then errs on the side of
    /// keeping landmarks).
    fn sensor(&self, max_range: f64, min_bearing: f64, max_bearing: f64) -> Sensor {
        let configured = &self.filter.config().sensor;
        Sensor {
            max_range,
            field_of_view: (2.0 * min_bearing.abs().max(max_bearing.abs())).min(TAU),
            ..configured.clone()
        }
    }

    fn update(
        &mut self,
        header: Header,
        observations: &[Observation],
        sensor: &Sensor,
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        let refiner = self.refiner.as_mut().map(|r| r as &mut dyn PoseRefiner);
        let mut pose = PoseEstimate::default();
        let report = self
            .filter
            .update_publishing(observations, sensor, refiner, |estimate| {
                pose = message(header, estimate);
                publish(pose);
            })?;
        if let Some(backend) = &mut self.backend {
            backend.send(Feed::Scan {
                stamp_ns: header.stamp_ns,
                sightings: self.filter.best_sightings(sensor),
            });
            let mean = Pose2::new(pose.x, pose.y, pose.theta);
            self.take_over(header.stamp_ns, mean);
        }
        Ok(Step {
            pose,
            report,
            observations: observations.len(),
        })
    }

    /// After the scan stamped `stamp_ns` whose estimate was `mean`: takes over what the
    /// back-end reported `delay` scans ago, if anything — its noise fit, then its
    /// solution (re-anchoring).
    fn take_over(&mut self, stamp_ns: u64, mean: Pose2) {
        let Some(backend) = &mut self.backend else {
            return;
        };
        let delay = self.handover_delay;
        if let Some(recent) = &mut self.recent {
            recent.push_back((stamp_ns, mean));
            while recent.len() as u64 > delay + 1 {
                recent.pop_front();
            }
        }
        let Some(handover) = backend.due(delay) else {
            return;
        };
        if let Some(noise) = handover.noise {
            self.run_on_noise(&noise);
        }
        if let Some(solution) = handover.solution {
            self.reanchor(&solution);
        }
    }

    /// Runs the filter on the noise the back-end's variance components `noise` support
    /// ([`VarianceComponents::scales_to_run_on`]), saying so when that changes it.
    fn run_on_noise(&mut self, noise: &VarianceComponents) {
        let scales = noise.scales_to_run_on();
        if scales == self.filter.noise_fit().in_use() {
            return;
        }
        self.filter.run_on_noise(scales);
        let [p1, p2, pr, pb] = self.filter.noise_report().profile;
        let in_use = self.filter.config();
        tracing::info!(
            odometry_sigmas = ?in_use.motion.noise_sigmas(),
            sensor_sigmas = ?[in_use.sensor.sigma_range, in_use.sensor.sigma_bearing],
            profile_odometry = ?[p1, p2],
            profile_sensor = ?[pr, pb],
            "filter runs on the smoothing back-end's noise fit"
        );
    }

    /// Moves the particles onto `solution`: the correction is the rigid motion taking
    /// the filter's estimate at the solution's last pose onto that pose.
    fn reanchor(&mut self, solution: &Solution) {
        let Some(&(last_ns, smoothed)) = solution.poses.last() else {
            return;
        };
        let Some(&(_, then)) = (self.recent.iter().flatten()).find(|(t, _)| *t == last_ns) else {
            tracing::warn!(
                last_ns,
                "re-anchoring skipped: no estimate at the solution's last pose"
            );
            return;
        };
        let correction = smoothed.compose(&then.inverse());
        tracing::info!(
            dx_m = correction.x,
            dy_m = correction.y,
            dtheta_rad = correction.theta,
            solve = solution.solves,
            "particles re-anchored on the smoothed solution"
        );
        self.filter.reanchor(&correction, &solution.landmarks);
    }
}

impl Estimator for LandmarkSlam {
    fn predict(
        &mut self,
        control: &Control,
        from_ns: u64,
        to_ns: u64,
    ) -> fastslam_estimation::Result<()> {
        let dt = to_ns.saturating_sub(from_ns) as f64 * 1e-9;
        self.filter.predict(control, dt)?;
        if let Some(backend) = &mut self.backend {
            backend.send(Feed::Control {
                from_ns,
                to_ns,
                control: *control,
            });
        }
        Ok(())
    }

    /// Converted into the reused buffer, then one filter step.
    fn observe(
        &mut self,
        header: &ObservationsHeader,
        observations: &[fastslam_protocol::Observation],
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        let mut buffer = std::mem::take(&mut self.observations);
        buffer.clear();
        buffer.extend(observations.iter().map(|o| Observation {
            range: o.range,
            bearing: o.bearing,
            id: o.known_id(),
        }));
        let sensor = self.sensor(header.max_range, header.min_bearing, header.max_bearing);
        let step = self.update(header.header, &buffer, &sensor, publish);
        self.observations = buffer;
        step
    }

    /// Poles extracted and used as observations with unknown association, then the scan
    /// offered to the grid mapper as a keyframe.
    fn observe_raw(
        &mut self,
        h: &LaserScanHeader,
        scan: &RangeScan<'_>,
        publish: PoseSink<'_>,
    ) -> fastslam_estimation::Result<Step> {
        // 1. Poles in the scan, seen from the base.
        let mount = self.mount;
        let observations: Vec<Observation> = extract(scan, &self.extractor)
            .iter()
            .map(|f| {
                let (range, bearing) = mount.map_or((f.range, f.bearing), |m| {
                    let [x, y] =
                        m.transform_point([f.range * f.bearing.cos(), f.range * f.bearing.sin()]);
                    (x.hypot(y), y.atan2(x))
                });
                Observation {
                    range,
                    bearing,
                    id: None,
                }
            })
            .collect();
        // 2. The filter step; poles are found up to the extractor's range.
        let max_range = self.extractor.max_range.min(scan.range_max);
        let sensor = self.sensor(max_range, scan.angle_min, h.angle_max());
        let step = self.update(h.header, &observations, &sensor, publish)?;
        // 3. A keyframe for the grid: every particle records its pose.
        let base = Pose2::new(step.pose.x, step.pose.y, step.pose.theta);
        let estimate = mount.map_or(base, |m| base.compose(&m));
        if let Some(keyframe) = self.mapper.offer(scan, estimate) {
            self.filter.record_poses(keyframe);
        }
        Ok(step)
    }

    fn start_back_end(&mut self, config: &ServiceConfig, feed: Vec<Feed>) -> anyhow::Result<()> {
        if !config.smoother.enabled {
            tracing::info!(
                "smoothing back-end off ([smoother] enabled = false, the library's default; \
                 the profiles and scenarios turn it on where it measured better than the \
                 filter, docs/RESULTS.md): nothing is published on smoothed/*"
            );
            return Ok(());
        }
        let filter = config.filter_config();
        let noise = NoiseModel::of(&filter);
        // With known association the keys are the data's ids: nothing to fuse.
        let smoother = SmootherConfig {
            fuse_duplicates: config.smoother.fuse_duplicates
                && filter.association.mode == AssociationMode::Unknown,
            ..config.smoother.clone()
        };
        let takes = Takes {
            solutions: config.smoother.reanchor,
            noise: filter.noise.adapt == Adapt::Smoother,
        };
        self.backend = Some(Backend::start(smoother, noise, takes, feed)?);
        self.handover_delay = config.smoother.handover_delay_scans;
        self.recent = takes.solutions.then(VecDeque::new);
        Ok(())
    }

    fn flush_back_end(&mut self) {
        if let Some(backend) = &mut self.backend {
            backend.flush();
        }
    }

    fn smoothed(&mut self) -> Option<Solution> {
        self.backend.as_mut().and_then(Backend::latest)
    }

    fn finish_back_end(&mut self) -> Option<Solution> {
        self.backend.as_mut().and_then(Backend::finish)
    }

    fn torn_solves(&self) -> TornSolves {
        self.backend.as_ref().map(Backend::torn).unwrap_or_default()
    }

    fn noise_components(&self) -> Option<VarianceComponents> {
        self.backend.as_ref().and_then(Backend::noise)
    }

    fn back_end_feed(&self) -> Vec<Feed> {
        self.backend
            .as_ref()
            .map(|b| b.feed().to_vec())
            .unwrap_or_default()
    }

    fn state(&self) -> EstimatorState {
        EstimatorState::Landmarks(Box::new(self.filter.state()))
    }

    fn fix_map(&mut self) -> anyhow::Result<()> {
        self.filter.fix_map();
        Ok(())
    }

    /// The best particle's occupancy grid, built from its own trajectory and the kept
    /// raw scans. See `fastslam_estimation::grid` for the cost.
    fn occupancy(&mut self) -> Option<OccupancyGrid> {
        self.mapper.grid(self.filter.best().trail())
    }

    /// The best particle's map, provisional landmarks left out.
    fn map(&self) -> Vec<MapLandmark> {
        (self.filter.best_map().iter())
            .map(|l| MapLandmark {
                id: l.id,
                x: l.mean.x,
                y: l.mean.y,
                cov_xx: l.covariance[(0, 0)],
                cov_xy: l.covariance[(0, 1)],
                cov_yy: l.covariance[(1, 1)],
                observations: l.hits.into(),
            })
            .collect()
    }

    fn landmarks(&self) -> usize {
        self.filter.confirmed_landmarks()
    }

    fn cloud(&self) -> Vec<Particle> {
        let weights = self.filter.weights().as_slice();
        (self.filter.particles().iter().zip(weights))
            .map(|(p, &w)| particle(p.pose(), w))
            .collect()
    }

    fn move_stats(&self) -> Option<MoveStats> {
        self.refiner.as_ref().map(OptimiserRefiner::stats)
    }

    fn particles(&self) -> usize {
        self.filter.particles().len()
    }

    fn noise(&self) -> Option<fastslam_estimation::fastslam::NoiseReport> {
        Some(self.filter.noise_report())
    }
}
