//! Planar poses and angle arithmetic (REP-103: x forward, y left, θ counter-clockwise).

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Wraps an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let shifted = a + PI;
    // `rem_euclid` is exact and leaves a value in [0, 2π) as it is: skipping its `fmod`
    // call there gives the same bits, faster (most angles are already in range).
    let reduced = if (0.0..2.0 * PI).contains(&shifted) {
        shifted
    } else {
        shifted.rem_euclid(2.0 * PI)
    };
    let w = reduced - PI;
    if w <= -PI { w + 2.0 * PI } else { w }
}

/// A planar pose: position in metres, heading in radians wrapped to (−π, π].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    /// x position (m).
    pub x: f64,
    /// y position (m).
    pub y: f64,
    /// Heading (rad), counter-clockwise from +x.
    pub theta: f64,
}

impl Pose2 {
    /// A pose from its parts; the heading is wrapped.
    pub fn new(x: f64, y: f64, theta: f64) -> Self {
        Self {
            x,
            y,
            theta: wrap_angle(theta),
        }
    }

    /// `self ∘ other`: pose `other`, given in `self`'s frame, in the world.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2::new(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            self.theta + other.theta,
        )
    }

    /// Point `p`, given in this pose's frame, in the world.
    pub fn transform_point(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.theta.sin_cos();
        [self.x + c * p[0] - s * p[1], self.y + s * p[0] + c * p[1]]
    }

    /// `self⁻¹`: the world seen from this pose, so that `self⁻¹ ∘ self` is the identity.
    pub fn inverse(&self) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2::new(
            -c * self.x - s * self.y,
            s * self.x - c * self.y,
            -self.theta,
        )
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn composing_with_the_inverse_gives_the_identity() {
        let a = Pose2::new(3.0, -2.0, 2.5);
        let b = Pose2::new(-1.0, 4.0, -0.7);
        let back = a.inverse().compose(&a.compose(&b));
        assert!((back.x - b.x).abs() < 1e-12 && (back.y - b.y).abs() < 1e-12);
        assert!(wrap_angle(back.theta - b.theta).abs() < 1e-12);
        // A point 1 m ahead of a pose facing +y lies 1 m above it.
        let ahead =
            Pose2::new(2.0, 0.0, std::f64::consts::FRAC_PI_2).compose(&Pose2::new(1.0, 0.0, 0.0));
        assert!((ahead.x - 2.0).abs() < 1e-12 && (ahead.y - 1.0).abs() < 1e-12);
    }

    #[test]
    fn wrap_angle_skips_the_remainder_only_where_it_changes_nothing() {
        let by_remainder = |a: f64| {
            let w = (a + PI).rem_euclid(2.0 * PI) - PI;
            if w <= -PI { w + 2.0 * PI } else { w }
        };
        let edges = [0.0, -0.0, 1e-300, -1e-300, PI, -PI, 2.0 * PI, -2.0 * PI];
        let nudged = edges
            .iter()
            .flat_map(|&e: &f64| [e, e.next_up(), e.next_down()]);
        let sweep = (-20_000..=20_000).map(|k| k as f64 * 1e-3 * PI + 1e-7);
        for a in nudged.chain(sweep).chain([f64::INFINITY, 1e17]) {
            assert_eq!(
                wrap_angle(a).to_bits(),
                by_remainder(a).to_bits(),
                "angle {a:e}"
            );
        }
    }

    #[test]
    fn wrap_angle_maps_into_half_open_interval() {
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(2.0 * PI + 0.5) - 0.5).abs() < 1e-12);
        assert!((wrap_angle(-2.0 * PI - 0.5) + 0.5).abs() < 1e-12);
        assert!(wrap_angle(f64::NAN).is_nan());
    }
}
