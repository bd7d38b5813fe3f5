//! What the filter publishes (docs/ALGORITHMS.md §1 step 7): the weighted pose estimate with
//! its covariance, and landmarks of the best particle's map.

use super::landmarks::Landmark;
use crate::pose::{Pose2, wrap_angle};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// Weighted mean pose of the particles with its weighted covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseEstimate {
    /// Weighted mean (m, m, rad); the heading is the circular mean.
    pub mean: Pose2,
    /// Weighted covariance of `(x, y, θ)` (m², m·rad, rad²), heading differences wrapped.
    pub covariance: Matrix3<f64>,
}

impl PoseEstimate {
    /// Estimate from `poses` with normalised `weights` (same length, summing to 1).
    ///
    /// # Performance
    /// O(n), two passes.
    pub fn from_weighted(poses: impl Iterator<Item = Pose2> + Clone, weights: &[f64]) -> Self {
        Self::from_mixture(poses.map(|p| (p, Matrix3::zeros())), weights)
    }

    /// Estimate from a Gaussian mixture: components `(μᵢ, Σᵢ)` with normalised `weights`.
    /// Mean `Σ wᵢ μᵢ` (circular mean heading), covariance `Σ wᵢ (Σᵢ + dᵢ dᵢᵀ)` with
    /// `dᵢ = μᵢ − μ` (heading wrapped): positive definite as soon as one component with
    /// weight is.
    ///
    /// # Performance
    /// O(n), two passes.
    pub fn from_mixture(
        components: impl Iterator<Item = (Pose2, Matrix3<f64>)> + Clone,
        weights: &[f64],
    ) -> Self {
        let (mut x, mut y, mut sin, mut cos) = (0.0, 0.0, 0.0, 0.0);
        for ((pose, _), &w) in components.clone().zip(weights) {
            x += w * pose.x;
            y += w * pose.y;
            sin += w * pose.theta.sin();
            cos += w * pose.theta.cos();
        }
        let mean = Pose2::new(x, y, sin.atan2(cos));
        let covariance =
            components
                .zip(weights)
                .fold(Matrix3::zeros(), |acc, ((pose, spread), &w)| {
                    let d = Vector3::new(
                        pose.x - mean.x,
                        pose.y - mean.y,
                        wrap_angle(pose.theta - mean.theta),
                    );
                    acc + w * (spread + d * d.transpose())
                });
        Self { mean, covariance }
    }
}

/// A landmark as published: identity, Gaussian and how often it was seen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapLandmark {
    /// Stable id (the observation's id under known association, else a per-particle
    /// counter, so ids of different particles' maps are unrelated).
    pub id: u64,
    /// Position (m), world frame (the map frame is the initial pose).
    pub mean: Vector2<f64>,
    /// Position covariance (m²).
    pub covariance: Matrix2<f64>,
    /// Scans in which the landmark was observed.
    pub hits: u32,
}

impl From<&Landmark> for MapLandmark {
    fn from(landmark: &Landmark) -> Self {
        Self {
            id: landmark.id,
            mean: landmark.mean,
            covariance: landmark.covariance,
            hits: landmark.hits,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn heading_mean_and_spread_are_circular_across_pi() {
        let poses = [
            Pose2::new(1.0, 0.0, PI - 0.1),
            Pose2::new(3.0, 2.0, -PI + 0.1),
        ];
        let e = PoseEstimate::from_weighted(poses.iter().copied(), &[0.5, 0.5]);
        assert!((e.mean.x - 2.0).abs() < 1e-12 && (e.mean.y - 1.0).abs() < 1e-12);
        assert!(
            (e.mean.theta.abs() - PI).abs() < 1e-12,
            "mean heading is ±π, not 0"
        );
        assert!((e.covariance[(2, 2)] - 0.01).abs() < 1e-12);
        assert!((e.covariance[(0, 0)] - 1.0).abs() < 1e-12);
        assert!((e.covariance[(0, 1)] - 1.0).abs() < 1e-12);
        assert!((e.covariance[(0, 2)] - 0.1).abs() < 1e-12);
        assert!((e.covariance - e.covariance.transpose()).norm() < 1e-15);
    }

    #[test]
    fn a_mixture_adds_the_components_spread_to_the_spread_of_their_means() {
        let components = [
            (Pose2::new(0.0, 0.0, 0.0), Matrix3::identity() * 0.5),
            (Pose2::new(2.0, 0.0, 0.0), Matrix3::identity() * 1.5),
        ];
        let e = PoseEstimate::from_mixture(components.iter().copied(), &[0.5, 0.5]);
        assert!((e.mean.x - 1.0).abs() < 1e-12);
        // Within 1.0, between 1.0 in x.
        assert!((e.covariance[(0, 0)] - 2.0).abs() < 1e-12);
        assert!((e.covariance[(1, 1)] - 1.0).abs() < 1e-12);
        // Two equal points alone would be singular; their Gaussians are not.
        let same = [(Pose2::default(), Matrix3::identity() * 1e-6); 2];
        let e = PoseEstimate::from_mixture(same.iter().copied(), &[0.5, 0.5]);
        assert!(e.covariance.cholesky().is_some());
    }

    #[test]
    fn weights_pull_the_mean() {
        let poses = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(10.0, 0.0, 0.0)];
        let e = PoseEstimate::from_weighted(poses.iter().copied(), &[0.9, 0.1]);
        assert!((e.mean.x - 1.0).abs() < 1e-12);
        assert!((e.covariance[(0, 0)] - 9.0).abs() < 1e-12);
    }
}
