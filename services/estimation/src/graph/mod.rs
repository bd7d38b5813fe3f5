//! Full SLAM as nonlinear least squares (docs/ALGORITHMS.md §8): the poses at the scans
//! and the landmark positions, estimated jointly from every odometry interval and every
//! landmark observation — the maximum a posteriori solution a filter approximates. One
//! solver serves two users: the client's *reference* (what the data supports, with the
//! true landmark ids) and the service's *smoothing back-end* (with the best particle's
//! associations).
//!
//! - [`Graph`] holds the variables (poses `x_i = (x, y, θ)`, landmarks `m_k = (x, y)`) and
//!   the factors: a prior on the first pose, [`Between`] factors from odometry (the
//!   relative pose the controls integrate to, with its covariance), and [`Sighting`]
//!   factors (a range–bearing observation of a landmark from a pose).
//! - [`Graph::solve`] runs Levenberg–Marquardt on the normal equations `(H + λ D) δ = −g`,
//!   `H = Σ Jᵀ W J`, solved by a sparse Cholesky factorisation (faer, fill-reducing
//!   ordering) whose structure and symbolic part are computed once per solve; each
//!   iteration writes the factors' fixed-size blocks straight into the matrix. The
//!   [`Damping`] schedule and the [`PoseUpdate`] are options:
//!   [`SolveOptions::pose_graph`] picks GTSAM's (Levenberg's damping, the exponential
//!   update), which converge in a few iterations on pose graphs with long loops.
//! - A robust kernel ([`Kernel`]) down-weights sightings whose normalised residual is
//!   large, so a wrong association bends the solution less than a right one.
//! - [`OdometryIntegrator`] turns the controls between two scans into a [`Between`]
//!   factor with the filter's own motion model and noise.
//! - [`g2o`] reads and writes pose graphs in the g2o text format (2D: `VERTEX_SE2`,
//!   `EDGE_SE2`, `VERTEX_XY`, `EDGE_SE2_XY`, `FIX`): their pose edges are [`Between`]
//!   factors with the SE(2) logarithm residual ([`PoseResidual::Logmap`]) and their
//!   landmark edges [`Offset`] factors.

mod consistency;
mod duplicates;
pub mod g2o;
mod integrate;
mod smoother;
mod solve;
mod system;
mod variance;
mod window;

pub use consistency::{Fit, TornGate};
pub use duplicates::duplicates;
pub use integrate::OdometryIntegrator;
pub use smoother::{Feed, KernelKind, NoiseModel, Smoother, SmootherConfig, Solution};
pub use solve::{Covariances, Damping, Kernel, PoseUpdate, SolveOptions, SolveReport};
pub use variance::{Component, MIN_REDUNDANCY, VarianceComponents};

use crate::observation::{Observation, predict};
use crate::pose::{Pose2, wrap_angle};
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

/// An odometry factor: pose `to` seen from pose `from` is `delta` (in `from`'s frame),
/// with information (inverse covariance) `information`, a full symmetric 3 × 3 matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Between {
    /// Index of the earlier pose.
    pub from: usize,
    /// Index of the later pose.
    pub to: usize,
    /// The relative pose `from⁻¹ ∘ to` the odometry measured (m, m, rad).
    pub delta: Pose2,
    /// Inverse covariance of `delta` (in `from`'s frame).
    pub information: Matrix3<f64>,
    /// How the mismatch between `delta` and the estimates' relative pose is measured.
    pub residual: PoseResidual,
}

/// The residual of a [`Between`] factor, `p = from⁻¹ ∘ to` being the estimates' relative
/// pose, `R(·)` a rotation and `t` a translation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PoseResidual {
    /// Translation and heading apart: `(t_p − t_δ, θ_p − θ_δ)`, both in `from`'s frame —
    /// the odometry factors' form.
    #[default]
    Componentwise,
    /// The SE(2) logarithm of `δ⁻¹ ∘ p`: `(V(φ)⁻¹ R(θ_δ)ᵀ (t_p − t_δ), φ)`, `φ = θ_p − θ_δ`
    /// and `V(φ)⁻¹ = [[a, φ/2], [−φ/2, a]]`, `a = (φ/2) cot(φ/2)` — the pose-graph
    /// convention of GTSAM's between factor, used for g2o edges.
    Logmap,
}

/// A landmark's position measured in a pose's frame (x ahead, y left): a g2o
/// `EDGE_SE2_XY`. Its residual is `R(θ)ᵀ (m − t) − offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Offset {
    /// Index of the observing pose.
    pub pose: usize,
    /// Index of the landmark.
    pub landmark: usize,
    /// The landmark in the pose's frame (m).
    pub offset: Vector2<f64>,
    /// Inverse covariance of `offset`.
    pub information: Matrix2<f64>,
}

/// A landmark observation factor: landmark `landmark` seen from pose `pose` at range and
/// bearing `z`, with information `information` (the sensor's `R⁻¹`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// Index of the observing pose.
    pub pose: usize,
    /// Index of the landmark.
    pub landmark: usize,
    /// Range (m) and bearing (rad).
    pub z: Vector2<f64>,
    /// Inverse covariance of `z`.
    pub information: Matrix2<f64>,
}

/// A prior on one pose: it is `mean`, with information `information`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Index of the pose.
    pub pose: usize,
    /// Its prior mean.
    pub mean: Pose2,
    /// Inverse covariance of the prior.
    pub information: Matrix3<f64>,
}

/// A prior on one landmark: it is `mean`, with information `information` (what sightings
/// from poses held fixed say about it, in a window solve).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkPrior {
    /// Index of the landmark.
    pub landmark: usize,
    /// Its prior mean.
    pub mean: Vector2<f64>,
    /// Inverse covariance of the prior.
    pub information: Matrix2<f64>,
}

/// The variables and factors of a full-SLAM problem; see the module documentation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Graph {
    /// Pose estimates, in time order (initial values until solved).
    pub poses: Vec<Pose2>,
    /// Landmark position estimates.
    pub landmarks: Vec<Vector2<f64>>,
    /// Priors (usually one: the first pose is the map frame's origin).
    pub priors: Vec<Prior>,
    /// Odometry factors.
    pub betweens: Vec<Between>,
    /// Observation factors.
    pub sightings: Vec<Sighting>,
    /// Landmark positions measured in a pose's frame.
    pub offsets: Vec<Offset>,
    /// Priors on landmarks.
    pub landmark_priors: Vec<LandmarkPrior>,
}

/// One factor's residual and its Jacobians with respect to the variables it touches.
pub(crate) enum Linearised {
    /// Residual (3) and Jacobian w.r.t. one pose.
    Prior { r: Vector3<f64>, j: Matrix3<f64> },
    /// Residual (3) and Jacobians w.r.t. the two poses (the solver takes them from
    /// [`Between::jacobians`] directly).
    #[cfg(test)]
    Between {
        r: Vector3<f64>,
        j_from: Matrix3<f64>,
        j_to: Matrix3<f64>,
    },
    /// Residual (2) and Jacobians w.r.t. the pose and the landmark.
    Sighting {
        r: Vector2<f64>,
        j_pose: Matrix2x3<f64>,
        j_landmark: Matrix2<f64>,
    },
}

impl Prior {
    /// Residual `x ⊖ mean` (heading wrapped) at `pose`.
    pub(crate) fn linearise(&self, pose: &Pose2) -> Linearised {
        let r = Vector3::new(
            pose.x - self.mean.x,
            pose.y - self.mean.y,
            wrap_angle(pose.theta - self.mean.theta),
        );
        Linearised::Prior {
            r,
            j: Matrix3::identity(),
        }
    }
}

impl Between {
    /// Residual ([`PoseResidual`]) at the two poses, with its Jacobians.
    #[cfg(test)]
    pub(crate) fn linearise(&self, from: &Pose2, to: &Pose2) -> Linearised {
        let (r, j_from, j_to) = self.jacobians(from, to);
        Linearised::Between { r, j_from, j_to }
    }

    /// `to` in `from`'s frame (translation) and the heading mismatch `θ_p − θ_δ`, wrapped.
    fn relative(&self, from: &Pose2, to: &Pose2) -> (f64, f64, Vector2<f64>, f64) {
        let (s, c) = from.theta.sin_cos();
        let (dx, dy) = (to.x - from.x, to.y - from.y);
        let local = Vector2::new(c * dx + s * dy, -s * dx + c * dy);
        let phi = wrap_angle(to.theta - from.theta - self.delta.theta);
        (s, c, local, phi)
    }

    /// The residual at the two poses.
    pub(crate) fn residual(&self, from: &Pose2, to: &Pose2) -> Vector3<f64> {
        let (_, _, local, phi) = self.relative(from, to);
        let u = Vector2::new(local.x - self.delta.x, local.y - self.delta.y);
        match self.residual {
            PoseResidual::Componentwise => Vector3::new(u.x, u.y, phi),
            PoseResidual::Logmap => {
                let ((te, _), (a, _)) = (self.unrotate(&u), half_cot(phi, false));
                let h = 0.5 * phi;
                Vector3::new(a * te.x + h * te.y, -h * te.x + a * te.y, phi)
            }
        }
    }

    /// `R(θ_δ)ᵀ u` and `R(θ_δ)ᵀ` itself.
    fn unrotate(&self, u: &Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let (sz, cz) = self.delta.theta.sin_cos();
        let te = Vector2::new(cz * u.x + sz * u.y, -sz * u.x + cz * u.y);
        (te, Matrix2::new(cz, sz, -sz, cz))
    }

    /// The residual and its Jacobians with respect to `from` and `to` (in the solver's
    /// `(x, y, θ)` increments).
    pub(crate) fn jacobians(
        &self,
        from: &Pose2,
        to: &Pose2,
    ) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let (s, c, local, phi) = self.relative(from, to);
        let u = Vector2::new(local.x - self.delta.x, local.y - self.delta.y);
        match self.residual {
            PoseResidual::Componentwise => {
                let r = Vector3::new(u.x, u.y, phi);
                let j_from = Matrix3::new(-c, -s, local.y, s, -c, -local.x, 0.0, 0.0, -1.0);
                let j_to = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
                (r, j_from, j_to)
            }
            PoseResidual::Logmap => {
                let ((te, rz), (a, da)) = (self.unrotate(&u), half_cot(phi, true));
                let h = 0.5 * phi;
                let r = Vector3::new(a * te.x + h * te.y, -h * te.x + a * te.y, phi);
                // ∂e/∂φ through V(φ)⁻¹, and V(φ)⁻¹ R(θ_δ)ᵀ, the map from the local
                // translation to the residual's.
                let dphi = Vector2::new(da * te.x + 0.5 * te.y, -0.5 * te.x + da * te.y);
                let m = Matrix2::new(a, h, -h, a) * rz;
                let dt = m * Matrix2::new(c, s, -s, c);
                let dtheta = m * Vector2::new(local.y, -local.x) - dphi;
                let j_to = Matrix3::new(
                    dt[(0, 0)],
                    dt[(0, 1)],
                    dphi.x,
                    dt[(1, 0)],
                    dt[(1, 1)],
                    dphi.y,
                    0.0,
                    0.0,
                    1.0,
                );
                let j_from = Matrix3::new(
                    -dt[(0, 0)],
                    -dt[(0, 1)],
                    dtheta.x,
                    -dt[(1, 0)],
                    -dt[(1, 1)],
                    dtheta.y,
                    0.0,
                    0.0,
                    -1.0,
                );
                (r, j_from, j_to)
            }
        }
    }
}

/// `a(φ) = (φ/2) cot(φ/2)`, the diagonal of `V(φ)⁻¹`, and (when `derivative`) `a′(φ)`;
/// a series near zero, where the closed form cancels.
fn half_cot(phi: f64, derivative: bool) -> (f64, f64) {
    let p2 = phi * phi;
    if phi.abs() < 1e-3 {
        return (
            1.0 - p2 / 12.0 - p2 * p2 / 720.0,
            -phi / 6.0 - phi * p2 / 180.0,
        );
    }
    let h = 0.5 * phi;
    let (sh, ch) = h.sin_cos();
    let cot = ch / sh;
    let da = if derivative {
        0.5 * (cot - h / (sh * sh))
    } else {
        0.0
    };
    (h * cot, da)
}

impl Offset {
    /// The residual `R(θ)ᵀ (m − t) − offset` at `pose` and `landmark`, with its Jacobians
    /// with respect to both.
    pub(crate) fn jacobians(
        &self,
        pose: &Pose2,
        landmark: &Vector2<f64>,
    ) -> (Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
        let (s, c) = pose.theta.sin_cos();
        let (dx, dy) = (landmark.x - pose.x, landmark.y - pose.y);
        let local = Vector2::new(c * dx + s * dy, -s * dx + c * dy);
        let r = local - self.offset;
        let j_pose = Matrix2x3::new(-c, -s, local.y, s, -c, -local.x);
        (r, j_pose, Matrix2::new(c, s, -s, c))
    }

    /// The residual alone.
    pub(crate) fn residual(&self, pose: &Pose2, landmark: &Vector2<f64>) -> Vector2<f64> {
        let (s, c) = pose.theta.sin_cos();
        let (dx, dy) = (landmark.x - pose.x, landmark.y - pose.y);
        Vector2::new(c * dx + s * dy, -s * dx + c * dy) - self.offset
    }
}

impl Sighting {
    /// Residual `h(pose, landmark) − z` (bearing wrapped) with its Jacobians; `None` when
    /// the landmark sits on the pose (no bearing).
    pub(crate) fn linearise(&self, pose: &Pose2, landmark: &Vector2<f64>) -> Option<Linearised> {
        let p = predict(pose, landmark)?;
        let r = Vector2::new(p.z[0] - self.z[0], wrap_angle(p.z[1] - self.z[1]));
        Some(Linearised::Sighting {
            r,
            j_pose: p.wrt_pose,
            j_landmark: p.wrt_landmark,
        })
    }
}

impl Graph {
    /// Adds a pose (its initial value) and returns its index.
    pub fn add_pose(&mut self, initial: Pose2) -> usize {
        self.poses.push(initial);
        self.poses.len() - 1
    }

    /// Adds a landmark (its initial value) and returns its index.
    pub fn add_landmark(&mut self, initial: Vector2<f64>) -> usize {
        self.landmarks.push(initial);
        self.landmarks.len() - 1
    }

    /// Adds a sighting of landmark `landmark` from pose `pose`: `observation` with the
    /// sensor noise covariance `noise` (`R`).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for an index out of range, a non-finite observation or a
    /// noise that is not positive definite.
    pub fn add_sighting(
        &mut self,
        pose: usize,
        landmark: usize,
        observation: &Observation,
        noise: &Matrix2<f64>,
    ) -> Result<()> {
        let information = noise
            .try_inverse()
            .filter(|i| i.iter().all(|v| v.is_finite()));
        match information {
            Some(information)
                if pose < self.poses.len()
                    && landmark < self.landmarks.len()
                    && observation.validate().is_ok() =>
            {
                self.sightings.push(Sighting {
                    pose,
                    landmark,
                    z: observation.z(),
                    information,
                });
                Ok(())
            }
            _ => Err(Error::InvalidInput {
                what: "sighting",
                reason: format!(
                    "pose {pose} of {}, landmark {landmark} of {}, {observation:?}, noise {noise:?}",
                    self.poses.len(),
                    self.landmarks.len()
                ),
            }),
        }
    }

    /// Number of scalar unknowns (3 per pose, 2 per landmark).
    pub fn unknowns(&self) -> usize {
        3 * self.poses.len() + 2 * self.landmarks.len()
    }

    /// Number of scalar residuals (3 per prior and odometry factor, 2 per sighting, offset
    /// and landmark prior).
    pub fn residuals(&self) -> usize {
        3 * (self.priors.len() + self.betweens.len())
            + 2 * (self.sightings.len() + self.offsets.len() + self.landmark_priors.len())
    }

    /// `χ² = Σ rᵀ Ω r` over every factor at the current estimates (no robust kernel):
    /// about the number of residuals minus the unknowns for a model whose noise is right.
    pub fn chi2(&self) -> f64 {
        let mut chi2 = 0.0;
        for p in &self.priors {
            if let Linearised::Prior { r, .. } = p.linearise(&self.poses[p.pose]) {
                chi2 += (r.transpose() * p.information * r)[0];
            }
        }
        for p in &self.landmark_priors {
            let r = self.landmarks[p.landmark] - p.mean;
            chi2 += (r.transpose() * p.information * r)[0];
        }
        chi2 + self.chi2_measurements()
    }

    /// [`chi2`](Self::chi2) without the priors: `Σ rᵀ Ω r` over the measurements (odometry
    /// factors, sightings, offsets) — what a pose-graph tool reports for a graph whose
    /// priors only anchor it.
    pub fn chi2_measurements(&self) -> f64 {
        let mut chi2 = 0.0;
        for b in &self.betweens {
            let r = b.residual(&self.poses[b.from], &self.poses[b.to]);
            chi2 += (r.transpose() * b.information * r)[0];
        }
        for s in &self.sightings {
            if let Some(Linearised::Sighting { r, .. }) =
                s.linearise(&self.poses[s.pose], &self.landmarks[s.landmark])
            {
                chi2 += (r.transpose() * s.information * r)[0];
            }
        }
        for o in &self.offsets {
            let r = o.residual(&self.poses[o.pose], &self.landmarks[o.landmark]);
            chi2 += (r.transpose() * o.information * r)[0];
        }
        chi2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `f` at `x` in each of its coordinates.
    fn numeric<const N: usize, const M: usize>(
        x: [f64; N],
        f: impl Fn([f64; N]) -> nalgebra::SVector<f64, M>,
    ) -> nalgebra::SMatrix<f64, M, N> {
        let h = 1e-6;
        nalgebra::SMatrix::from_fn(|row, col| {
            let (mut a, mut b) = (x, x);
            a[col] += h;
            b[col] -= h;
            (f(a)[row] - f(b)[row]) / (2.0 * h)
        })
    }

    #[test]
    fn between_jacobians_match_finite_differences() {
        let b = Between {
            from: 0,
            to: 1,
            delta: Pose2::new(1.0, 0.2, 0.1),
            information: Matrix3::identity(),
            residual: PoseResidual::Componentwise,
        };
        let (from, to) = ([0.3, -0.2, 0.7], [1.4, 0.9, 0.95]);
        let r = |f: [f64; 3], t: [f64; 3]| match b
            .linearise(&Pose2::new(f[0], f[1], f[2]), &Pose2::new(t[0], t[1], t[2]))
        {
            Linearised::Between { r, .. } => r,
            _ => unreachable!(),
        };
        let Linearised::Between { j_from, j_to, .. } = b.linearise(
            &Pose2::new(from[0], from[1], from[2]),
            &Pose2::new(to[0], to[1], to[2]),
        ) else {
            unreachable!()
        };
        assert!(
            (j_from - numeric(from, |f| r(f, to))).norm() < 1e-6,
            "{j_from}"
        );
        assert!((j_to - numeric(to, |t| r(from, t))).norm() < 1e-6, "{j_to}");
    }

    #[test]
    fn logmap_between_residual_and_jacobians() {
        let b = Between {
            from: 0,
            to: 1,
            delta: Pose2::new(1.0, 0.2, 0.1),
            information: Matrix3::identity(),
            residual: PoseResidual::Logmap,
        };
        // Against the SE(2) logarithm of δ⁻¹ ∘ from⁻¹ ∘ to written out: V(φ)⁻¹ t.
        let (from, to) = (Pose2::new(0.3, -0.2, 0.7), Pose2::new(1.4, 0.9, 2.95));
        let e = b.delta.inverse().compose(&from.inverse().compose(&to));
        let phi = e.theta;
        let v = Matrix2::new(phi.sin(), phi.cos() - 1.0, 1.0 - phi.cos(), phi.sin()) / phi;
        let t = v.try_inverse().unwrap() * Vector2::new(e.x, e.y);
        let r = b.residual(&from, &to);
        assert!((r - Vector3::new(t.x, t.y, phi)).norm() < 1e-12, "{r}");
        for (from, to) in [
            ([0.3, -0.2, 0.7], [1.4, 0.9, 2.95]),
            ([0.3, -0.2, 0.7], [1.3, 0.0, 0.8]),
            ([0.3, -0.2, 0.7], [1.3, 0.0, 0.80004]),
            ([-2.0, 1.0, 3.0], [-3.0, 1.5, -3.0]),
        ] {
            let r = |f: [f64; 3], t: [f64; 3]| {
                b.residual(&Pose2::new(f[0], f[1], f[2]), &Pose2::new(t[0], t[1], t[2]))
            };
            let (_, j_from, j_to) = b.jacobians(
                &Pose2::new(from[0], from[1], from[2]),
                &Pose2::new(to[0], to[1], to[2]),
            );
            let (n_from, n_to) = (numeric(from, |f| r(f, to)), numeric(to, |t| r(from, t)));
            assert!((j_from - n_from).norm() < 1e-6, "{j_from} vs {n_from}");
            assert!((j_to - n_to).norm() < 1e-6, "{j_to} vs {n_to}");
        }
    }

    #[test]
    fn offset_jacobians_match_finite_differences() {
        let o = Offset {
            pose: 0,
            landmark: 0,
            offset: Vector2::new(2.0, -1.0),
            information: Matrix2::identity(),
        };
        let (pose, landmark) = ([0.3, -0.2, 0.7], [3.0, 4.0]);
        let r = |p: [f64; 3], m: [f64; 2]| {
            o.residual(&Pose2::new(p[0], p[1], p[2]), &Vector2::new(m[0], m[1]))
        };
        let (_, j_pose, j_landmark) = o.jacobians(
            &Pose2::new(pose[0], pose[1], pose[2]),
            &Vector2::new(landmark[0], landmark[1]),
        );
        assert!((j_pose - numeric(pose, |p| r(p, landmark))).norm() < 1e-6);
        assert!((j_landmark - numeric(landmark, |m| r(pose, m))).norm() < 1e-6);
    }

    #[test]
    fn sighting_jacobians_match_finite_differences() {
        let s = Sighting {
            pose: 0,
            landmark: 0,
            z: Vector2::new(5.0, 0.3),
            information: Matrix2::identity(),
        };
        let (pose, landmark) = ([0.3, -0.2, 0.7], [3.0, 4.0]);
        let r = |p: [f64; 3], m: [f64; 2]| match s
            .linearise(&Pose2::new(p[0], p[1], p[2]), &Vector2::new(m[0], m[1]))
        {
            Some(Linearised::Sighting { r, .. }) => r,
            _ => unreachable!(),
        };
        let Some(Linearised::Sighting {
            j_pose, j_landmark, ..
        }) = s.linearise(
            &Pose2::new(pose[0], pose[1], pose[2]),
            &Vector2::new(landmark[0], landmark[1]),
        )
        else {
            unreachable!()
        };
        assert!((j_pose - numeric(pose, |p| r(p, landmark))).norm() < 1e-6);
        assert!((j_landmark - numeric(landmark, |m| r(pose, m))).norm() < 1e-6);
    }
}

#[cfg(test)]
mod solve_tests {
    use super::*;
    use crate::motion::{Control, MotionModel, Unicycle};
    use crate::observation::measure;
    use crate::rng::seeded;
    use rand::RngExt;
    use rand_distr::StandardNormal;

    const DT: f64 = 0.1;
    const PER_SCAN: usize = 5;

    /// A unicycle on a circle among `n` landmarks: the true poses at the scans, the true
    /// landmarks, and the graph built from odometry and observations with `noise` (0:
    /// exact), starting from dead reckoning.
    fn circle(noise: f64, scans: usize, seed: u64) -> (Vec<Pose2>, Vec<Vector2<f64>>, Graph) {
        let mut rng = seeded(seed);
        let mut normal = || noise * rng.sample::<f64, _>(StandardNormal);
        let motion = MotionModel::Unicycle(Unicycle {
            sigma_v: 0.1,
            sigma_omega: 0.05,
        });
        let (sv, sw) = (0.1, 0.05);
        let (sr, sb) = (0.1, 0.02);
        let r = Matrix2::from_diagonal(&Vector2::new(sr * sr, sb * sb));
        let landmarks: Vec<Vector2<f64>> = (0..12)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 12.0;
                Vector2::new(14.0 * a.cos(), 10.0 + 14.0 * a.sin())
            })
            .collect();
        let mut graph = Graph::default();
        for m in &landmarks {
            graph.add_landmark(m + Vector2::new(1.0, -1.0));
        }
        let control = Control {
            v: 1.0,
            omega: 0.1,
            steering: 0.0,
            ..Control::ZERO
        };
        let mut truth = vec![Pose2::default()];
        let (mut x, mut dead) = (Pose2::default(), Pose2::default());
        graph.add_pose(dead);
        graph.priors.push(Prior {
            pose: 0,
            mean: Pose2::default(),
            information: Matrix3::identity() * 1e8,
        });
        let floor = Matrix3::identity() * 1e-10;
        let mut odometry = OdometryIntegrator::new(motion.clone(), floor);
        for s in 1..=scans {
            for _ in 0..PER_SCAN {
                x = motion.propagate(&x, &control, DT);
                let measured = Control {
                    v: control.v + sv * normal(),
                    omega: control.omega + sw * normal(),
                    steering: 0.0,
                    ..Control::ZERO
                };
                odometry.add(&measured, DT);
                dead = motion.propagate(&dead, &measured, DT);
            }
            truth.push(x);
            let i = graph.add_pose(dead);
            graph.betweens.push(odometry.take(s - 1, s).unwrap());
            for (k, m) in landmarks.iter().enumerate() {
                let z = measure(&x, m);
                if z[0] < 12.0 {
                    let obs = Observation {
                        range: z[0] + sr * normal(),
                        bearing: z[1] + sb * normal(),
                        id: Some(k as u64),
                    };
                    graph.add_sighting(i, k, &obs, &r).unwrap();
                }
            }
        }
        (truth, landmarks, graph)
    }

    fn worst(truth: &[Pose2], graph: &Graph) -> f64 {
        truth
            .iter()
            .zip(&graph.poses)
            .map(|(t, p)| (t.x - p.x).hypot(t.y - p.y))
            .fold(0.0, f64::max)
    }

    #[test]
    fn noise_free_data_is_solved_exactly_from_a_wrong_start() {
        let (truth, landmarks, mut graph) = circle(0.0, 120, 1);
        // A start far off: dead reckoning is exact here, so bend it.
        for (i, p) in graph.poses.iter_mut().enumerate().skip(1) {
            *p = Pose2::new(p.x + 0.01 * i as f64, p.y, p.theta + 0.05);
        }
        let report = graph.solve(&SolveOptions::default()).unwrap();
        assert!(report.converged, "{report:?}");
        assert!(worst(&truth, &graph) < 1e-6, "{}", worst(&truth, &graph));
        let landmark_error = landmarks
            .iter()
            .zip(&graph.landmarks)
            .map(|(t, m)| (t - m).norm())
            .fold(0.0, f64::max);
        assert!(landmark_error < 1e-6, "{landmark_error}");
        assert!(graph.chi2() < 1e-9, "{}", graph.chi2());
    }

    #[test]
    fn with_the_right_noise_chi2_per_degree_of_freedom_is_about_one() {
        let mut ratios = Vec::new();
        for seed in 1..=8 {
            let (truth, _, mut graph) = circle(1.0, 150, seed);
            let dead_reckoning = worst(&truth, &graph);
            graph.solve(&SolveOptions::default()).unwrap();
            let dof = (graph.residuals() - graph.unknowns()) as f64;
            ratios.push(graph.chi2() / dof);
            assert!(worst(&truth, &graph) < dead_reckoning, "seed {seed}");
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        // Each ratio has a standard deviation of about √(2 / dof) ≈ 0.04.
        assert!((mean - 1.0).abs() < 0.05, "{ratios:?}");
    }

    #[test]
    fn a_robust_kernel_resists_a_wrong_association() {
        let solve = |kernel| {
            let (truth, _, mut graph) = circle(1.0, 150, 3);
            // Ten sightings of landmark 0 attributed to landmark 6 across the circle.
            let wrong: Vec<usize> = (0..graph.sightings.len())
                .filter(|&i| graph.sightings[i].landmark == 0)
                .take(10)
                .collect();
            for i in wrong {
                graph.sightings[i].landmark = 6;
            }
            graph
                .solve(&SolveOptions {
                    kernel,
                    ..SolveOptions::default()
                })
                .unwrap();
            worst(&truth, &graph)
        };
        let (plain, cauchy) = (solve(Kernel::None), solve(Kernel::Cauchy(3.0)));
        assert!(cauchy < 0.5 * plain, "Cauchy {cauchy} m, plain {plain} m");
        assert!(cauchy < 0.5, "{cauchy}");
    }

    #[test]
    fn cross_covariances_of_two_landmarks_seen_from_one_uncertain_pose_are_exact() {
        // One pose with prior covariance Σ (no other factor), two landmarks each seen once
        // from it: linearised, m_k = g(x, z_k), so Cov(m_a, m_b) = J_a Σ J_bᵀ and
        // Var(m_k) = J_k Σ J_kᵀ + G_k R G_kᵀ, J_k = ∂g/∂x.
        let sigma = Matrix3::from_diagonal(&Vector3::new(0.3, 0.2, 0.01));
        let r = Matrix2::from_diagonal(&Vector2::new(0.01, 0.0004));
        let pose = Pose2::new(1.0, -2.0, 0.4);
        let z = [Vector2::new(8.0, 0.5), Vector2::new(5.0, -1.0)];
        let mut graph = Graph::default();
        graph.add_pose(pose);
        graph.priors.push(Prior {
            pose: 0,
            mean: pose,
            information: sigma.try_inverse().unwrap(),
        });
        for (k, z) in z.iter().enumerate() {
            graph.add_landmark(crate::observation::inverse(&pose, z).0);
            let obs = Observation {
                range: z[0],
                bearing: z[1],
                id: None,
            };
            graph.add_sighting(0, k, &obs, &r).unwrap();
        }
        let j = |z: &Vector2<f64>| {
            let (s, c) = (pose.theta + z[1]).sin_cos();
            nalgebra::Matrix2x3::new(1.0, 0.0, -z[0] * s, 0.0, 1.0, z[0] * c)
        };
        let g = |z: &Vector2<f64>| crate::observation::inverse(&pose, z).1;
        let covariances = graph.covariances(Kernel::None).unwrap();
        let blocks = covariances
            .blocks(&[(0, 1), (1, 0), (0, 0), (1, 1)])
            .unwrap();
        let expected = [
            j(&z[0]) * sigma * j(&z[1]).transpose(),
            j(&z[1]) * sigma * j(&z[0]).transpose(),
            j(&z[0]) * sigma * j(&z[0]).transpose() + g(&z[0]) * r * g(&z[0]).transpose(),
            j(&z[1]) * sigma * j(&z[1]).transpose() + g(&z[1]) * r * g(&z[1]).transpose(),
        ];
        for (got, want) in blocks.iter().zip(&expected) {
            assert!((got - want).norm() < 1e-9 * want.norm(), "{got} vs {want}");
        }
        assert_eq!(
            graph.landmark_covariances(Kernel::None).unwrap()[1],
            blocks[3]
        );
        assert!(covariances.blocks(&[(0, 2)]).is_err());
    }
}
