//! Off-lattice refinement of a branch-and-bound match: Levenberg–Marquardt on
//! `Σ (1 − S(T pᵢ))²`, `S` the submap's probabilities smoothed by a 3 × 3 binomial kernel
//! and interpolated bilinearly between cell centres, `T` the scan's pose.
//!
//! The lattice pose is within half a cell and half a heading step of the best one, where
//! the smoothed field still slopes towards it; the refinement is kept only when it lowers
//! the cost and stays within a cell and a heading step of where it started, so a flat or
//! ambiguous neighbourhood leaves the lattice pose as it was.

use super::probability::ProbabilityGrid;
use crate::pose::Pose2;
use nalgebra::{Matrix3, Vector3};

/// Most iterations (accepted or rejected steps).
const ITERATIONS: usize = 20;

/// The refined pose of `points` (base frame) from `start` (submap frame); `start` itself
/// when no better pose lies within `resolution` and `angular_step` of it. With it, the
/// cost's Gauss–Newton curvature `JᵀJ` there (variables x, y, θ).
pub(crate) fn refine(
    grid: &ProbabilityGrid,
    points: &[[f64; 2]],
    start: &Pose2,
    resolution: f64,
    angular_step: f64,
) -> (Pose2, Matrix3<f64>) {
    let cost = |pose: &Pose2| -> f64 {
        let (s, c) = pose.theta.sin_cos();
        points
            .iter()
            .map(|q| {
                let (v, _) =
                    grid.interpolate(pose.x + c * q[0] - s * q[1], pose.y + s * q[0] + c * q[1]);
                (1.0 - v) * (1.0 - v)
            })
            .sum()
    };
    let mut pose = *start;
    let mut current = cost(&pose);
    let mut lambda = 1e-3;
    for _ in 0..ITERATIONS {
        let (h, g) = normal_equations(grid, points, &pose);
        let damped = h + Matrix3::from_diagonal(&h.diagonal()) * lambda;
        let Some(step) = damped.try_inverse().map(|inv| -(inv * g)) else {
            break;
        };
        if !step.iter().all(|v| v.is_finite()) {
            break;
        }
        let next = Pose2::new(pose.x + step[0], pose.y + step[1], pose.theta + step[2]);
        let after = cost(&next);
        if after < current {
            let gain = (current - after) / current.max(f64::MIN_POSITIVE);
            pose = next;
            current = after;
            lambda = (lambda / 3.0).max(1e-9);
            if gain < 1e-9 {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e6 {
                break;
            }
        }
    }
    let moved = (pose.x - start.x).hypot(pose.y - start.y);
    let turned = crate::wrap_angle(pose.theta - start.theta).abs();
    let pose = if moved <= resolution && turned <= angular_step {
        pose
    } else {
        *start
    };
    (pose, curvature(grid, points, &pose))
}

/// The refinement cost's curvature `JᵀJ` at `pose` (variables x, y, θ).
pub(crate) fn curvature(grid: &ProbabilityGrid, points: &[[f64; 2]], pose: &Pose2) -> Matrix3<f64> {
    normal_equations(grid, points, pose).0
}

/// `JᵀJ` and `Jᵀr` of the residuals `1 − S(T pᵢ)` at `pose`.
fn normal_equations(
    grid: &ProbabilityGrid,
    points: &[[f64; 2]],
    pose: &Pose2,
) -> (Matrix3<f64>, Vector3<f64>) {
    let (s, c) = pose.theta.sin_cos();
    let mut h = Matrix3::zeros();
    let mut g = Vector3::zeros();
    for q in points {
        let (x, y) = (pose.x + c * q[0] - s * q[1], pose.y + s * q[0] + c * q[1]);
        let (v, grad) = grid.interpolate(x, y);
        let r = 1.0 - v;
        // ∂(x, y)/∂θ of the rotated point.
        let (tx, ty) = (-s * q[0] - c * q[1], c * q[0] - s * q[1]);
        let j = Vector3::new(-grad[0], -grad[1], -(grad[0] * tx + grad[1] * ty));
        h += j * j.transpose();
        g += j * r;
    }
    (h, g)
}
