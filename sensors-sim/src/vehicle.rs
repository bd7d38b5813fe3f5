//! The true vehicle: kinematics and the waypoint-following controller (after Bailey and
//! Nieto's FastSLAM simulator: steer toward the current waypoint within the steering
//! angle and rate limits; switch waypoint within `switch_distance`).

use crate::scenario::{Route, VehicleSpec};
use fastslam_estimation::wrap_angle;

/// A planar pose (m, m, rad).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct State {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub theta: f64,
}

/// The controls applied over one control period.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Controls {
    /// Speed (m/s).
    pub v: f64,
    /// Yaw rate (rad/s).
    pub omega: f64,
    /// Steering angle (rad; 0 for a unicycle).
    pub steering: f64,
}

/// Moves `s` by `u` for `dt` seconds with the vehicle's kinematics: for a bicycle the
/// steering angle sets the direction of motion and the yaw rate (IBA paper eq. 14),
/// for a unicycle the yaw rate is commanded directly (ICOA paper eq. 24).
pub fn advance(spec: &VehicleSpec, s: State, u: Controls, dt: f64) -> State {
    match spec {
        VehicleSpec::Bicycle { wheelbase_m, .. } => {
            let heading = s.theta + u.steering;
            State {
                x: s.x + u.v * dt * heading.cos(),
                y: s.y + u.v * dt * heading.sin(),
                theta: wrap_angle(s.theta + u.v * dt * u.steering.sin() / wheelbase_m),
            }
        }
        VehicleSpec::Unicycle { .. } => State {
            x: s.x + u.v * dt * s.theta.cos(),
            y: s.y + u.v * dt * s.theta.sin(),
            theta: wrap_angle(s.theta + u.omega * dt),
        },
    }
}

/// The yaw rate a control produces (bicycle: v·sin(γ)/B).
pub fn yaw_rate(spec: &VehicleSpec, v: f64, steering: f64, omega: f64) -> f64 {
    match spec {
        VehicleSpec::Bicycle { wheelbase_m, .. } => v * steering.sin() / wheelbase_m,
        VehicleSpec::Unicycle { .. } => omega,
    }
}

/// The vehicle driving its route, one control period at a time.
#[derive(Debug, Clone)]
pub struct Drive {
    spec: VehicleSpec,
    route: Route,
    dt: f64,
    state: State,
    steering: f64,
    waypoint: usize,
    loops_left: u32,
}

impl Drive {
    /// Starts at the origin heading +x, toward the first waypoint.
    pub fn new(spec: VehicleSpec, route: Route, dt: f64) -> Self {
        let loops_left = route.loops;
        Self {
            spec,
            route,
            dt,
            state: State::default(),
            steering: 0.0,
            waypoint: 0,
            loops_left,
        }
    }

    /// The current true state.
    pub fn state(&self) -> State {
        self.state
    }

    /// Steers and moves one control period; `None` once the last loop is finished.
    pub fn step(&mut self) -> Option<Controls> {
        let target = self.current_target()?;
        let bearing = (target[1] - self.state.y).atan2(target[0] - self.state.x);
        let u = match self.spec {
            VehicleSpec::Bicycle {
                speed_mps,
                max_steer_deg,
                max_steer_rate_deg_s,
                ..
            } => {
                let max_delta = max_steer_rate_deg_s.to_radians() * self.dt;
                let delta = wrap_angle(bearing - self.state.theta - self.steering)
                    .clamp(-max_delta, max_delta);
                let limit = max_steer_deg.to_radians();
                self.steering = (self.steering + delta).clamp(-limit, limit);
                Controls {
                    v: speed_mps,
                    omega: yaw_rate(&self.spec, speed_mps, self.steering, 0.0),
                    steering: self.steering,
                }
            }
            VehicleSpec::Unicycle {
                speed_mps,
                max_yaw_rate_deg_s,
                heading_gain,
            } => {
                let limit = max_yaw_rate_deg_s.to_radians();
                let omega =
                    (heading_gain * wrap_angle(bearing - self.state.theta)).clamp(-limit, limit);
                Controls {
                    v: speed_mps,
                    omega,
                    steering: 0.0,
                }
            }
        };
        self.state = advance(&self.spec, self.state, u, self.dt);
        Some(u)
    }

    /// The waypoint to steer for, switching (and counting loops) on arrival.
    fn current_target(&mut self) -> Option<[f64; 2]> {
        loop {
            let target = self.route.waypoints[self.waypoint];
            let d = (target[0] - self.state.x).hypot(target[1] - self.state.y);
            if d >= self.route.switch_distance_m {
                return Some(target);
            }
            self.waypoint += 1;
            if self.waypoint == self.route.waypoints.len() {
                self.loops_left -= 1;
                if self.loops_left == 0 {
                    return None;
                }
                self.waypoint = 0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;

    #[test]
    fn drive_visits_every_waypoint_and_ends() {
        let s = Scenario::load("bailey-short").unwrap();
        let mut drive = Drive::new(
            s.vehicle.clone(),
            s.route.clone(),
            s.timing.control_period_s,
        );
        let mut closest = vec![f64::INFINITY; s.route.waypoints.len()];
        let mut steps = 0;
        while drive.step().is_some() {
            steps += 1;
            assert!(steps < 1_000_000, "the drive never ends");
            let p = drive.state();
            for (c, w) in closest.iter_mut().zip(&s.route.waypoints) {
                *c = c.min((w[0] - p.x).hypot(w[1] - p.y));
            }
        }
        assert!(
            closest.iter().all(|&d| d < 1.5),
            "closest approaches {closest:?}"
        );
    }

    #[test]
    fn bicycle_respects_steering_limits() {
        let s = Scenario::load("bailey-short").unwrap();
        let mut drive = Drive::new(
            s.vehicle.clone(),
            s.route.clone(),
            s.timing.control_period_s,
        );
        let mut previous = 0.0_f64;
        while let Some(u) = drive.step() {
            assert!(u.steering.abs() <= 30f64.to_radians() + 1e-12);
            assert!((u.steering - previous).abs() <= 20f64.to_radians() * 0.025 + 1e-12);
            previous = u.steering;
        }
    }
}
