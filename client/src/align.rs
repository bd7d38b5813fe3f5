//! Rigid planar transforms (SE(2)) and the least-squares alignment of one trajectory onto
//! another (Umeyama 1991, without scale), for external data whose estimate lives in a
//! frame of its own. Simulated runs share the true frame and are scored unaligned.

use crate::recording::StampedPose;
use fastslam_estimation::wrap_angle;
use fastslam_protocol::MapLandmark;
use serde::{Deserialize, Serialize};

/// A rigid motion of the plane: rotate by `theta`, then translate by `(x, y)`. Also a
/// pose: the transform from the pose's body frame to the world frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Se2 {
    /// Translation x (m).
    #[serde(rename = "x_m")]
    #[serde(deserialize_with = "crate::json_number::number")]
    pub x: f64,
    /// Translation y (m).
    #[serde(rename = "y_m")]
    #[serde(deserialize_with = "crate::json_number::number")]
    pub y: f64,
    /// Rotation (rad, in (−π, π]).
    #[serde(rename = "theta_rad")]
    #[serde(deserialize_with = "crate::json_number::number")]
    pub theta: f64,
}

impl Se2 {
    /// The identity.
    pub const IDENTITY: Self = Self {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };

    /// The transform of a pose.
    pub fn of(p: &StampedPose) -> Self {
        Self {
            x: p.x,
            y: p.y,
            theta: p.theta,
        }
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Self) -> Self {
        let (x, y) = self.apply(other.x, other.y);
        Self {
            x,
            y,
            theta: wrap_angle(self.theta + other.theta),
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Self {
        let (s, c) = self.theta.sin_cos();
        Self {
            x: -(c * self.x + s * self.y),
            y: -(-s * self.x + c * self.y),
            theta: wrap_angle(-self.theta),
        }
    }

    /// Maps the point `(px, py)`.
    pub fn apply(&self, px: f64, py: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        (c * px - s * py + self.x, s * px + c * py + self.y)
    }

    /// Maps a stamped pose (position and heading).
    pub fn apply_pose(&self, p: &StampedPose) -> StampedPose {
        let (x, y) = self.apply(p.x, p.y);
        StampedPose {
            stamp_ns: p.stamp_ns,
            x,
            y,
            theta: wrap_angle(p.theta + self.theta),
        }
    }

    /// Maps a row-major 3×3 covariance of (x, y, θ): `R P Rᵀ` with `R` rotating the
    /// position block (the heading variance does not change under a rigid motion).
    pub fn apply_covariance(&self, p: &[f64; 9]) -> [f64; 9] {
        let (s, c) = self.theta.sin_cos();
        let r = nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let m = r * nalgebra::Matrix3::from_row_slice(p) * r.transpose();
        let mut out = [0.0; 9];
        for (i, v) in out.iter_mut().enumerate() {
            *v = m[(i / 3, i % 3)];
        }
        out
    }

    /// Maps a landmark: its position and covariance.
    pub fn apply_landmark(&self, l: &MapLandmark) -> MapLandmark {
        let (x, y) = self.apply(l.x, l.y);
        let (cov_xx, cov_xy, cov_yy) = self.apply_point_covariance(l.cov_xx, l.cov_xy, l.cov_yy);
        MapLandmark {
            x,
            y,
            cov_xx,
            cov_xy,
            cov_yy,
            ..*l
        }
    }

    /// Maps a 2×2 covariance `(xx, xy, yy)` of a point.
    pub fn apply_point_covariance(&self, xx: f64, xy: f64, yy: f64) -> (f64, f64, f64) {
        let (s, c) = self.theta.sin_cos();
        (
            c * c * xx - 2.0 * c * s * xy + s * s * yy,
            c * s * (xx - yy) + (c * c - s * s) * xy,
            s * s * xx + 2.0 * c * s * xy + c * c * yy,
        )
    }
}

/// The rigid motion `T` minimising `Σ ‖truth_i − T(estimate_i)‖²` over the matched
/// positions (Umeyama's least-squares solution without scale). In 2-D it has a closed
/// form: centre both sets, take the rotation angle of the cross-covariance
/// `θ = atan2(Σ (e × t), Σ (e · t))` — a proper rotation by construction, so no reflection
/// check is needed — then the translation that maps one centroid onto the other.
/// `None` for fewer than two pairs or sets that do not fix a rotation (all points equal).
pub fn umeyama_se2(estimate: &[(f64, f64)], truth: &[(f64, f64)]) -> Option<Se2> {
    let n = estimate.len().min(truth.len());
    if n < 2 {
        return None;
    }
    let centroid = |v: &[(f64, f64)]| {
        let (sx, sy) = v[..n]
            .iter()
            .fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
        (sx / n as f64, sy / n as f64)
    };
    let (me, mt) = (centroid(estimate), centroid(truth));
    let (mut dot, mut cross) = (0.0, 0.0);
    for (e, t) in estimate[..n].iter().zip(&truth[..n]) {
        let (ex, ey, tx, ty) = (e.0 - me.0, e.1 - me.1, t.0 - mt.0, t.1 - mt.1);
        dot += ex * tx + ey * ty;
        cross += ex * ty - ey * tx;
    }
    if dot == 0.0 && cross == 0.0 {
        return None;
    }
    let rotation = Se2 {
        x: 0.0,
        y: 0.0,
        theta: cross.atan2(dot),
    };
    let (rx, ry) = rotation.apply(me.0, me.1);
    Some(Se2 {
        x: mt.0 - rx,
        y: mt.1 - ry,
        theta: rotation.theta,
    })
}

impl From<fastslam_estimation::Pose2> for Se2 {
    /// The same transform: a pose of the estimation crate (a sensor's mount, say).
    fn from(p: fastslam_estimation::Pose2) -> Self {
        Self {
            x: p.x,
            y: p.y,
            theta: p.theta,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn umeyama_recovers_a_known_transform() {
        let truth: Vec<(f64, f64)> = (0..50)
            .map(|k| {
                let t = k as f64 * 0.3;
                (10.0 * t.cos() + t, 4.0 * t.sin())
            })
            .collect();
        let known = Se2 {
            x: -3.0,
            y: 7.5,
            theta: 2.4,
        };
        // The estimate is the truth seen from another frame: estimate = known⁻¹(truth).
        let inv = known.inverse();
        let estimate: Vec<(f64, f64)> = truth.iter().map(|p| inv.apply(p.0, p.1)).collect();
        let t = umeyama_se2(&estimate, &truth).unwrap();
        assert!(
            close(t.x, known.x) && close(t.y, known.y) && close(t.theta, known.theta),
            "{t:?}"
        );
    }

    #[test]
    fn umeyama_with_noise_is_the_least_squares_fit() {
        // Noisy points: the fit is a least-squares minimum, close to the true transform.
        let known = Se2 {
            x: 1.0,
            y: -2.0,
            theta: -0.7,
        };
        let base = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0)];
        let noise = [(0.1, 0.0), (-0.1, 0.0), (0.1, 0.0), (-0.1, 0.0)];
        let truth: Vec<(f64, f64)> = base.iter().map(|p| known.apply(p.0, p.1)).collect();
        let estimate: Vec<(f64, f64)> = base
            .iter()
            .zip(noise)
            .map(|(p, n)| (p.0 + n.0, p.1 + n.1))
            .collect();
        let t = umeyama_se2(&estimate, &truth).unwrap();
        let residual = |t: &Se2| {
            estimate
                .iter()
                .zip(&truth)
                .map(|(e, q)| {
                    let (x, y) = t.apply(e.0, e.1);
                    (x - q.0).powi(2) + (y - q.1).powi(2)
                })
                .sum::<f64>()
        };
        // Any nearby transform fits worse.
        for d in [1e-3, -1e-3] {
            for nudged in [
                Se2 { x: t.x + d, ..t },
                Se2 { y: t.y + d, ..t },
                Se2 {
                    theta: t.theta + d,
                    ..t
                },
            ] {
                assert!(residual(&nudged) > residual(&t));
            }
        }
        assert!((t.theta - known.theta).abs() < 0.05, "{t:?}");
    }

    #[test]
    fn umeyama_needs_two_distinct_points() {
        assert_eq!(umeyama_se2(&[(1.0, 1.0)], &[(2.0, 2.0)]), None);
        assert_eq!(
            umeyama_se2(&[(1.0, 1.0), (1.0, 1.0)], &[(2.0, 2.0), (3.0, 3.0)]),
            None
        );
    }

    #[test]
    fn compose_with_the_inverse_is_the_identity() {
        let a = Se2 {
            x: 3.0,
            y: -1.0,
            theta: 2.0,
        };
        let i = a.compose(&a.inverse());
        assert!(
            close(i.x, 0.0) && close(i.y, 0.0) && close(i.theta, 0.0),
            "{i:?}"
        );
    }

    #[test]
    fn rotating_a_covariance_keeps_its_trace_and_heading_variance() {
        let t = Se2 {
            x: 5.0,
            y: 5.0,
            theta: std::f64::consts::FRAC_PI_2,
        };
        let p = [4.0, 0.0, 0.1, 0.0, 1.0, 0.0, 0.1, 0.0, 0.5];
        let q = t.apply_covariance(&p);
        // A quarter turn swaps the x and y variances.
        assert!(
            close(q[0], 1.0) && close(q[4], 4.0) && close(q[8], 0.5),
            "{q:?}"
        );
        let (xx, xy, yy) = t.apply_point_covariance(4.0, 0.0, 1.0);
        assert!(close(xx, 1.0) && close(xy, 0.0) && close(yy, 4.0));
    }
}
