//! The three simulator processes in one loop, without IPC: for a `(scenario, seed)` it
//! yields exactly the messages `truth-sim`, `odometry-sim` and `lidar-sim` publish — the
//! same types, stamps, sequence numbers and seeded noise streams, built by the same code
//! ([`GroundTruthSource`], [`OdometrySensor::for_scenario`], the [`Lidar`] for scenarios
//! with a `[lidar]`, else [`LandmarkSensor::for_scenario`]) — so an in-process run of the
//! estimator sees what a run through the processes sees.
//!
//! Order: the true map first (the truth simulator repeats it; every copy is the same), then
//! per ground-truth sample the sample itself, its odometry, and the scan when one is taken.
//! Across streams the order is irrelevant: consumers sort by stamp per stream.

use crate::Scenario;
use crate::args::streams;
use crate::ground_truth::observation_due;
use crate::ground_truth::{GroundTruthSource, true_map};
use crate::landmark_sensor::LandmarkSensor;
use crate::lidar_sensor::Lidar;
use crate::odometry_sensor::OdometrySensor;
use crate::vehicle::State;
use fastslam_estimation::rng::stream;
use fastslam_protocol::{
    GroundTruth, LaserScanHeader, MapLandmark, Observation, ObservationsHeader, Odometry,
};
use std::collections::VecDeque;

/// One message a simulator process would publish.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// The true landmark map (`truth-sim`, topic `true_landmarks`).
    TrueMap(Vec<MapLandmark>),
    /// A ground-truth sample (`truth-sim`).
    GroundTruth(GroundTruth),
    /// An odometry message (`odometry-sim`).
    Odometry(Odometry),
    /// A scan's observations (`lidar-sim` without a `[lidar]`).
    Observations(ObservationsHeader, Vec<Observation>),
    /// A raw scan: the header and the message's slice, ranges then any intensities
    /// (`lidar-sim` with a `[lidar]`).
    RawScan(LaserScanHeader, Vec<f32>),
}

/// The scenario's lidar: raw scans, or landmark observations.
#[derive(Debug, Clone)]
enum Sensor {
    Scans {
        lidar: Box<Lidar>,
        every: u64,
        period_s: f64,
    },
    Landmarks(LandmarkSensor),
}

/// The simulators' messages for one `(scenario, seed)`, as an iterator.
#[derive(Debug, Clone)]
pub struct OfflineRun {
    truth: GroundTruthSource,
    odometry: OdometrySensor,
    lidar: Sensor,
    scans: u64,
    pending: VecDeque<Message>,
}

impl OfflineRun {
    /// The run of `scenario` with the simulation seed `seed` (the processes' `--seed`).
    pub fn new(scenario: &Scenario, seed: u64) -> Self {
        Self {
            truth: GroundTruthSource::new(scenario),
            odometry: OdometrySensor::for_scenario(scenario, seed),
            lidar: match &scenario.lidar {
                Some(spec) => Sensor::Scans {
                    lidar: Box::new(Lidar::new(
                        spec.clone(),
                        &scenario.world,
                        stream(seed, &[streams::LIDAR]),
                    )),
                    every: scenario.timing.observe_every,
                    period_s: scenario.observe_period_s(),
                },
                None => Sensor::Landmarks(LandmarkSensor::for_scenario(scenario, seed)),
            },
            scans: 0,
            pending: VecDeque::from([Message::TrueMap(true_map(scenario))]),
        }
    }
}

impl Iterator for OfflineRun {
    type Item = Message;

    fn next(&mut self) -> Option<Message> {
        if let Some(message) = self.pending.pop_front() {
            return Some(message);
        }
        let truth = self.truth.next()?;
        self.pending
            .push_back(Message::Odometry(self.odometry.measure(&truth)));
        let scan = match &mut self.lidar {
            Sensor::Landmarks(sensor) => sensor
                .scan(&truth, self.scans)
                .map(|(header, observations)| Message::Observations(header, observations)),
            Sensor::Scans {
                lidar,
                every,
                period_s,
            } => observation_due(&truth, *every, self.scans).map(|header| {
                let scan = lidar.scan(State::from(&truth));
                Message::RawScan(lidar.header(header, *period_s), scan.data)
            }),
        };
        if let Some(scan) = scan {
            self.scans += 1;
            self.pending.push_back(scan);
        }
        Some(Message::GroundTruth(truth))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_complete_ordered_and_reproducible() {
        let scenario = Scenario::load("bailey-short").unwrap();
        let messages: Vec<Message> = OfflineRun::new(&scenario, 3).collect();
        let (mut truth, mut odometry, mut scans) = (Vec::new(), Vec::new(), Vec::new());
        for m in &messages {
            match m {
                Message::TrueMap(map) => {
                    assert_eq!(map.len(), scenario.world.point_landmarks().len())
                }
                Message::GroundTruth(gt) => truth.push(gt.header),
                Message::Odometry(o) => odometry.push(o.header),
                Message::Observations(h, obs) => {
                    assert_eq!(h.count as usize, obs.len());
                    scans.push(h.header);
                }
                Message::RawScan(..) => panic!("bailey-short has no [lidar]"),
            }
        }
        assert_eq!(
            truth, odometry,
            "one odometry message per ground-truth sample"
        );
        let every = scenario.timing.observe_every;
        assert_eq!(scans.len() as u64, (truth.len() as u64 - 1) / every);
        assert!(scans.iter().enumerate().all(|(k, h)| h.seq == k as u64));
        assert!(truth.windows(2).all(|w| w[1].seq == w[0].seq + 1));
        let again: Vec<Message> = OfflineRun::new(&scenario, 3).collect();
        assert_eq!(messages, again);
        let other: Vec<Message> = OfflineRun::new(&scenario, 4).collect();
        assert_ne!(messages, other, "the seed must matter");
    }
}
