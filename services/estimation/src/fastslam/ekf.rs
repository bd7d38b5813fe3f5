//! The per-landmark 2-D EKF of FastSLAM (docs/ALGORITHMS.md §1 steps 3–4): innovation and its
//! likelihood for gating and weighting, then the Joseph-form update that keeps the
//! landmark covariance symmetric positive definite.

use crate::observation::{Prediction, innovation};
use nalgebra::{Matrix2, Vector2};
use std::f64::consts::TAU;

/// The innovation of one observation against one landmark, with what gating, weighting
/// and the update need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation {
    /// `ν = z − ẑ` (m, rad), bearing wrapped.
    pub nu: Vector2<f64>,
    /// `S⁻¹` with `S = H Σ Hᵀ + R`.
    pub s_inv: Matrix2<f64>,
    /// Normalised innovation squared `d² = νᵀ S⁻¹ ν` (dimensionless).
    pub d2: f64,
    /// `log N(ν; 0, S) = −d²/2 − log(2π) − log det(S)/2`.
    pub log_likelihood: f64,
}

/// Innovation of measurement `z` against a landmark with covariance `cov` predicted as
/// `prediction`, under measurement noise `noise` (R).
///
/// `None` when `S` is not positive definite or not finite (a broken landmark), so the
/// caller treats the landmark as no candidate instead of propagating NaN.
pub fn innovate(
    z: &Vector2<f64>,
    prediction: &Prediction,
    cov: &Matrix2<f64>,
    noise: &Matrix2<f64>,
) -> Option<Innovation> {
    let h = &prediction.wrt_landmark;
    innovate_with(z, prediction, &(h * cov * h.transpose() + noise))
}

/// Innovation of measurement `z` against `prediction` with a given innovation covariance
/// `s` (FastSLAM 2.0 adds the pose uncertainty to the landmark's); `None` when `s` is not
/// positive definite or not finite.
pub fn innovate_with(
    z: &Vector2<f64>,
    prediction: &Prediction,
    s: &Matrix2<f64>,
) -> Option<Innovation> {
    let det = s.determinant();
    if !(det.is_finite() && det > 0.0 && s[(0, 0)] > 0.0) {
        return None;
    }
    let s_inv = Matrix2::new(s[(1, 1)], -s[(0, 1)], -s[(1, 0)], s[(0, 0)]) / det;
    let s_inv = 0.5 * (s_inv + s_inv.transpose());
    let nu = innovation(z, &prediction.z);
    let d2 = (nu.transpose() * s_inv * nu)[0];
    let log_likelihood = -0.5 * d2 - TAU.ln() - 0.5 * det.ln();
    Some(Innovation {
        nu,
        s_inv,
        d2,
        log_likelihood,
    })
}

/// EKF update of a landmark `(mean, cov)` with `innovation` (from [`innovate`] with the
/// same landmark), Jacobian `h` (w.r.t. the landmark) and noise `noise`:
/// `K = Σ Hᵀ S⁻¹`, `μ += K ν`, Joseph form `Σ = (I−KH) Σ (I−KH)ᵀ + K R Kᵀ`, then
/// `Σ = (Σ + Σᵀ)/2` so rounding never makes it asymmetric.
pub fn update(
    mean: &mut Vector2<f64>,
    cov: &mut Matrix2<f64>,
    innovation: &Innovation,
    h: &Matrix2<f64>,
    noise: &Matrix2<f64>,
) {
    let k = *cov * h.transpose() * innovation.s_inv;
    *mean += k * innovation.nu;
    let a = Matrix2::identity() - k * h;
    let joseph = a * *cov * a.transpose() + k * noise * k.transpose();
    *cov = 0.5 * (joseph + joseph.transpose());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observation::{Sensor, initialise, measure, predict};
    use crate::pose::Pose2;
    use crate::rng::seeded;
    use rand::RngExt;
    use rand_distr::StandardNormal;

    fn is_spd(m: &Matrix2<f64>) -> bool {
        m[(0, 1)] == m[(1, 0)] && m[(0, 0)] > 0.0 && m.determinant() > 0.0
    }

    #[test]
    fn joseph_form_keeps_covariance_symmetric_positive_definite() {
        // A very precise sensor against a vague landmark is where the short form
        // (I−KH)Σ loses symmetry and definiteness; 5 000 updates from moving poses.
        let precise = Sensor {
            sigma_range: 1e-4,
            sigma_bearing: 1e-5,
            ..Sensor::default()
        };
        let noise = precise.noise();
        let truth = Vector2::new(10.0, 5.0);
        let mut rng = seeded(4);
        let first = Pose2::new(0.0, 0.0, 0.0);
        let (mut mean, _) = initialise(&first, &measure(&first, &truth), &noise);
        let mut cov = Matrix2::new(1e4, 9.9e3, 9.9e3, 1e4);
        let mut last_trace = cov.trace();
        for i in 0..5_000 {
            let pose = Pose2::new(
                rng.random_range(-20.0..0.0),
                rng.random_range(-20.0..20.0),
                rng.random_range(-3.0..3.0),
            );
            let z = measure(&pose, &truth)
                + Vector2::new(
                    precise.sigma_range * rng.sample::<f64, _>(StandardNormal),
                    precise.sigma_bearing * rng.sample::<f64, _>(StandardNormal),
                );
            let p = predict(&pose, &mean).unwrap();
            let inn = innovate(&z, &p, &cov, &noise).unwrap();
            update(&mut mean, &mut cov, &inn, &p.wrt_landmark, &noise);
            assert!(is_spd(&cov), "update {i}: {cov}");
            assert!(
                cov.trace() <= last_trace * (1.0 + 1e-9),
                "information never decreases"
            );
            last_trace = cov.trace();
        }
        assert!((mean - truth).norm() < 1e-4);
    }

    #[test]
    fn joseph_form_equals_the_short_form_for_the_optimal_gain() {
        let noise = Sensor::default().noise();
        let pose = Pose2::new(0.0, 0.0, 0.3);
        let mut mean = Vector2::new(8.0, 6.0);
        let mut cov = Matrix2::new(0.5, 0.1, 0.1, 0.3);
        let p = predict(&pose, &mean).unwrap();
        let inn = innovate(&Vector2::new(10.2, 0.35), &p, &cov, &noise).unwrap();
        let h = p.wrt_landmark;
        let k = cov * h.transpose() * inn.s_inv;
        let short = (Matrix2::identity() - k * h) * cov;
        update(&mut mean, &mut cov, &inn, &h, &noise);
        assert!((cov - short).norm() < 1e-12);
    }

    #[test]
    fn innovation_likelihood_is_the_gaussian_density() {
        let noise = Sensor::default().noise();
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let m = Vector2::new(5.0, 0.0);
        let cov = Matrix2::new(0.02, 0.0, 0.0, 0.03);
        let p = predict(&pose, &m).unwrap();
        let z = Vector2::new(5.1, 0.01);
        let inn = innovate(&z, &p, &cov, &noise).unwrap();
        let s = p.wrt_landmark * cov * p.wrt_landmark.transpose() + noise;
        let nu = z - p.z;
        let d2 = nu[0] * nu[0] / s[(0, 0)] + nu[1] * nu[1] / s[(1, 1)];
        let expected = -0.5 * d2 - (TAU * (s[(0, 0)] * s[(1, 1)]).sqrt()).ln();
        assert!((inn.d2 - d2).abs() < 1e-9);
        assert!((inn.log_likelihood - expected).abs() < 1e-9);
    }

    #[test]
    fn broken_landmark_covariance_gives_no_innovation() {
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let p = predict(&pose, &Vector2::new(5.0, 0.0)).unwrap();
        let nan = Matrix2::new(f64::NAN, 0.0, 0.0, 1.0);
        assert!(
            innovate(
                &Vector2::new(5.0, 0.0),
                &p,
                &nan,
                &Sensor::default().noise()
            )
            .is_none()
        );
    }
}
