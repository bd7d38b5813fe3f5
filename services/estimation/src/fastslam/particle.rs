//! One FastSLAM particle: a pose hypothesis, its log-weight and its own landmark map
//! (docs/ALGORITHMS.md §1), with the map update that applies a scan's association decisions.

use super::association::{AssociationMode, Decision, Scan, ScanAssociation};
use super::ekf;
use super::evidence::NegativeEvidence;
use super::landmarks::{LandmarkMap, new_landmark_id};
use super::merge;
use super::trail::Trail;
use crate::motion::{Control, MotionModel};
use crate::pose::{Pose2, wrap_angle};
use crate::{Error, Result};
use nalgebra::{Matrix3, Vector3};

/// A pose hypothesis with its normalised log-weight, landmark map and the motion prior of
/// its pose in the current step.
///
/// Cloning is O(1): the clone shares the map until one of the two writes to it.
#[derive(Debug, Clone)]
pub struct Particle {
    pub(crate) pose: Pose2,
    pub(crate) log_weight: f64,
    pub(crate) map: LandmarkMap,
    pub(crate) trail: Trail,
    pub(crate) prior: MotionPrior,
}

/// The Gaussian motion prior `N(x̂, P)` of a particle's pose in the current filter step: what
/// FastSLAM 2.0's proposal starts from, and the motion-prior term of the optimisers' fitness
/// and of the Metropolis–Hastings target (docs/ALGORITHMS.md §3).
///
/// After an update it is the particle's pose with the covariance floor; every prediction
/// propagates the mean without noise and adds the control noise,
/// `P ← F_x P F_xᵀ + F_u Q F_uᵀ` with the Jacobians at the mean (Bailey's FastSLAM 2.0
/// `predict`). The particle's own pose is a sample of the same motion model, drawn control
/// by control — or, with deferred sampling, the prior's mean until an observation draws it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionPrior {
    /// `x̂`: the noise-free prediction from the pose the last update left (m, m, rad).
    pub mean: Pose2,
    /// `P`: covariance of `(x, y, θ)` around `x̂` (m², m·rad, rad²), symmetric positive
    /// definite thanks to the floor.
    pub covariance: Matrix3<f64>,
}

impl MotionPrior {
    /// The prior right after an update: the pose itself, with covariance `floor`.
    pub(crate) fn settled(pose: Pose2, floor: &Matrix3<f64>) -> Self {
        Self {
            mean: pose,
            covariance: *floor,
        }
    }

    /// The prior after one more control period.
    pub(crate) fn predict(&self, motion: &MotionModel, control: &Control, dt: f64) -> Self {
        let j = motion.jacobians(&self.mean, control, dt);
        let noise = motion.pose_noise(&self.mean, control, dt);
        let covariance = j.wrt_pose * self.covariance * j.wrt_pose.transpose() + noise;
        Self {
            mean: motion.propagate(&self.mean, control, dt),
            covariance: 0.5 * (covariance + covariance.transpose()),
        }
    }

    /// `pose − x̂` with the heading difference wrapped.
    pub fn deviation(&self, pose: &Pose2) -> Vector3<f64> {
        Vector3::new(
            pose.x - self.mean.x,
            pose.y - self.mean.y,
            wrap_angle(pose.theta - self.mean.theta),
        )
    }
}

/// Landmark changes one particle made for one scan.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct MapChanges {
    pub matched: usize,
    pub created: usize,
    pub ignored: usize,
    pub removed: usize,
}

impl Particle {
    /// The pose hypothesis (m, m, rad).
    pub fn pose(&self) -> &Pose2 {
        &self.pose
    }

    /// Normalised log-weight (`log wᵢ`, Σ wᵢ = 1 over the filter's particles).
    pub fn log_weight(&self) -> f64 {
        self.log_weight
    }

    /// This particle's landmark map.
    pub fn map(&self) -> &LandmarkMap {
        &self.map
    }

    /// This particle's recorded poses (see [`FastSlam::record_poses`](super::FastSlam::record_poses)).
    pub fn trail(&self) -> &Trail {
        &self.trail
    }

    /// The motion prior of the pose in the current step.
    pub fn prior(&self) -> &MotionPrior {
        &self.prior
    }

    /// Moves the particle (step 2 of docs/ALGORITHMS.md §1: an optimiser moving predicted
    /// poses); the map moves with it. The heading is wrapped.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when a component is not finite; the pose is unchanged.
    pub fn set_pose(&mut self, pose: Pose2) -> Result<()> {
        if !pose.is_finite() {
            return Err(Error::InvalidInput {
                what: "particle pose",
                reason: format!("not finite: {pose:?}"),
            });
        }
        self.pose = Pose2::new(pose.x, pose.y, pose.theta);
        Ok(())
    }

    /// Applies `association` (computed by `scan` for this particle's pose and map): EKF
    /// updates, new landmarks, then negative evidence.
    pub(crate) fn apply(
        &mut self,
        scan: &Scan<'_>,
        association: &ScanAssociation,
        evidence: &NegativeEvidence,
    ) -> MapChanges {
        let noise = scan.sensor().noise();
        let mut changes = MapChanges::default();
        let config = scan.config();
        let merging = config.mode == AssociationMode::Unknown && config.merge_gate > 0.0;
        let mut touched = Vec::new();
        let decided = scan.observations().iter().zip(&association.decisions);
        for (index, (obs, decision)) in decided.enumerate() {
            match *decision {
                Decision::Update {
                    slot,
                    h,
                    innovation,
                } => {
                    self.map.update_at(slot, |landmark| {
                        ekf::update(
                            &mut landmark.mean,
                            &mut landmark.covariance,
                            &innovation,
                            &h,
                            &noise,
                        );
                        landmark.hits = landmark.hits.saturating_add(1);
                    });
                    changes.matched += 1;
                    if merging {
                        touched.push(slot.id());
                    }
                }
                Decision::New { id } => {
                    let Some(id) = id.or_else(|| new_landmark_id(scan.step(), index)) else {
                        changes.ignored += 1;
                        continue;
                    };
                    self.map
                        .insert(LandmarkMap::landmark_from(id, &self.pose, &obs.z(), &noise));
                    changes.created += 1;
                    if merging {
                        touched.push(id);
                    }
                }
                Decision::Ignore => changes.ignored += 1,
            }
        }
        changes.removed = evidence.apply(&mut self.map, &self.pose, scan.sensor());
        if merging {
            let (gate, radius) = (config.merge_gate, config.search_radius);
            changes.removed += merge::merge_touched(&mut self.map, &touched, gate, radius);
        }
        changes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_pose_rejects_non_finite_poses_and_wraps_the_heading() {
        let mut p = Particle {
            pose: Pose2::default(),
            log_weight: 0.0,
            map: LandmarkMap::new(10.0),
            trail: Trail::default(),
            prior: MotionPrior::settled(Pose2::default(), &Matrix3::identity()),
        };
        assert!(
            p.set_pose(Pose2 {
                x: f64::NAN,
                y: 0.0,
                theta: 0.0
            })
            .is_err()
        );
        assert_eq!(*p.pose(), Pose2::default());
        p.set_pose(Pose2 {
            x: 1.0,
            y: 2.0,
            theta: 7.0,
        })
        .unwrap();
        assert!((p.pose().theta - (7.0 - std::f64::consts::TAU)).abs() < 1e-12);
    }

    #[test]
    fn prior_follows_the_noise_free_motion_and_accumulates_its_noise() {
        let motion = MotionModel::default();
        let control = Control {
            v: 3.0,
            omega: 0.0,
            steering: 0.2,
            ..Control::ZERO
        };
        let floor = Matrix3::from_diagonal(&Vector3::new(1e-6, 1e-6, 1e-8));
        let start = Pose2::new(1.0, 2.0, 0.3);
        let mut prior = MotionPrior::settled(start, &floor);
        let mut mean = start;
        let mut covariance = floor;
        for _ in 0..8 {
            let j = motion.jacobians(&mean, &control, 0.025);
            covariance = j.wrt_pose * covariance * j.wrt_pose.transpose()
                + motion.pose_noise(&mean, &control, 0.025);
            mean = motion.propagate(&mean, &control, 0.025);
            prior = prior.predict(&motion, &control, 0.025);
        }
        assert_eq!(prior.mean, mean);
        assert!((prior.covariance - covariance).norm() < 1e-15);
        assert!(prior.covariance.cholesky().is_some(), "positive definite");
        // At least the speed noise of eight periods along the track.
        let along = 8.0 * (0.3f64 * 0.025).powi(2);
        assert!(prior.covariance[(0, 0)] + prior.covariance[(1, 1)] > along);
        let d = prior.deviation(&Pose2::new(mean.x + 0.5, mean.y, mean.theta - 0.1));
        assert!((d - Vector3::new(0.5, 0.0, -0.1)).norm() < 1e-12);
    }
}
