//! Vehicle motion models (docs/ALGORITHMS.md §2): the unicycle / differential drive of the
//! ICOA paper (eq. 24) and the bicycle of the IBA paper (eq. 14), as data.
//!
//! Both models take two controls — (v, ω) for the unicycle, (v, γ) for the bicycle — with
//! independent Gaussian noise on each. One [`Control`] carries everything odometry may
//! report; the model picks the two it uses. For FastSLAM 2.0 and the optimisers' motion
//! prior the module also gives the Jacobians and the control noise projected to the pose.
//!
//! Noise is applied once per [`MotionModel::sample`] call, as in Bailey's simulator and the
//! papers: the σ's belong to the odometry period the model is driven at.

use crate::check::{non_negative, positive};
use crate::pose::Pose2;
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix3, Matrix3x2};
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// What odometry reports over one period; a model uses the fields it needs.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Control {
    /// Forward speed (m/s); both models.
    pub v: f64,
    /// Yaw rate (rad/s), counter-clockwise positive; unicycle.
    pub omega: f64,
    /// Steering angle of the front wheel (rad), left positive; bicycle.
    pub steering: f64,
}

impl Control {
    /// Checks that every field is finite (including the ones the model ignores, so a
    /// broken odometry message is noticed whichever model runs).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the first non-finite field.
    pub fn validate(&self) -> Result<()> {
        for (what, value) in [
            ("control.v", self.v),
            ("control.omega", self.omega),
            ("control.steering", self.steering),
        ] {
            if !value.is_finite() {
                return Err(Error::InvalidInput {
                    what,
                    reason: format!("not finite: {value}"),
                });
            }
        }
        Ok(())
    }
}

/// Unicycle / differential drive (ICOA eq. 24): `x += v Δt cos θ`, `y += v Δt sin θ`,
/// `θ += ω Δt`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Unicycle {
    /// Standard deviation of the speed noise (m/s); ICOA paper 0.05.
    pub sigma_v: f64,
    /// Standard deviation of the yaw-rate noise (rad/s); ICOA paper 0.03.
    pub sigma_omega: f64,
}

impl Default for Unicycle {
    fn default() -> Self {
        Self {
            sigma_v: 0.05,
            sigma_omega: 0.03,
        }
    }
}

/// Kinematic bicycle (IBA eq. 14, Bailey's simulator): `x += v Δt cos(θ+γ)`,
/// `y += v Δt sin(θ+γ)`, `θ += v Δt sin(γ) / B`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Bicycle {
    /// Wheelbase `B` (m); Bailey / IBA 4.
    pub wheelbase: f64,
    /// Standard deviation of the speed noise (m/s); Bailey / IBA 0.3.
    pub sigma_v: f64,
    /// Standard deviation of the steering noise (rad); Bailey / IBA 3° = 0.05236.
    pub sigma_steering: f64,
}

impl Default for Bicycle {
    fn default() -> Self {
        Self {
            wheelbase: 4.0,
            sigma_v: 0.3,
            sigma_steering: 3f64.to_radians(),
        }
    }
}

/// The motion model, chosen in TOML by `model = "unicycle"` or `model = "bicycle"` next to
/// that model's fields. Default: Bailey's bicycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum MotionModel {
    /// Control (v, ω).
    Unicycle(Unicycle),
    /// Control (v, γ) with a wheelbase.
    Bicycle(Bicycle),
}

impl Default for MotionModel {
    fn default() -> Self {
        Self::Bicycle(Bicycle::default())
    }
}

/// First-order sensitivities of one motion step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionJacobians {
    /// ∂(new pose)/∂(old pose), 3×3.
    pub wrt_pose: Matrix3<f64>,
    /// ∂(new pose)/∂(the model's two controls), 3×2; columns (v, ω) or (v, γ).
    pub wrt_control: Matrix3x2<f64>,
}

impl MotionModel {
    /// Checks the noise and geometry parameters.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a negative or non-finite σ or a wheelbase ≤ 0.
    pub fn validate(&self) -> Result<()> {
        match self {
            Self::Unicycle(u) => {
                non_negative("motion.sigma_v", u.sigma_v)?;
                non_negative("motion.sigma_omega", u.sigma_omega)
            }
            Self::Bicycle(b) => {
                positive("motion.wheelbase", b.wheelbase)?;
                non_negative("motion.sigma_v", b.sigma_v)?;
                non_negative("motion.sigma_steering", b.sigma_steering)
            }
        }
    }

    /// The two controls this model uses: (v, ω) or (v, γ).
    fn controls(&self, control: &Control) -> [f64; 2] {
        match self {
            Self::Unicycle(_) => [control.v, control.omega],
            Self::Bicycle(_) => [control.v, control.steering],
        }
    }

    /// Noise-free step from `pose` with the model's two controls `u` over `dt` seconds.
    fn step(&self, pose: &Pose2, u: [f64; 2], dt: f64) -> Pose2 {
        let [v, second] = u;
        match self {
            Self::Unicycle(_) => Pose2::new(
                pose.x + v * dt * pose.theta.cos(),
                pose.y + v * dt * pose.theta.sin(),
                pose.theta + second * dt,
            ),
            Self::Bicycle(b) => {
                let heading = pose.theta + second;
                Pose2::new(
                    pose.x + v * dt * heading.cos(),
                    pose.y + v * dt * heading.sin(),
                    pose.theta + v * dt * second.sin() / b.wheelbase,
                )
            }
        }
    }

    /// Deterministic (noise-free) propagation of `pose` by `control` over `dt` seconds.
    pub fn propagate(&self, pose: &Pose2, control: &Control, dt: f64) -> Pose2 {
        self.step(pose, self.controls(control), dt)
    }

    /// Draws the next pose from `p(x' | x, u)`: Gaussian noise on the two controls, then
    /// the noise-free step.
    pub fn sample(&self, pose: &Pose2, control: &Control, dt: f64, rng: &mut impl Rng) -> Pose2 {
        let [v, second] = self.controls(control);
        let [sv, ss] = self.sigmas();
        let noisy = [
            v + sv * rng.sample::<f64, _>(StandardNormal),
            second + ss * rng.sample::<f64, _>(StandardNormal),
        ];
        self.step(pose, noisy, dt)
    }

    /// Standard deviations of the two controls' noise.
    fn sigmas(&self) -> [f64; 2] {
        match self {
            Self::Unicycle(u) => [u.sigma_v, u.sigma_omega],
            Self::Bicycle(b) => [b.sigma_v, b.sigma_steering],
        }
    }

    /// Covariance `Q` of the two controls' noise, `diag(σ_v², σ²)`.
    pub fn control_noise(&self) -> Matrix2<f64> {
        let [sv, ss] = self.sigmas();
        Matrix2::new(sv * sv, 0.0, 0.0, ss * ss)
    }

    /// Jacobians of [`propagate`](Self::propagate) at (`pose`, `control`, `dt`).
    pub fn jacobians(&self, pose: &Pose2, control: &Control, dt: f64) -> MotionJacobians {
        let [v, second] = self.controls(control);
        let heading = match self {
            Self::Unicycle(_) => pose.theta,
            Self::Bicycle(_) => pose.theta + second,
        };
        let (s, c) = heading.sin_cos();
        let wrt_pose = Matrix3::new(1.0, 0.0, -v * dt * s, 0.0, 1.0, v * dt * c, 0.0, 0.0, 1.0);
        let wrt_control = match self {
            Self::Unicycle(_) => Matrix3x2::new(dt * c, 0.0, dt * s, 0.0, 0.0, dt),
            Self::Bicycle(b) => Matrix3x2::new(
                dt * c,
                -v * dt * s,
                dt * s,
                v * dt * c,
                dt * second.sin() / b.wheelbase,
                v * dt * second.cos() / b.wheelbase,
            ),
        };
        MotionJacobians {
            wrt_pose,
            wrt_control,
        }
    }

    /// Control noise projected to the pose, `F_u Q F_uᵀ` (3×3), for one step.
    ///
    /// Its rank is at most 2 (two noisy controls move three pose coordinates); a consumer
    /// that inverts it (a motion prior) must regularise it.
    pub fn pose_noise(&self, pose: &Pose2, control: &Control, dt: f64) -> Matrix3<f64> {
        let f_u = self.jacobians(pose, control, dt).wrt_control;
        f_u * self.control_noise() * f_u.transpose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::wrap_angle;
    use crate::rng::seeded;
    use nalgebra::Vector3;

    fn models() -> [MotionModel; 2] {
        [
            MotionModel::Unicycle(Unicycle::default()),
            MotionModel::default(),
        ]
    }

    const CONTROL: Control = Control {
        v: 3.0,
        omega: 0.4,
        steering: 0.3,
    };

    fn pose_diff(a: &Pose2, b: &Pose2) -> Vector3<f64> {
        Vector3::new(a.x - b.x, a.y - b.y, wrap_angle(a.theta - b.theta))
    }

    #[test]
    fn unicycle_and_bicycle_follow_their_equations() {
        let start = Pose2::new(1.0, 2.0, 0.5);
        let u = MotionModel::Unicycle(Unicycle::default()).propagate(&start, &CONTROL, 0.1);
        assert!((u.x - (1.0 + 0.3 * 0.5f64.cos())).abs() < 1e-12);
        assert!((u.y - (2.0 + 0.3 * 0.5f64.sin())).abs() < 1e-12);
        assert!((u.theta - 0.54).abs() < 1e-12);
        let b = MotionModel::default().propagate(&start, &CONTROL, 0.1);
        assert!((b.x - (1.0 + 0.3 * 0.8f64.cos())).abs() < 1e-12);
        assert!((b.y - (2.0 + 0.3 * 0.8f64.sin())).abs() < 1e-12);
        assert!((b.theta - (0.5 + 0.3 * 0.3f64.sin() / 4.0)).abs() < 1e-12);
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let pose = Pose2::new(-3.0, 4.0, 2.9);
        let dt = 0.2;
        let h = 1e-6;
        for model in models() {
            let j = model.jacobians(&pose, &CONTROL, dt);
            let base = model.propagate(&pose, &CONTROL, dt);
            for k in 0..3 {
                let mut p = [pose.x, pose.y, pose.theta];
                p[k] += h;
                let moved = model.propagate(&Pose2::new(p[0], p[1], p[2]), &CONTROL, dt);
                let d = pose_diff(&moved, &base) / h;
                assert!((d - j.wrt_pose.column(k)).norm() < 1e-5, "{model:?} F_x");
            }
            let used = model.controls(&CONTROL);
            for k in 0..2 {
                let mut u = used;
                u[k] += h;
                let d = pose_diff(&model.step(&pose, u, dt), &base) / h;
                assert!((d - j.wrt_control.column(k)).norm() < 1e-5, "{model:?} F_u");
            }
        }
    }

    #[test]
    fn samples_match_mean_and_projected_covariance() {
        // Small noise so the linearisation holds; seeded, 20 000 draws, 5 % tolerance.
        let pose = Pose2::new(0.0, 0.0, 0.3);
        let dt = 0.5;
        for model in models() {
            let mean = model.propagate(&pose, &CONTROL, dt);
            let predicted = model.pose_noise(&pose, &CONTROL, dt);
            let mut rng = seeded(21);
            let n = 20_000;
            let mut cov = Matrix3::zeros();
            for _ in 0..n {
                let d = pose_diff(&model.sample(&pose, &CONTROL, dt, &mut rng), &mean);
                cov += d * d.transpose() / n as f64;
            }
            for r in 0..3 {
                let scale = predicted[(r, r)].sqrt();
                for c in 0..3 {
                    let tol = 0.05 * scale * predicted[(c, c)].sqrt() + 1e-12;
                    assert!(
                        (cov[(r, c)] - predicted[(r, c)]).abs() < tol,
                        "{model:?} ({r},{c}): {} vs {}",
                        cov[(r, c)],
                        predicted[(r, c)]
                    );
                }
            }
        }
    }

    #[test]
    fn control_with_nan_is_rejected() {
        assert!(CONTROL.validate().is_ok());
        let bad = Control {
            steering: f64::NAN,
            ..CONTROL
        };
        assert!(matches!(
            bad.validate(),
            Err(Error::InvalidInput {
                what: "control.steering",
                ..
            })
        ));
    }

    #[test]
    fn motion_model_is_selected_in_toml_with_defaults() {
        let m: MotionModel = toml::from_str("model = \"unicycle\"\nsigma_v = 0.1").unwrap();
        assert_eq!(
            m,
            MotionModel::Unicycle(Unicycle {
                sigma_v: 0.1,
                sigma_omega: 0.03
            })
        );
        let m: MotionModel = toml::from_str("model = \"bicycle\"").unwrap();
        assert_eq!(m, MotionModel::default());
        assert!(toml::from_str::<MotionModel>("model = \"bicycle\"\nsigma_omega = 1.0").is_err());
        let bad = MotionModel::Bicycle(Bicycle {
            wheelbase: 0.0,
            ..Bicycle::default()
        });
        assert!(bad.validate().is_err());
    }
}
