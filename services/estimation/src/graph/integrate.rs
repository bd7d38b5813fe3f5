//! Odometry between two poses of a [`Graph`](super::Graph) as one [`Between`] factor.

use super::{Between, PoseResidual};
use crate::motion::{Control, MotionModel};
use crate::pose::Pose2;
use nalgebra::Matrix3;

/// Integrates the controls between two poses with the filter's motion model: the
/// noise-free relative pose and its covariance, propagated as the filter's motion prior
/// is (`P ← F_x P F_xᵀ + F_u Q F_uᵀ`), in the frame of the first pose. The models are
/// invariant to where the vehicle is, so the integration starts at the origin.
#[derive(Debug, Clone)]
pub struct OdometryIntegrator {
    motion: MotionModel,
    floor: Matrix3<f64>,
    delta: Pose2,
    covariance: Matrix3<f64>,
    controls: usize,
}

impl OdometryIntegrator {
    /// An integrator with `motion` and its noise; `floor` is added to every factor's
    /// covariance (the filter's prior floor), so a vehicle standing still still gives an
    /// invertible one.
    pub fn new(motion: MotionModel, floor: Matrix3<f64>) -> Self {
        Self {
            motion,
            floor,
            delta: Pose2::default(),
            covariance: Matrix3::zeros(),
            controls: 0,
        }
    }

    /// Adds `control` held for `dt` seconds.
    pub fn add(&mut self, control: &Control, dt: f64) {
        let j = self.motion.jacobians(&self.delta, control, dt);
        let noise = self.motion.pose_noise(&self.delta, control, dt);
        let covariance = j.wrt_pose * self.covariance * j.wrt_pose.transpose() + noise;
        self.covariance = 0.5 * (covariance + covariance.transpose());
        self.delta = self.motion.propagate(&self.delta, control, dt);
        self.controls += 1;
    }

    /// Controls added since the last [`take`](Self::take).
    pub fn controls(&self) -> usize {
        self.controls
    }

    /// The factor from pose `from` to pose `to` for the controls added since the last
    /// call, and a fresh start; `None` when the covariance cannot be inverted.
    pub fn take(&mut self, from: usize, to: usize) -> Option<Between> {
        let information = (self.covariance + self.floor).try_inverse()?;
        let factor = Between {
            from,
            to,
            delta: self.delta,
            information: 0.5 * (information + information.transpose()),
            residual: PoseResidual::Componentwise,
        };
        (self.delta, self.covariance, self.controls) = (Pose2::default(), Matrix3::zeros(), 0);
        information.iter().all(|v| v.is_finite()).then_some(factor)
    }
}
