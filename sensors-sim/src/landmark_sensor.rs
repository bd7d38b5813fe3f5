//! The simulated landmark sensor: range and bearing to every landmark within range and
//! field of view, with Gaussian noise (Bailey's simulator: front half-plane, 30 m).

use crate::Scenario;
use crate::args::streams;
use crate::ground_truth::observation_due;
use crate::scenario::LandmarkSensorSpec;
use crate::vehicle::State;
use fastslam_estimation::rng::{SimRng, stream};
use fastslam_estimation::wrap_angle;
use fastslam_protocol::{GroundTruth, Header, Observation, ObservationsHeader};
use rand::RngExt;
use rand_distr::StandardNormal;

/// Observes the scenario's point landmarks from the true pose.
#[derive(Debug, Clone)]
pub struct LandmarkSensor {
    spec: LandmarkSensorSpec,
    landmarks: Vec<[f64; 2]>,
    rng: SimRng,
    every: u64,
}

impl LandmarkSensor {
    /// A sensor over `landmarks` whose noise comes from `rng`, observing at every
    /// `every`-th ground-truth sample (≥ 1).
    pub fn new(
        spec: LandmarkSensorSpec,
        landmarks: Vec<[f64; 2]>,
        rng: SimRng,
        every: u64,
    ) -> Self {
        Self {
            spec,
            landmarks,
            rng,
            every: every.max(1),
        }
    }

    /// The sensor of `scenario` with the noise stream of `seed` that `lidar-sim` uses.
    pub fn for_scenario(scenario: &Scenario, seed: u64) -> Self {
        Self::new(
            scenario.landmark_sensor.clone(),
            scenario.world.point_landmarks(),
            stream(seed, &[streams::LANDMARKS]),
            scenario.timing.observe_every,
        )
    }

    /// The scan taken at ground-truth sample `truth`, if it is an observation instant
    /// (every `every`-th sample after the start), as message `seq` of the stream.
    pub fn scan(
        &mut self,
        truth: &GroundTruth,
        seq: u64,
    ) -> Option<(ObservationsHeader, Vec<Observation>)> {
        let header = observation_due(truth, self.every, seq)?;
        let seen = self.observe(State::from(truth));
        Some((self.header(header, seen.len()), seen))
    }

    /// Noisy observations of the landmarks visible from `s`, in landmark order.
    ///
    /// Visibility uses the true range and bearing; a noisy range is kept positive.
    pub fn observe(&mut self, s: State) -> Vec<Observation> {
        let half_fov = self.spec.fov_deg.to_radians() / 2.0;
        let mut out = Vec::new();
        for (id, lm) in self.landmarks.iter().enumerate() {
            let (dx, dy) = (lm[0] - s.x, lm[1] - s.y);
            let range = dx.hypot(dy);
            let bearing = wrap_angle(dy.atan2(dx) - s.theta);
            if range > self.spec.max_range_m || bearing.abs() > half_fov {
                continue;
            }
            let nr: f64 = self.rng.sample(StandardNormal);
            let nb: f64 = self.rng.sample(StandardNormal);
            out.push(Observation {
                range: (range + self.spec.sigma_range_m * nr).clamp(1e-3, self.spec.max_range_m),
                bearing: wrap_angle(bearing + self.spec.sigma_bearing_deg.to_radians() * nb),
                diameter: 0.0,
                id: if self.spec.report_ids { id as i64 } else { -1 },
            });
        }
        out
    }

    /// The message header describing this sensor, for `count` observations.
    pub fn header(&self, header: Header, count: usize) -> ObservationsHeader {
        let half_fov = self.spec.fov_deg.to_radians() / 2.0;
        ObservationsHeader {
            header,
            count: count as u32,
            reserved: 0,
            max_range: self.spec.max_range_m,
            min_bearing: -half_fov,
            max_bearing: half_fov,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_estimation::rng::seeded;

    fn sensor(sigma: f64) -> LandmarkSensor {
        let spec = LandmarkSensorSpec {
            max_range_m: 30.0,
            fov_deg: 180.0,
            sigma_range_m: sigma,
            sigma_bearing_deg: sigma,
            report_ids: true,
        };
        let landmarks = vec![
            [10.0, 0.0],
            [0.0, 10.0],
            [-10.0, 0.0],
            [40.0, 0.0],
            [0.0, -29.0],
        ];
        LandmarkSensor::new(spec, landmarks, seeded(3), 1)
    }

    #[test]
    fn sees_only_landmarks_in_range_and_in_front() {
        let obs = sensor(0.0).observe(State::default());
        let ids: Vec<i64> = obs.iter().map(|o| o.id).collect();
        assert_eq!(
            ids,
            vec![0, 1, 4],
            "behind (2) and too far (3) are not seen"
        );
        assert!((obs[0].range - 10.0).abs() < 1e-12 && obs[0].bearing.abs() < 1e-12);
        assert!((obs[1].bearing - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn noise_has_the_configured_spread() {
        let mut s = sensor(0.5);
        let errors: Vec<f64> = (0..2000)
            .map(|_| s.observe(State::default())[0].range - 10.0)
            .collect();
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let sd =
            (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / errors.len() as f64).sqrt();
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!((sd - 0.5).abs() < 0.05, "sd {sd}");
    }
}
