//! A recorded data set turned into the stack's messages, ready to publish: odometry,
//! landmark observations grouped per scan (or the raw laser scans), ground truth and the
//! true landmark map, all stamped on one clock. The data-set readers ([`crate::mrclam`],
//! [`crate::victoria_park`]) build it; the [`crate::player`] publishes it.
//!
//! Conventions every reader follows:
//! - **Stamps** are nanoseconds since the data set's *epoch*, the earliest time found in
//!   the files the replay reads ([`Clock`]), so the first message of a replay is stamped
//!   near 0 whatever clock the data set used (Unix time, seconds since power-up).
//! - **Odometry** records hold from their own time until the next record (a velocity
//!   command or an encoder reading applies over the interval that follows it). The
//!   protocol's [`Odometry`] covers the interval that *ends* at its stamp, so message
//!   `k + 1` (stamped at record `k + 1`'s time) carries record `k`'s controls, and message
//!   0 only marks the start ([`odometry`]).
//! - **Dead reckoning** in the odometry messages integrates the controls with the
//!   filter's own noise-free motion model from the origin, so it starts where the filter
//!   starts.

use crate::text::{DataError, Result};
use fastslam_estimation::Pose2;
use fastslam_estimation::motion::{Control, MotionModel};
use fastslam_protocol::header::stamp_from_secs;
use fastslam_protocol::message::Owned;
use fastslam_protocol::{
    GroundTruth, Header, LaserScanHeader, MapLandmark, Observation, ObservationsHeader, Odometry,
};
use serde::Deserialize;

/// A data set as messages, in stamp order within each stream.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DataSet {
    /// Odometry, one message per record plus the start marker.
    pub odometry: Vec<Odometry>,
    /// Landmark observations, one message per scan (camera frame, laser scan).
    pub scans: Vec<Scan>,
    /// Raw laser scans, when the profile asks for them ([`LaserOutput::Scans`]; `scans`
    /// is then empty, and a data set with both plays only these); empty otherwise.
    pub raw_scans: Vec<RawScan>,
    /// Ground truth poses (Vicon, GPS…), for the client only.
    pub truth: Vec<GroundTruth>,
    /// True landmark positions for map metrics; empty when the data set has none.
    pub landmarks: Vec<MapLandmark>,
    /// The laser's pose in the robot's base frame (REP-103: x forward, y left); the
    /// identity when the laser sits at the base's origin.
    pub laser_mount: Pose2,
    /// The data set's epoch on its own clock (s): stamp 0 is this time, so a file on the
    /// original clock (a relations file in Unix time) can be matched to the stamps.
    pub epoch_s: f64,
}

/// One scan's observations as they go on the wire (`items`: the observations, vehicle
/// frame).
pub type Scan = Owned<ObservationsHeader>;

/// One raw laser scan as it goes on the wire (`items`: one range per beam (m), no
/// intensities, a beam without a return as +∞, REP-117).
pub type RawScan = Owned<LaserScanHeader>;

/// Observations grouped per scan, before they become messages: `(stamp_ns, observations)`
/// in stamp order.
pub type ScanGroups = Vec<(u64, Vec<Observation>)>;

/// Whether observations carry the landmark's identity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Association {
    /// Each observation carries its landmark's id (MRCLAM barcodes → subject numbers);
    /// run the service with `association.mode = "known"`.
    #[default]
    Known,
    /// Every id is −1: the service must associate by itself (`mode = "unknown"`).
    Unknown,
}

impl Association {
    /// The [`Observation::id`] to publish for a landmark whose identity is `id`.
    pub fn wire_id(self, id: u64) -> i64 {
        match self {
            Self::Known => i64::try_from(id).unwrap_or(-1),
            Self::Unknown => -1,
        }
    }

    /// The service's `filter.association.mode` that goes with it.
    pub fn service_mode(self) -> &'static str {
        match self {
            Self::Known => "known",
            Self::Unknown => "unknown",
        }
    }
}

/// The landmark sensor as the replay describes it in every [`ObservationsHeader`]: the
/// range it is trusted to and its field of view. Observations beyond the range are not
/// published (a profile setting: far detections of a real sensor are often unreliable).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Largest range published (m), > 0.
    pub max_range_m: f64,
    /// Field of view centred on the vehicle's heading (deg), in (0, 360].
    pub field_of_view_deg: f64,
    /// What the replay publishes for the laser: its landmark observations (the default)
    /// or its raw scans, where the data set has them.
    #[serde(default)]
    pub publish: LaserOutput,
}

/// What a replay publishes for the data set's laser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LaserOutput {
    /// Landmark observations on `observations` (detections released with the data set).
    #[default]
    Observations,
    /// The raw range scans on `scan`: the service extracts poles or matches the scans.
    Scans,
}

impl SensorSpec {
    /// Checks the range and field of view.
    ///
    /// # Errors
    /// [`DataError::Unusable`] naming the bad value.
    pub fn validate(&self) -> Result<()> {
        if !(self.max_range_m.is_finite() && self.max_range_m > 0.0) {
            return Err(DataError::Unusable(format!(
                "sensor.max_range_m must be > 0, got {}",
                self.max_range_m
            )));
        }
        if !(self.field_of_view_deg > 0.0 && self.field_of_view_deg <= 360.0) {
            return Err(DataError::Unusable(format!(
                "sensor.field_of_view_deg must lie in (0, 360], got {}",
                self.field_of_view_deg
            )));
        }
        Ok(())
    }

    /// One message per scan from `(stamp_ns, observations)` in stamp order; observations
    /// beyond the range are dropped. Returns the scans and how many observations were
    /// dropped.
    pub fn scans(&self, groups: ScanGroups) -> (Vec<Scan>, usize) {
        let half = self.field_of_view_deg.to_radians() / 2.0;
        let mut dropped = 0;
        let scans = (groups.into_iter().enumerate())
            .map(|(seq, (stamp_ns, mut observations))| {
                let before = observations.len();
                observations.retain(|o| o.range <= self.max_range_m);
                dropped += before - observations.len();
                let header = ObservationsHeader {
                    header: Header {
                        stamp_ns,
                        seq: seq as u64,
                    },
                    count: observations.len() as u32,
                    reserved: 0,
                    max_range: self.max_range_m,
                    min_bearing: -half,
                    max_bearing: half,
                };
                Scan {
                    header,
                    items: observations,
                }
            })
            .collect();
        (scans, dropped)
    }
}

/// The data set's clock: times in seconds on the data set's own clock → stamps in
/// nanoseconds since its epoch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    epoch_s: f64,
}

impl Clock {
    /// A clock whose epoch is the earliest of `first_times` (the first time of each file).
    ///
    /// # Errors
    /// [`DataError::Unusable`] when there is no time at all (every file empty).
    pub fn starting_at(first_times: impl IntoIterator<Item = f64>) -> Result<Self> {
        let epoch_s = first_times.into_iter().fold(f64::INFINITY, f64::min);
        if epoch_s.is_finite() {
            Ok(Self { epoch_s })
        } else {
            Err(DataError::Unusable("the data set has no records".into()))
        }
    }

    /// The epoch on the data set's clock (s).
    pub fn epoch_s(&self) -> f64 {
        self.epoch_s
    }

    /// The stamp of data-set time `t_s` (ns since the epoch; times before it give 0).
    pub fn stamp(&self, t_s: f64) -> u64 {
        stamp_from_secs((t_s - self.epoch_s).max(0.0))
    }
}

/// Odometry messages from control records `(time on the data set's clock, controls)`,
/// each holding until the next record (see the module doc), with the pose dead-reckoned
/// by `model` from the origin. Message 0 marks the start: zero controls at the first
/// record's time.
pub fn odometry(records: &[(f64, Control)], model: &MotionModel, clock: &Clock) -> Vec<Odometry> {
    let mut pose = Pose2::default();
    let mut previous: Option<(u64, Control)> = None;
    let mut out = Vec::with_capacity(records.len());
    for (seq, &(t_s, control)) in records.iter().enumerate() {
        let stamp_ns = clock.stamp(t_s);
        let held = match previous {
            Some((start_ns, held)) => {
                let dt = stamp_ns.saturating_sub(start_ns) as f64 * 1e-9;
                pose = model.propagate(&pose, &held, dt);
                held
            }
            None => Control::default(),
        };
        previous = Some((stamp_ns, control));
        out.push(Odometry {
            header: Header {
                stamp_ns,
                seq: seq as u64,
            },
            v: held.v,
            omega: held.omega,
            steering: held.steering,
            x: pose.x,
            y: pose.y,
            theta: pose.theta,
        });
    }
    out
}

/// The speed along the heading and the yaw rate that take pose `from` at `from_ns` to
/// pose `to` at `to_ns` (ns); `(0, 0)` unless `to_ns` is later.
pub fn rates(from_ns: u64, from: &Pose2, to_ns: u64, to: &Pose2) -> (f64, f64) {
    if to_ns <= from_ns {
        return (0.0, 0.0);
    }
    let dt = (to_ns - from_ns) as f64 * 1e-9;
    let (dx, dy) = (to.x - from.x, to.y - from.y);
    let forward = dx * from.theta.cos() + dy * from.theta.sin();
    let turn = fastslam_estimation::wrap_angle(to.theta - from.theta);
    (forward / dt, turn / dt)
}

/// Ground-truth messages from poses `(stamp_ns, pose)` in stamp order, with speed and
/// yaw rate differentiated from the previous pose ([`rates`]; 0 for the first; steering
/// is not measured and left 0).
pub fn truth_track(poses: impl IntoIterator<Item = (u64, Pose2)>) -> Vec<GroundTruth> {
    let mut out: Vec<GroundTruth> = Vec::new();
    for (seq, (stamp_ns, p)) in poses.into_iter().enumerate() {
        let (v, omega) = out.last().map_or((0.0, 0.0), |prev| {
            let from = Pose2 {
                x: prev.x,
                y: prev.y,
                theta: prev.theta,
            };
            rates(prev.header.stamp_ns, &from, stamp_ns, &p)
        });
        out.push(GroundTruth {
            header: Header {
                stamp_ns,
                seq: seq as u64,
            },
            x: p.x,
            y: p.y,
            theta: p.theta,
            v,
            omega,
            steering: 0.0,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_estimation::motion::Unicycle;

    #[test]
    fn each_odometry_message_carries_the_controls_of_the_record_before_it() {
        let clock = Clock::starting_at([10.0, 9.5]).unwrap();
        let u = |v, omega| Control {
            v,
            omega,
            steering: 0.0,
            ..Control::ZERO
        };
        let records = [
            (10.0, u(1.0, 0.0)),
            (12.0, u(0.5, 0.25)),
            (13.0, u(9.0, 9.0)),
        ];
        let model = MotionModel::Unicycle(Unicycle::default());
        let odo = odometry(&records, &model, &clock);
        let stamps: Vec<u64> = odo.iter().map(|o| o.header.stamp_ns).collect();
        assert_eq!(stamps, [500_000_000, 2_500_000_000, 3_500_000_000]);
        assert_eq!((odo[0].v, odo[1].v, odo[2].v), (0.0, 1.0, 0.5));
        assert_eq!(odo[2].omega, 0.25);
        // 1 m/s for 2 s straight, then 0.5 m/s turning at 0.25 rad/s for 1 s (Euler step).
        assert!((odo[1].x - 2.0).abs() < 1e-12 && odo[1].y.abs() < 1e-12);
        assert!((odo[2].x - 2.5).abs() < 1e-12 && (odo[2].theta - 0.25).abs() < 1e-12);
        assert_eq!(
            odo.iter().map(|o| o.header.seq).collect::<Vec<_>>(),
            [0, 1, 2]
        );
    }

    #[test]
    fn truth_rates_come_from_consecutive_poses() {
        let track = truth_track([
            (0, Pose2::new(0.0, 0.0, 0.0)),
            (500_000_000, Pose2::new(1.0, 0.0, 0.5)),
        ]);
        assert_eq!((track[0].v, track[0].omega), (0.0, 0.0));
        assert!((track[1].v - 2.0).abs() < 1e-12 && (track[1].omega - 1.0).abs() < 1e-12);
        assert_eq!(track[1].header.seq, 1);
    }

    #[test]
    fn scans_drop_far_observations_and_describe_the_sensor() {
        let sensor = SensorSpec {
            max_range_m: 10.0,
            field_of_view_deg: 180.0,
            publish: LaserOutput::Observations,
        };
        sensor.validate().unwrap();
        let obs = |range| Observation {
            range,
            bearing: 0.0,
            diameter: 0.0,
            id: -1,
        };
        let (scans, dropped) = sensor.scans(vec![(5, vec![obs(3.0), obs(12.0)]), (9, vec![])]);
        assert_eq!(dropped, 1);
        assert_eq!(scans[0].items, vec![obs(3.0)]);
        assert_eq!((scans[0].header.count, scans[1].header.count), (1, 0));
        assert_eq!(
            scans[1].header.header,
            Header {
                stamp_ns: 9,
                seq: 1
            }
        );
        assert!((scans[0].header.max_bearing - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let bad = SensorSpec {
            field_of_view_deg: 0.0,
            ..sensor
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("field_of_view_deg")
        );
    }

    #[test]
    fn known_association_keeps_ids_and_unknown_hides_them() {
        assert_eq!(Association::Known.wire_id(7), 7);
        assert_eq!(Association::Unknown.wire_id(7), -1);
        assert!(Clock::starting_at([]).is_err());
    }
}
