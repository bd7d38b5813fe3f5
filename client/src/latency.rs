//! End-to-end latency from a sensor sample's publication to the publication of the pose
//! that used it, as seen by a subscriber of both topics.
//!
//! The service stamps each pose with the stamp of the observations that produced it, so
//! the client pairs the two by stamp and subtracts its own monotonic receive times. Both
//! receive times carry the client's wake-up delay, which cancels to first order; what
//! remains is the time the sample spent in the service (queueing behind odometry and the
//! filter step) plus IPC. A sample that produced no pose (rejected) is never paired.

use std::collections::BTreeMap;
use std::time::Instant;

/// Pairs observation and pose receive times by stamp.
#[derive(Debug, Default)]
pub struct LatencyMatcher {
    /// Receive times of observations whose pose has not arrived yet, by stamp.
    observations: BTreeMap<u64, Instant>,
    /// Receive times of poses that arrived before their observation, by stamp.
    poses: BTreeMap<u64, Instant>,
    /// Latency per pose stamp (s), in pairing order.
    latencies: Vec<(u64, f64)>,
    /// When the first observation and the latest pose arrived.
    first_observation: Option<Instant>,
    last_pose: Option<Instant>,
}

impl LatencyMatcher {
    /// An observation with `stamp_ns` arrived at `at`.
    pub fn observation(&mut self, stamp_ns: u64, at: Instant) {
        self.first_observation.get_or_insert(at);
        match self.poses.remove(&stamp_ns) {
            Some(pose_at) => self.pair(stamp_ns, at, pose_at),
            None => {
                self.observations.insert(stamp_ns, at);
            }
        }
    }

    /// A pose with `stamp_ns` arrived at `at`. Observations older than it that are still
    /// unpaired produced no pose and are forgotten (stamps only grow).
    pub fn pose(&mut self, stamp_ns: u64, at: Instant) {
        self.last_pose = Some(at);
        match self.observations.remove(&stamp_ns) {
            Some(obs_at) => self.pair(stamp_ns, obs_at, at),
            None => {
                self.poses.insert(stamp_ns, at);
            }
        }
        self.observations = self.observations.split_off(&stamp_ns);
    }

    /// A pose received before its observation — possible only when the client's
    /// observation buffer was full while the service already had the sample — counts as
    /// zero: the client cannot tell how much earlier the observation was published.
    fn pair(&mut self, stamp_ns: u64, obs_at: Instant, pose_at: Instant) {
        let latency = pose_at.saturating_duration_since(obs_at).as_secs_f64();
        self.latencies.push((stamp_ns, latency));
    }

    /// Latencies paired so far: (pose stamp in ns, seconds).
    pub fn latencies(&self) -> &[(u64, f64)] {
        &self.latencies
    }

    /// Wall time from the first observation to the latest pose, as received (s): how
    /// long the stack took to stream the run through, without its start-up and the
    /// client's scoring. `None` before both have arrived.
    pub fn streamed_s(&self) -> Option<f64> {
        let (first, last) = (self.first_observation?, self.last_pose?);
        Some(last.saturating_duration_since(first).as_secs_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn latency_is_pose_time_minus_observation_time_by_stamp() {
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        let mut m = LatencyMatcher::default();
        m.observation(100, ms(0));
        m.observation(200, ms(5));
        m.pose(100, ms(3));
        m.observation(300, ms(9)); // rejected by the service: never gets a pose
        m.pose(200, ms(12));
        m.observation(400, ms(20));
        m.pose(400, ms(21));
        let got: Vec<(u64, u64)> = m
            .latencies()
            .iter()
            .map(|&(s, l)| (s, (l * 1e3).round() as u64))
            .collect();
        assert_eq!(got, vec![(100, 3), (200, 7), (400, 1)]);
        assert!(m.observations.is_empty(), "the unpaired 300 was forgotten");
        // Streamed from the first observation (0 ms) to the latest pose (21 ms).
        assert_eq!((m.streamed_s().unwrap() * 1e3).round(), 21.0);
        assert_eq!(LatencyMatcher::default().streamed_s(), None);
    }

    #[test]
    fn a_pose_that_arrives_first_waits_for_its_observation_and_counts_zero() {
        let t0 = Instant::now();
        let mut m = LatencyMatcher::default();
        m.pose(100, t0 + Duration::from_millis(2));
        m.observation(100, t0 + Duration::from_millis(4));
        assert_eq!(m.latencies(), &[(100, 0.0)]);
    }
}
