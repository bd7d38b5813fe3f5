//! The simulated odometry sensor: the true controls plus Gaussian noise, and the pose
//! dead-reckoned from the noisy controls (what a robot's odometry would show).

use crate::Scenario;
use crate::args::streams;
use crate::scenario::{OdometrySpec, VehicleSpec};
use crate::vehicle::{self, Controls, State};
use fastslam_estimation::rng::{SimRng, stream};
use fastslam_protocol::{GroundTruth, Odometry};
use rand::RngExt;
use rand_distr::StandardNormal;

/// Turns ground truth into noisy odometry.
#[derive(Debug, Clone)]
pub struct OdometrySensor {
    vehicle: VehicleSpec,
    noise: OdometrySpec,
    rng: SimRng,
    dead_reckoned: State,
    previous_stamp_ns: Option<u64>,
}

impl OdometrySensor {
    /// A sensor for `vehicle` whose noise comes from `rng`; dead reckoning starts at the
    /// origin (the vehicle's start).
    pub fn new(vehicle: VehicleSpec, noise: OdometrySpec, rng: SimRng) -> Self {
        Self {
            vehicle,
            noise,
            rng,
            dead_reckoned: State::default(),
            previous_stamp_ns: None,
        }
    }

    /// The sensor of `scenario` with the noise stream of `seed` that `odometry-sim` uses.
    pub fn for_scenario(scenario: &Scenario, seed: u64) -> Self {
        Self::new(
            scenario.vehicle.clone(),
            scenario.odometry.clone(),
            stream(seed, &[streams::ODOMETRY]),
        )
    }

    /// The odometry for the interval that ends at `truth`'s stamp. The first message only
    /// marks the start (zero motion, no noise).
    pub fn measure(&mut self, truth: &GroundTruth) -> Odometry {
        let dt = self.previous_stamp_ns.map_or(0.0, |p| {
            truth.header.stamp_ns.saturating_sub(p) as f64 * 1e-9
        });
        self.previous_stamp_ns = Some(truth.header.stamp_ns);
        let u = if dt > 0.0 {
            self.noisy(truth)
        } else {
            Controls::default()
        };
        self.dead_reckoned = vehicle::advance(&self.vehicle, self.dead_reckoned, u, dt);
        Odometry {
            header: truth.header,
            v: u.v,
            omega: u.omega,
            steering: u.steering,
            x: self.dead_reckoned.x,
            y: self.dead_reckoned.y,
            theta: self.dead_reckoned.theta,
        }
    }

    fn noisy(&mut self, truth: &GroundTruth) -> Controls {
        let mut draw = |sigma: f64| sigma * self.rng.sample::<f64, _>(StandardNormal);
        let n = &self.noise;
        let (scale, steer_offset, omega_offset) = (
            n.speed_scale,
            n.steer_offset_deg.to_radians(),
            n.omega_offset_deg_s.to_radians(),
        );
        let (sigma_v, sigma_steer, sigma_omega) = (
            n.sigma_v_mps,
            n.sigma_steer_deg.to_radians(),
            n.sigma_omega_deg_s.to_radians(),
        );
        let v = scale * truth.v + draw(sigma_v);
        let steering = truth.steering + steer_offset + draw(sigma_steer);
        let omega = truth.omega + omega_offset + draw(sigma_omega);
        let omega = vehicle::yaw_rate(&self.vehicle, v, steering, omega);
        Controls { v, omega, steering }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;
    use fastslam_estimation::rng::seeded;
    use fastslam_protocol::Header;

    #[test]
    fn without_noise_dead_reckoning_follows_truth() {
        let s = Scenario::load("bailey-short").unwrap();
        let quiet = OdometrySpec {
            sigma_v_mps: 0.0,
            sigma_steer_deg: 0.0,
            sigma_omega_deg_s: 0.0,
            speed_scale: 1.0,
            steer_offset_deg: 0.0,
            omega_offset_deg_s: 0.0,
        };
        let mut sensor = OdometrySensor::new(s.vehicle.clone(), quiet, seeded(1));
        let dt = s.timing.control_period_s;
        let mut drive = vehicle::Drive::new(s.vehicle.clone(), s.route.clone(), dt);
        let mut k = 0;
        let gt = |k: u64, st: State, u: Controls| GroundTruth {
            header: Header {
                stamp_ns: k * 25_000_000,
                seq: k,
            },
            x: st.x,
            y: st.y,
            theta: st.theta,
            v: u.v,
            omega: u.omega,
            steering: u.steering,
        };
        sensor.measure(&gt(0, drive.state(), Controls::default()));
        while let Some(u) = drive.step() {
            k += 1;
            let odo = sensor.measure(&gt(k, drive.state(), u));
            let st = drive.state();
            assert!(
                (odo.x - st.x).abs() < 1e-9 && (odo.y - st.y).abs() < 1e-9,
                "step {k}"
            );
        }
        assert!(k > 100);
    }
}
