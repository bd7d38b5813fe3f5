//! Everything the client received, kept in stamp order.

use crate::lidar_count::LidarCount;
use crate::resources::ProcessUsage;
use fastslam_estimation::motion::Control;
use fastslam_estimation::observation::Observation;
use fastslam_protocol::message::Message;
use fastslam_protocol::topics::{self, Topic};
use fastslam_protocol::{
    GroundTruth, MapLandmark, ObservationsHeader, OccupancyGridHeader, Odometry, PoseEstimate,
    ServiceStatus, TrajectoryHeader, TrajectoryPose, status,
};

/// A planar pose at a stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Stamp (ns).
    pub stamp_ns: u64,
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub theta: f64,
}

/// An estimated pose with its covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The pose.
    pub pose: StampedPose,
    /// Covariance of (x, y, θ), row-major.
    pub covariance: [f64; 9],
}

/// The control an odometry message carried, at its stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedControl {
    /// Stamp (ns).
    pub stamp_ns: u64,
    /// Speed, yaw rate and steering angle as measured.
    pub control: Control,
}

/// The observations of one scan that carry a landmark id: what the reference solve
/// ([`crate::reference`]) uses.
#[derive(Debug, Clone, PartialEq)]
pub struct Sightings {
    /// Stamp of the scan (ns).
    pub stamp_ns: u64,
    /// Range, bearing and landmark id of each.
    pub observations: Vec<Observation>,
}

/// What the client recorded during a run.
#[derive(Debug, Clone, Default)]
pub struct Recording {
    /// Ground truth, one per control period.
    pub truth: Vec<StampedPose>,
    /// The run had no ground truth (the client did not subscribe to it): nothing is
    /// scored against truth (see [`crate::Metrics::ground_truth`]).
    pub without_truth: bool,
    /// Dead-reckoned poses from the odometry messages.
    pub dead_reckoning: Vec<StampedPose>,
    /// The controls of the odometry messages.
    pub controls: Vec<StampedControl>,
    /// Landmark observations with ids, per scan (none from raw scans).
    pub sightings: Vec<Sightings>,
    /// The achievable-accuracy reference's trajectory in the truth's frame, once solved
    /// (see [`crate::reference`]); empty without one.
    pub reference: Vec<StampedPose>,
    /// The reference's solved graph, once solved.
    pub reference_graph: Option<fastslam_estimation::graph::Graph>,
    /// The smoothing back-end's newest trajectory (the service's frame; the truth's once
    /// scored, see [`crate::metrics::Metrics::with_smoothed`]); empty without one.
    pub smoothed: Vec<StampedPose>,
    /// The χ² per degree of freedom and the solve count of that trajectory.
    pub smoothed_fit: Option<(f64, u32)>,
    /// The smoothing back-end's newest map.
    pub smoothed_map: Vec<MapLandmark>,
    /// The back-end's solves withheld as torn, as of the service's newest status.
    pub torn_solves: u32,
    /// The service's landmark filter associates without ids
    /// ([`status::flags::UNKNOWN_ASSOCIATION`]).
    pub unknown_association: bool,
    /// The service's estimates.
    pub estimates: Vec<Estimate>,
    /// The newest landmark map from the service.
    pub map: Vec<MapLandmark>,
    /// The true landmark map from the simulator.
    pub true_map: Vec<MapLandmark>,
    /// The newest occupancy grid from the service, with its cells.
    pub grid: Option<(OccupancyGridHeader, Vec<i8>)>,
    /// The service's status after each observation step.
    pub status: Vec<StatusSample>,
    /// End-to-end latency per pose: (pose stamp in ns, seconds), see [`crate::latency`].
    pub latencies: Vec<(u64, f64)>,
    /// Wall time from the first observation to the last pose, as received (s); see
    /// [`crate::latency::LatencyMatcher::streamed_s`].
    pub streamed_s: Option<f64>,
    /// CPU time and peak memory of the stack's processes, see [`crate::resources`].
    pub processes: Vec<ProcessUsage>,
    /// The service's count of inputs it dropped or rejected, by
    /// [`status::RejectionKind`] index, as of its newest status.
    pub rejections: [u64; status::REJECTION_KINDS],
    /// The lidar messages received, and those without anything usable.
    pub lidar: LidarCount,
}

/// The filter-health part of one [`ServiceStatus`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusSample {
    /// Stamp of the observation step (the stamp of the pose it produced) (ns).
    pub stamp_ns: u64,
    /// Effective sample size before resampling (1..particles).
    pub n_eff: f64,
    /// Number of particles.
    pub particles: u32,
    /// Distinct particles after the step.
    pub distinct: u32,
    /// Whether the step resampled.
    pub resampled: bool,
    /// Landmarks in the best particle's map.
    pub landmarks: u64,
    /// Wall-clock time of the filter update, as the service measured it (s).
    pub step_time_s: f64,
    /// The noise check's NIS per degree of freedom over its window (NaN before a match).
    pub nis: f64,
    /// The noise check failed at this step ([`status::flags::NIS_HIGH`]).
    pub nis_high: bool,
    /// ... with the odometry suspected ([`status::flags::NIS_POSE`]).
    pub nis_pose: bool,
    /// The configured noise as standard deviations ([`ServiceStatus::noise_profile`]).
    pub noise_profile: [f64; 4],
    /// The noise as fitted ([`ServiceStatus::noise_fitted`]).
    pub noise_fitted: [f64; 4],
    /// Where `noise_fitted` comes from: a [`status::noise_fit`] value.
    pub noise_fit: u32,
    /// The source the noise check blames: a [`status::noise_suspect`] value.
    pub noise_suspect: u32,
}

impl Recording {
    /// Keeps what the scores need of a valid message of `topic`: every ground-truth
    /// sample, odometry message, pose estimate and status, the observations with a
    /// landmark id, and the newest of the maps, the grid and the smoothed trajectory.
    pub fn add(&mut self, topic: Topic, message: Message<'_>) {
        match (topic, message) {
            (topics::GROUND_TRUTH, Message::GroundTruth(m)) => self.add_truth(m),
            (topics::ODOMETRY, Message::Odometry(m)) => self.add_odometry(m),
            (topics::OBSERVATIONS, Message::Observations(h, o)) => self.add_observations(h, o),
            (topics::POSE, Message::Pose(m)) => self.add_estimate(m),
            (topics::STATUS, Message::Status(m)) => self.add_status(m),
            (topics::MAP, Message::LandmarkMap(_, l)) => self.map = l.to_vec(),
            (topics::SMOOTHED_MAP, Message::LandmarkMap(_, l)) => self.smoothed_map = l.to_vec(),
            (topics::TRUE_LANDMARKS, Message::LandmarkMap(_, l)) => self.true_map = l.to_vec(),
            (topics::GRID, Message::Grid(h, c)) => self.grid = Some((*h, c.to_vec())),
            (topics::SMOOTHED_TRAJECTORY, Message::Trajectory(h, p)) => self.set_smoothed(h, p),
            // Raw scans and particle clouds go to run.mcap only.
            _ => {}
        }
    }

    /// Puts the streams recorded in stamp order (stable: equal stamps keep their order),
    /// as a client that resumed a run takes them out of order.
    pub fn sort_by_stamp(&mut self) {
        self.truth.sort_by_key(|p| p.stamp_ns);
        self.dead_reckoning.sort_by_key(|p| p.stamp_ns);
        self.controls.sort_by_key(|c| c.stamp_ns);
        self.sightings.sort_by_key(|s| s.stamp_ns);
        self.estimates.sort_by_key(|e| e.pose.stamp_ns);
        self.status.sort_by_key(|s| s.stamp_ns);
    }

    /// Keeps a smoothed trajectory (replacing the previous one).
    pub fn set_smoothed(&mut self, h: &TrajectoryHeader, poses: &[TrajectoryPose]) {
        self.smoothed = (poses.iter())
            .map(|p| StampedPose {
                stamp_ns: p.stamp_ns,
                x: p.x,
                y: p.y,
                theta: p.theta,
            })
            .collect();
        self.smoothed_fit = Some((h.chi2_per_dof, h.solves));
    }

    /// Adds a ground-truth sample.
    pub fn add_truth(&mut self, m: &GroundTruth) {
        self.truth.push(StampedPose {
            stamp_ns: m.header.stamp_ns,
            x: m.x,
            y: m.y,
            theta: m.theta,
        });
    }

    /// Adds an odometry sample's dead-reckoned pose and control.
    pub fn add_odometry(&mut self, m: &Odometry) {
        self.dead_reckoning.push(StampedPose {
            stamp_ns: m.header.stamp_ns,
            x: m.x,
            y: m.y,
            theta: m.theta,
        });
        self.controls.push(StampedControl {
            stamp_ns: m.header.stamp_ns,
            control: Control {
                v: m.v,
                omega: m.omega,
                steering: m.steering,
                ..Control::ZERO
            },
        });
    }

    /// Adds the observations of a scan that carry a landmark id (a scan without any adds
    /// nothing).
    pub fn add_observations(
        &mut self,
        header: &ObservationsHeader,
        observations: &[fastslam_protocol::Observation],
    ) {
        let observations: Vec<Observation> = observations
            .iter()
            .filter_map(|o| {
                o.known_id().map(|id| Observation {
                    range: o.range,
                    bearing: o.bearing,
                    id: Some(id),
                })
            })
            .collect();
        if !observations.is_empty() {
            self.sightings.push(Sightings {
                stamp_ns: header.header.stamp_ns,
                observations,
            });
        }
    }

    /// Adds a pose estimate.
    pub fn add_estimate(&mut self, m: &PoseEstimate) {
        let pose = StampedPose {
            stamp_ns: m.header.stamp_ns,
            x: m.x,
            y: m.y,
            theta: m.theta,
        };
        self.estimates.push(Estimate {
            pose,
            covariance: m.covariance,
        });
    }

    /// Adds the status message of an observation step; the service's final status (sent
    /// at shutdown, not a step) is only logged, and brings the last step's noise fit up
    /// to date (the back-end's last whole solve). Either brings the rejection counts up
    /// to date.
    pub fn add_status(&mut self, m: &ServiceStatus) {
        // The counts only grow: the newest status has them all.
        for (count, &now) in self.rejections.iter_mut().zip(&m.rejections) {
            *count = (*count).max(now);
        }
        self.torn_solves = self.torn_solves.max(m.torn_solves);
        self.unknown_association |= m.flags & status::flags::UNKNOWN_ASSOCIATION != 0;
        if m.flags & status::flags::FINAL != 0 {
            tracing::info!(
                steps = m.steps,
                resamplings = m.resamplings,
                landmarks = m.landmarks,
                rejected = m.rejections.iter().sum::<u64>(),
                "final status of the service"
            );
            if let Some(last) = self.status.last_mut() {
                last.noise_fitted = m.noise_fitted;
                (last.noise_fit, last.noise_suspect) = (m.noise_fit, m.noise_suspect);
            }
            return;
        }
        self.status.push(StatusSample {
            stamp_ns: m.header.stamp_ns,
            n_eff: m.n_eff,
            particles: m.particles,
            distinct: m.distinct_particles,
            resampled: m.flags & status::flags::RESAMPLED != 0,
            landmarks: m.landmarks,
            step_time_s: m.step_time_ns as f64 * 1e-9,
            nis: m.nis,
            nis_high: m.flags & status::flags::NIS_HIGH != 0,
            nis_pose: m.flags & status::flags::NIS_POSE != 0,
            noise_profile: m.noise_profile,
            noise_fitted: m.noise_fitted,
            noise_fit: m.noise_fit,
            noise_suspect: m.noise_suspect,
        });
    }
}
