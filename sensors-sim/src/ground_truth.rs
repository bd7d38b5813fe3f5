//! Ground truth as the truth simulator publishes it: the vehicle driving its route, one
//! sample per control period, and the true landmark map.

use crate::Scenario;
use crate::vehicle::{Controls, Drive, State};
use fastslam_protocol::{GroundTruth, Header, MapLandmark};

/// The ground-truth samples of a scenario, in order: the start (zero controls), then one
/// per control period with the controls applied over it, until the route is finished.
#[derive(Debug, Clone)]
pub struct GroundTruthSource {
    drive: Drive,
    period_ns: u64,
    /// Sequence number and controls of the next sample, `None` once the route is done.
    next: Option<(u64, Controls)>,
}

impl GroundTruthSource {
    /// The vehicle of `scenario` at its start.
    pub fn new(scenario: &Scenario) -> Self {
        let dt = scenario.timing.control_period_s;
        Self {
            drive: Drive::new(scenario.vehicle.clone(), scenario.route.clone(), dt),
            period_ns: (dt * 1e9).round() as u64,
            next: Some((0, Controls::default())),
        }
    }
}

impl Iterator for GroundTruthSource {
    type Item = GroundTruth;

    /// The next sample, stamped `seq × control period`.
    fn next(&mut self) -> Option<GroundTruth> {
        let (seq, u) = self.next?;
        let s = self.drive.state();
        let sample = GroundTruth {
            header: Header {
                stamp_ns: seq * self.period_ns,
                seq,
            },
            x: s.x,
            y: s.y,
            theta: s.theta,
            v: u.v,
            omega: u.omega,
            steering: u.steering,
        };
        self.next = self.drive.step().map(|u| (seq + 1, u));
        Some(sample)
    }
}

/// The header of the observation (scan) a sensor taking one every `every` ground-truth
/// samples makes at `truth`, as message `seq` of its stream; `None` between observations
/// and at the start.
pub fn observation_due(truth: &GroundTruth, every: u64, seq: u64) -> Option<Header> {
    let due = truth.header.seq != 0 && truth.header.seq.is_multiple_of(every.max(1));
    due.then_some(Header {
        stamp_ns: truth.header.stamp_ns,
        seq,
    })
}

impl From<&GroundTruth> for State {
    fn from(truth: &GroundTruth) -> Self {
        Self {
            x: truth.x,
            y: truth.y,
            theta: truth.theta,
        }
    }
}

/// The scenario's point landmarks (and pole centres) as a map message's entries; a
/// landmark's id is its index in [`crate::scenario::World::point_landmarks`].
pub fn true_map(scenario: &Scenario) -> Vec<MapLandmark> {
    scenario
        .world
        .point_landmarks()
        .iter()
        .enumerate()
        .map(|(id, p)| MapLandmark {
            id: id as u64,
            x: p[0],
            y: p[1],
            ..Default::default()
        })
        .collect()
}
