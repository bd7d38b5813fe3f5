//! Range–bearing observation of point landmarks (docs/ALGORITHMS.md §2): the measurement
//! function, its Jacobians, the inverse model that initialises a landmark, the innovation
//! with the bearing wrapped, and the [`Sensor`] description (noise, range, field of view)
//! used for gating and negative evidence.

use crate::check::{in_range, positive};
use crate::pose::{Pose2, wrap_angle};
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix2x3, Vector2};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// One range–bearing observation of a point landmark, in the sensor (= vehicle) frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Observation {
    /// Distance to the landmark (m), ≥ 0.
    pub range: f64,
    /// Direction to the landmark relative to the heading (rad), counter-clockwise positive.
    pub bearing: f64,
    /// The landmark's identity when the sensor knows it (barcodes, simulation); used only
    /// with known association.
    pub id: Option<u64>,
}

impl Observation {
    /// The measurement vector `(r, b)`.
    pub fn z(&self) -> Vector2<f64> {
        Vector2::new(self.range, self.bearing)
    }

    /// Checks that range and bearing are finite and the range is not negative.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] describing the first bad field.
    pub fn validate(&self) -> Result<()> {
        if !(self.range.is_finite() && self.range >= 0.0) {
            return Err(Error::InvalidInput {
                what: "observation.range",
                reason: format!("must be finite and >= 0, got {}", self.range),
            });
        }
        if !self.bearing.is_finite() {
            return Err(Error::InvalidInput {
                what: "observation.bearing",
                reason: format!("not finite: {}", self.bearing),
            });
        }
        Ok(())
    }
}

/// What a range–bearing sensor measures and how well: noise for the landmark EKFs, range
/// and field of view for association search and negative evidence.
///
/// Defaults: the Bailey webmap simulator (σ_r 0.1 m, σ_b 1°, 30 m, front half-plane).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Sensor {
    /// Standard deviation of the range noise (m), > 0.
    pub sigma_range: f64,
    /// Standard deviation of the bearing noise (rad), > 0; Bailey 1° = 0.01745.
    pub sigma_bearing: f64,
    /// Largest range the sensor reports (m), > 0.
    pub max_range: f64,
    /// Full angular width of the field of view (rad), centred on the heading, in (0, 2π];
    /// Bailey's front half-plane is π.
    pub field_of_view: f64,
}

impl Default for Sensor {
    fn default() -> Self {
        Self {
            sigma_range: 0.1,
            sigma_bearing: 1f64.to_radians(),
            max_range: 30.0,
            field_of_view: PI,
        }
    }
}

impl Sensor {
    /// Checks noise, range and field of view.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a σ or range that is not finite and > 0, or a field
    /// of view outside (0, 2π].
    pub fn validate(&self) -> Result<()> {
        positive("sensor.sigma_range", self.sigma_range)?;
        positive("sensor.sigma_bearing", self.sigma_bearing)?;
        positive("sensor.max_range", self.max_range)?;
        positive("sensor.field_of_view", self.field_of_view)?;
        in_range("sensor.field_of_view", self.field_of_view, 0.0, TAU)
    }

    /// Measurement noise covariance `R = diag(σ_r², σ_b²)`.
    pub fn noise(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.sigma_range * self.sigma_range,
            0.0,
            0.0,
            self.sigma_bearing * self.sigma_bearing,
        )
    }

    /// True when this sensor can have reported `observation`: a range above zero and at
    /// most `max_range + 5 σ_r` (noise may push a landmark at the edge slightly beyond).
    /// A range far beyond would initialise a landmark with a huge covariance.
    pub fn can_report(&self, observation: &Observation) -> bool {
        observation.range > 0.0 && observation.range <= self.max_range + 5.0 * self.sigma_range
    }

    /// True when a landmark measured at `z = (r, b)` lies inside the footprint shrunk by
    /// `margin_range` (m) at the far edge and `margin_bearing` (rad) at each side edge —
    /// i.e. the sensor should certainly have seen it.
    pub fn sees(&self, z: &Vector2<f64>, margin_range: f64, margin_bearing: f64) -> bool {
        let within_range = z[0] <= self.max_range - margin_range;
        let half = 0.5 * self.field_of_view;
        let within_fov = half >= PI || wrap_angle(z[1]).abs() <= half - margin_bearing;
        within_range && within_fov
    }
}

/// The predicted measurement of a landmark from a pose with the Jacobians of
/// `h(x, m) = (√(dx² + dy²), atan2(dy, dx) − θ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Predicted `(r, b)`, bearing wrapped to (−π, π].
    pub z: Vector2<f64>,
    /// `∂h/∂m`, w.r.t. the landmark position (2×2).
    pub wrt_landmark: Matrix2<f64>,
    /// `∂h/∂x`, w.r.t. the pose `(x, y, θ)` (2×3).
    pub wrt_pose: Matrix2x3<f64>,
}

/// Below this squared distance (m²) a landmark sits on the sensor and its bearing and
/// Jacobians are undefined.
const MIN_RANGE_SQUARED: f64 = 1e-12;

/// Predicted measurement of `landmark` from `pose`, without Jacobians.
pub fn measure(pose: &Pose2, landmark: &Vector2<f64>) -> Vector2<f64> {
    let dx = landmark[0] - pose.x;
    let dy = landmark[1] - pose.y;
    Vector2::new(dx.hypot(dy), wrap_angle(dy.atan2(dx) - pose.theta))
}

/// Predicted measurement of `landmark` from `pose` with both Jacobians.
///
/// `None` when the landmark is (numerically) at the sensor position, where the bearing
/// and the Jacobians are undefined.
pub fn predict(pose: &Pose2, landmark: &Vector2<f64>) -> Option<Prediction> {
    let dx = landmark[0] - pose.x;
    let dy = landmark[1] - pose.y;
    let q = dx * dx + dy * dy;
    if q.is_nan() || q < MIN_RANGE_SQUARED {
        return None;
    }
    let r = q.sqrt();
    Some(Prediction {
        z: measure(pose, landmark),
        wrt_landmark: Matrix2::new(dx / r, dy / r, -dy / q, dx / q),
        wrt_pose: Matrix2x3::new(-dx / r, -dy / r, 0.0, dy / q, -dx / q, -1.0),
    })
}

/// Innovation `ν = z − ẑ` with the bearing difference wrapped to (−π, π].
pub fn innovation(z: &Vector2<f64>, predicted: &Vector2<f64>) -> Vector2<f64> {
    Vector2::new(z[0] - predicted[0], wrap_angle(z[1] - predicted[1]))
}

/// Inverse model: the landmark position seen at `z = (r, b)` from `pose`, with
/// `G = ∂m/∂z` (2×2).
pub fn inverse(pose: &Pose2, z: &Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
    let (r, b) = (z[0], z[1]);
    let (s, c) = (pose.theta + b).sin_cos();
    let mean = Vector2::new(pose.x + r * c, pose.y + r * s);
    let g = Matrix2::new(c, -r * s, s, r * c);
    (mean, g)
}

/// A new landmark's Gaussian from one observation: mean from [`inverse`] and
/// `Σ = G R Gᵀ` (docs/ALGORITHMS.md §1 step 4), made exactly symmetric.
pub fn initialise(
    pose: &Pose2,
    z: &Vector2<f64>,
    noise: &Matrix2<f64>,
) -> (Vector2<f64>, Matrix2<f64>) {
    let (mean, g) = inverse(pose, z);
    let cov = g * noise * g.transpose();
    (mean, 0.5 * (cov + cov.transpose()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_model_round_trips_through_the_measurement() {
        let pose = Pose2::new(2.0, -1.0, 3.0);
        let z = Vector2::new(12.5, -2.8);
        let (m, _) = inverse(&pose, &z);
        let back = measure(&pose, &m);
        assert!((back - z).norm() < 1e-12);
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let pose = Pose2::new(1.0, 2.0, -2.5);
        let m = Vector2::new(-6.0, 0.5);
        let p = predict(&pose, &m).unwrap();
        let h = 1e-6;
        for k in 0..2 {
            let mut moved = m;
            moved[k] += h;
            let d = innovation(&measure(&pose, &moved), &p.z) / h;
            assert!((d - p.wrt_landmark.column(k)).norm() < 1e-5);
        }
        for k in 0..3 {
            let mut x = [pose.x, pose.y, pose.theta];
            x[k] += h;
            let d = innovation(&measure(&Pose2::new(x[0], x[1], x[2]), &m), &p.z) / h;
            assert!((d - p.wrt_pose.column(k)).norm() < 1e-5);
        }
        let z = Vector2::new(7.0, 0.4);
        let (m0, g) = inverse(&pose, &z);
        for k in 0..2 {
            let mut zz = z;
            zz[k] += h;
            let d = (inverse(&pose, &zz).0 - m0) / h;
            assert!((d - g.column(k)).norm() < 1e-5);
        }
    }

    #[test]
    fn innovation_wraps_the_bearing() {
        let nu = innovation(
            &Vector2::new(5.0, PI - 0.01),
            &Vector2::new(4.0, -PI + 0.01),
        );
        assert!((nu[0] - 1.0).abs() < 1e-12);
        assert!((nu[1] + 0.02).abs() < 1e-12);
    }

    #[test]
    fn landmark_on_the_sensor_has_no_prediction() {
        let pose = Pose2::new(1.0, 1.0, 0.0);
        assert!(predict(&pose, &Vector2::new(1.0, 1.0)).is_none());
    }

    #[test]
    fn initial_covariance_is_g_r_g_transpose() {
        let sensor = Sensor::default();
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let (m, cov) = initialise(&pose, &Vector2::new(20.0, 0.0), &sensor.noise());
        assert!((m - Vector2::new(20.0, 0.0)).norm() < 1e-12);
        // Along the beam σ_r², across it (r σ_b)².
        assert!((cov[(0, 0)] - 0.01).abs() < 1e-12);
        assert!((cov[(1, 1)] - (20.0 * sensor.sigma_bearing).powi(2)).abs() < 1e-12);
        assert!(cov[(0, 1)].abs() < 1e-15);
    }

    #[test]
    fn sensor_footprint_respects_range_fov_and_margins() {
        let s = Sensor::default();
        assert!(s.sees(&Vector2::new(29.0, 1.5), 0.0, 0.0));
        assert!(!s.sees(&Vector2::new(31.0, 0.0), 0.0, 0.0));
        assert!(!s.sees(&Vector2::new(29.5, 0.0), 1.0, 0.0));
        assert!(!s.sees(&Vector2::new(10.0, 1.6), 0.0, 0.0));
        assert!(!s.sees(&Vector2::new(10.0, 1.55), 0.0, 0.05));
        let at = |range| Observation {
            range,
            bearing: 0.0,
            id: None,
        };
        assert!(s.can_report(&at(30.4)));
        assert!(!s.can_report(&at(30.6)));
        assert!(!s.can_report(&at(0.0)));
        assert!(!s.can_report(&at(1e300)));
        let all_round = Sensor {
            field_of_view: TAU,
            ..Sensor::default()
        };
        assert!(all_round.sees(&Vector2::new(10.0, PI), 0.0, 0.1));
    }

    #[test]
    fn bad_observations_and_sensors_are_rejected() {
        let ok = Observation {
            range: 3.0,
            bearing: 0.1,
            id: None,
        };
        assert!(ok.validate().is_ok());
        for bad in [
            Observation {
                range: f64::NAN,
                ..ok
            },
            Observation { range: -1.0, ..ok },
            Observation {
                bearing: f64::INFINITY,
                ..ok
            },
        ] {
            assert!(matches!(bad.validate(), Err(Error::InvalidInput { .. })));
        }
        assert!(Sensor::default().validate().is_ok());
        for bad in [
            Sensor {
                sigma_range: -0.1,
                ..Sensor::default()
            },
            Sensor {
                max_range: f64::NAN,
                ..Sensor::default()
            },
            Sensor {
                field_of_view: 7.0,
                ..Sensor::default()
            },
        ] {
            assert!(matches!(
                bad.validate(),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }
}
