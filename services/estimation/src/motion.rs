//! Vehicle motion models (docs/ALGORITHMS.md §2), as data: two velocity models — the
//! unicycle / differential drive of the ICOA paper (eq. 24) and the bicycle of the IBA
//! paper (eq. 14) — and the pose-increment model of odometry that reports poses
//! (wheel-encoder dead reckoning, `nav_msgs/Odometry`, a CARMEN log).
//!
//! The velocity models take two controls — (v, ω) for the unicycle, (v, γ) for the
//! bicycle — with independent Gaussian noise on each, applied once per
//! [`MotionModel::sample`] call, as in Bailey's simulator and the papers: their σ's belong
//! to the odometry period the model is driven at. They serve sources that report
//! velocities (the simulations, MRCLAM, Victoria Park).
//!
//! The [`Increment`] model takes the odometry's pose increment between two messages and
//! adds noise whose *variance* grows with the distance travelled and the angle turned, so
//! the noise over a path is the same however often the odometry is published, and a gap
//! or a burst of stamps changes nothing ([`Increment`]).
//!
//! One [`Control`] carries everything odometry may report; the model picks what it uses.
//! For FastSLAM 2.0 and the optimisers' motion prior the module also gives the Jacobians
//! and the noise projected to the pose.

use crate::check::{non_negative, positive};
use crate::pose::{Pose2, wrap_angle};
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
    /// The odometry's pose increment over the interval, in the frame of the pose at its
    /// start (m, m, rad); the [`Increment`] model.
    pub increment: Pose2,
}

impl Control {
    /// Every field zero: no motion.
    pub const ZERO: Control = Control {
        v: 0.0,
        omega: 0.0,
        steering: 0.0,
        increment: Pose2 {
            x: 0.0,
            y: 0.0,
            theta: 0.0,
        },
    };

    /// The control of odometry that reports poses: the increment from `from` to `to`
    /// (both in the odometry frame) in `from`'s frame, with the reported velocities.
    pub fn between_poses(from: &Pose2, to: &Pose2, v: f64, omega: f64) -> Self {
        let mut increment = from.inverse().compose(to);
        increment.theta = wrap_angle(to.theta - from.theta);
        Self {
            v,
            omega,
            increment,
            ..Self::ZERO
        }
    }

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
            ("control.increment.x", self.increment.x),
            ("control.increment.y", self.increment.y),
            ("control.increment.theta", self.increment.theta),
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

/// Odometry that reports poses: the pose moves by the measured increment `δ = (δx, δy,
/// δθ)` (in the frame of the pose at the interval's start) plus Gaussian noise on each
/// component, with variances that grow linearly with the distance `d = √(δx² + δy²)` and
/// the turn `|δθ|`:
///
/// `σ²_x = σ²_y = translation_per_m² · d + translation_per_rad² · |δθ|`,
/// `σ²_θ = rotation_per_m² · d + rotation_per_rad² · |δθ|`.
///
/// Variances (not σ's) proportional to the motion make the noise a random walk along the
/// path: split an interval in two and the two halves' noise adds up to the whole's, so the
/// publishing rate does not matter. The four constants are GMapping's `srr`, `str`, `srt`,
/// `stt` (Grisetti et al. 2007) read as σ over one metre or one radian of motion; the
/// defaults are GMapping's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Increment {
    /// Translation σ after 1 m travelled (m/√m); GMapping `srr` 0.1.
    pub translation_per_m: f64,
    /// Translation σ after 1 rad turned (m/√rad); GMapping `str` 0.1.
    pub translation_per_rad: f64,
    /// Rotation σ after 1 m travelled (rad/√m); GMapping `srt` 0.2.
    pub rotation_per_m: f64,
    /// Rotation σ after 1 rad turned (rad/√rad); GMapping `stt` 0.2.
    pub rotation_per_rad: f64,
}

impl Default for Increment {
    fn default() -> Self {
        Self {
            translation_per_m: 0.1,
            translation_per_rad: 0.1,
            rotation_per_m: 0.2,
            rotation_per_rad: 0.2,
        }
    }
}

impl Increment {
    /// The noise variances `[σ²_x, σ²_y, σ²_θ]` of increment `delta`.
    fn variances(&self, delta: &Pose2) -> [f64; 3] {
        let d = delta.x.hypot(delta.y);
        let turn = delta.theta.abs();
        let trans = self.translation_per_m.powi(2) * d + self.translation_per_rad.powi(2) * turn;
        let rot = self.rotation_per_m.powi(2) * d + self.rotation_per_rad.powi(2) * turn;
        [trans, trans, rot]
    }
}

/// The motion model, chosen in TOML by `model = "unicycle"`, `"bicycle"` or
/// `"increment"` next to that model's fields. Default: Bailey's bicycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum MotionModel {
    /// Control (v, ω).
    Unicycle(Unicycle),
    /// Control (v, γ) with a wheelbase.
    Bicycle(Bicycle),
    /// Control: the odometry's pose increment.
    Increment(Increment),
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
            Self::Increment(i) => {
                non_negative("motion.translation_per_m", i.translation_per_m)?;
                non_negative("motion.translation_per_rad", i.translation_per_rad)?;
                non_negative("motion.rotation_per_m", i.rotation_per_m)?;
                non_negative("motion.rotation_per_rad", i.rotation_per_rad)
            }
        }
    }

    /// The same model with every noise variance multiplied by `k` (σ's by `√k`).
    pub fn scaled(&self, k: f64) -> Self {
        let s = k.sqrt();
        match self {
            Self::Unicycle(u) => Self::Unicycle(Unicycle {
                sigma_v: u.sigma_v * s,
                sigma_omega: u.sigma_omega * s,
            }),
            Self::Bicycle(b) => Self::Bicycle(Bicycle {
                sigma_v: b.sigma_v * s,
                sigma_steering: b.sigma_steering * s,
                ..b.clone()
            }),
            Self::Increment(i) => Self::Increment(Increment {
                translation_per_m: i.translation_per_m * s,
                translation_per_rad: i.translation_per_rad * s,
                rotation_per_m: i.rotation_per_m * s,
                rotation_per_rad: i.rotation_per_rad * s,
            }),
        }
    }

    /// Two standard deviations that stand for the model's noise in reports: `σ_v` and
    /// `σ_ω` or `σ_steering` of a velocity model, `translation_per_m` and
    /// `rotation_per_rad` of the increment model.
    pub fn noise_sigmas(&self) -> [f64; 2] {
        match self {
            Self::Increment(i) => [i.translation_per_m, i.rotation_per_rad],
            velocity => velocity.sigmas(),
        }
    }

    /// How much noise the model puts on a motion `delta` along the path (its translation
    /// and heading variances, m² and rad²): the increment model's own variances, and for
    /// the velocity models, whose noise is per unit of time, GMapping's increment noise.
    /// Used to share a correction out along the path between two corrected poses.
    pub fn path_variances(&self, delta: &Pose2) -> [f64; 2] {
        let [trans, _, rot] = match self {
            Self::Increment(model) => model.variances(delta),
            Self::Unicycle(_) | Self::Bicycle(_) => Increment::default().variances(delta),
        };
        [trans, rot]
    }

    /// True for a model driven by the odometry's pose increments rather than velocities.
    pub fn uses_increments(&self) -> bool {
        matches!(self, Self::Increment(_))
    }

    /// The two controls a velocity model uses: (v, ω) or (v, γ); none for the increment
    /// model.
    fn controls(&self, control: &Control) -> [f64; 2] {
        match self {
            Self::Unicycle(_) | Self::Increment(_) => [control.v, control.omega],
            Self::Bicycle(_) => [control.v, control.steering],
        }
    }

    /// Noise-free step of a velocity model from `pose` with its two controls `u` over `dt`
    /// seconds (the increment model does not step by velocities: see
    /// [`Self::propagate`]).
    fn step(&self, pose: &Pose2, u: [f64; 2], dt: f64) -> Pose2 {
        let [v, second] = u;
        match self {
            Self::Unicycle(_) | Self::Increment(_) => Pose2::new(
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

    /// Deterministic (noise-free) propagation of `pose` by `control` over `dt` seconds (the
    /// increment model ignores `dt`: `pose ⊕ δ`).
    pub fn propagate(&self, pose: &Pose2, control: &Control, dt: f64) -> Pose2 {
        match self {
            Self::Increment(_) => pose.compose(&control.increment),
            _ => self.step(pose, self.controls(control), dt),
        }
    }

    /// Draws the next pose from `p(x' | x, u)`: Gaussian noise on the controls (the two
    /// velocities, or the increment's three components), then the noise-free step.
    pub fn sample(&self, pose: &Pose2, control: &Control, dt: f64, rng: &mut impl Rng) -> Pose2 {
        if let Self::Increment(model) = self {
            let d = control.increment;
            let [vx, vy, vt] = model.variances(&d);
            let noisy = Pose2::new(
                d.x + vx.sqrt() * rng.sample::<f64, _>(StandardNormal),
                d.y + vy.sqrt() * rng.sample::<f64, _>(StandardNormal),
                d.theta + vt.sqrt() * rng.sample::<f64, _>(StandardNormal),
            );
            return pose.compose(&noisy);
        }
        let [v, second] = self.controls(control);
        let [sv, ss] = self.sigmas();
        let noisy = [
            v + sv * rng.sample::<f64, _>(StandardNormal),
            second + ss * rng.sample::<f64, _>(StandardNormal),
        ];
        self.step(pose, noisy, dt)
    }

    /// Standard deviations of a velocity model's two controls' noise (none for the
    /// increment model, whose noise depends on the increment).
    fn sigmas(&self) -> [f64; 2] {
        match self {
            Self::Unicycle(u) => [u.sigma_v, u.sigma_omega],
            Self::Bicycle(b) => [b.sigma_v, b.sigma_steering],
            Self::Increment(_) => [0.0, 0.0],
        }
    }

    /// Covariance `Q` of a velocity model's two controls' noise, `diag(σ_v², σ²)`.
    fn control_noise(&self) -> Matrix2<f64> {
        let [sv, ss] = self.sigmas();
        Matrix2::new(sv * sv, 0.0, 0.0, ss * ss)
    }

    /// Jacobians of [`propagate`](Self::propagate) at (`pose`, `control`, `dt`); for the
    /// increment model `wrt_control` is ∂(pose ⊕ δ)/∂(δx, δy) (its heading column is in
    /// [`Self::pose_noise`]).
    pub fn jacobians(&self, pose: &Pose2, control: &Control, dt: f64) -> MotionJacobians {
        if matches!(self, Self::Increment(_)) {
            let d = control.increment;
            let (s, c) = pose.theta.sin_cos();
            return MotionJacobians {
                wrt_pose: Matrix3::new(
                    1.0,
                    0.0,
                    -s * d.x - c * d.y,
                    0.0,
                    1.0,
                    c * d.x - s * d.y,
                    0.0,
                    0.0,
                    1.0,
                ),
                wrt_control: Matrix3x2::new(c, -s, s, c, 0.0, 0.0),
            };
        }
        let [v, second] = self.controls(control);
        let heading = match self {
            Self::Unicycle(_) | Self::Increment(_) => pose.theta,
            Self::Bicycle(_) => pose.theta + second,
        };
        let (s, c) = heading.sin_cos();
        let wrt_pose = Matrix3::new(1.0, 0.0, -v * dt * s, 0.0, 1.0, v * dt * c, 0.0, 0.0, 1.0);
        let wrt_control = match self {
            Self::Unicycle(_) | Self::Increment(_) => {
                Matrix3x2::new(dt * c, 0.0, dt * s, 0.0, 0.0, dt)
            }
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
    /// A velocity model's has rank at most 2 (two noisy controls move three pose
    /// coordinates); a consumer that inverts it (a motion prior) must regularise it. The
    /// increment model's is `R Σ Rᵀ`, its noise `Σ` rotated into the map frame.
    pub fn pose_noise(&self, pose: &Pose2, control: &Control, dt: f64) -> Matrix3<f64> {
        if let Self::Increment(model) = self {
            let [vx, vy, vt] = model.variances(&control.increment);
            let (s, c) = pose.theta.sin_cos();
            let r = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
            return r * Matrix3::from_diagonal(&nalgebra::Vector3::new(vx, vy, vt)) * r.transpose();
        }
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
        ..Control::ZERO
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

    /// A turn-and-drive increment seen from a start pose, for the increment model.
    fn increment_control() -> Control {
        Control::between_poses(
            &Pose2::new(2.0, -1.0, 2.5),
            &Pose2::new(2.0 + 0.8 * 2.7f64.cos(), -1.0 + 0.8 * 2.7f64.sin(), 2.9),
            0.0,
            0.0,
        )
    }

    #[test]
    fn increment_between_poses_composes_back_to_the_end_pose() {
        let (from, to) = (Pose2::new(1.0, 2.0, 3.0), Pose2::new(-0.5, 2.2, -3.1));
        let control = Control::between_poses(&from, &to, 0.3, 0.1);
        let model = MotionModel::Increment(Increment::default());
        let end = model.propagate(&from, &control, 123.0);
        assert!(pose_diff(&end, &to).norm() < 1e-12);
        assert!((control.increment.theta - wrap_angle(-6.1)).abs() < 1e-12);
        assert_eq!((control.v, control.omega), (0.3, 0.1));
    }

    #[test]
    fn increment_samples_match_mean_and_projected_covariance() {
        let model = MotionModel::Increment(Increment::default());
        let pose = Pose2::new(0.0, 0.0, 0.7);
        let control = increment_control();
        let mean = model.propagate(&pose, &control, 0.0);
        let predicted = model.pose_noise(&pose, &control, 0.0);
        let j = model.jacobians(&pose, &control, 0.0);
        let mut rng = seeded(22);
        let n = 40_000;
        let mut cov = Matrix3::zeros();
        for _ in 0..n {
            let d = pose_diff(&model.sample(&pose, &control, 0.0, &mut rng), &mean);
            cov += d * d.transpose() / n as f64;
        }
        // The heading noise moves the end point too (second order in the small-noise
        // limit): compare the linearised covariance with a 10 % tolerance.
        for r in 0..3 {
            for c in 0..3 {
                let tol = 0.1 * (predicted[(r, r)] * predicted[(c, c)]).sqrt();
                assert!(
                    (cov[(r, c)] - predicted[(r, c)]).abs() < tol,
                    "({r},{c}): {} vs {}",
                    cov[(r, c)],
                    predicted[(r, c)]
                );
            }
        }
        // ∂(pose ⊕ δ)/∂pose, by finite differences.
        let h = 1e-6;
        for k in 0..3 {
            let mut p = [pose.x, pose.y, pose.theta];
            p[k] += h;
            let moved = model.propagate(&Pose2::new(p[0], p[1], p[2]), &control, 0.0);
            let d = pose_diff(&moved, &mean) / h;
            assert!((d - j.wrt_pose.column(k)).norm() < 1e-5);
        }
    }

    #[test]
    fn increment_noise_does_not_depend_on_the_publishing_rate() {
        // Straight ahead 2 m in one message, or in 1 000 messages of 2 mm: the noise
        // variances add up to the same.
        let model = MotionModel::Increment(Increment::default());
        let whole = Control {
            increment: Pose2::new(2.0, 0.0, 0.0),
            ..Control::ZERO
        };
        let part = Control {
            increment: Pose2::new(0.002, 0.0, 0.0),
            ..Control::ZERO
        };
        let pose = Pose2::default();
        let one = model.pose_noise(&pose, &whole, 1.0);
        let mut many = Matrix3::zeros();
        for _ in 0..1000 {
            many += model.pose_noise(&pose, &part, 0.001);
        }
        assert!((one - many).norm() < 1e-12 * one.norm().max(1.0));
        assert!((one[(0, 0)] - 0.1f64.powi(2) * 2.0).abs() < 1e-15);
        assert!((one[(2, 2)] - 0.2f64.powi(2) * 2.0).abs() < 1e-15);
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
        let m: MotionModel =
            toml::from_str("model = \"increment\"\nrotation_per_m = 0.05").unwrap();
        assert_eq!(
            m,
            MotionModel::Increment(Increment {
                rotation_per_m: 0.05,
                ..Increment::default()
            })
        );
        let bad = MotionModel::Bicycle(Bicycle {
            wheelbase: 0.0,
            ..Bicycle::default()
        });
        assert!(bad.validate().is_err());
    }
}
