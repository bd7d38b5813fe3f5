//! The lidar messages the client received, and those that carried nothing the filter can
//! use (a scan without a return, an empty observation set, a refused message).

use fastslam_estimation::scan::{Beam, RangeScan};
use fastslam_protocol::LaserScanHeader;
use fastslam_protocol::message::Message;

/// The lidar messages received and how many carried nothing usable.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LidarCount {
    /// Raw scans or observation sets received.
    pub messages: u64,
    /// Those without anything the filter can use (see [`InputAccount::lidar_unusable`](crate::account::InputAccount::lidar_unusable)).
    pub unusable: u64,
}

impl LidarCount {
    /// Counts `message` if it is a lidar message (`valid` when it passed the checks);
    /// true when it carries nothing the filter can use.
    pub fn note(&mut self, message: Message<'_>, valid: bool) -> bool {
        let unusable = match message {
            Message::Scan(h, data) => !valid || !has_a_return(h, data),
            Message::Observations(_, observations) => !valid || observations.is_empty(),
            _ => return false,
        };
        self.messages += 1;
        self.unusable += u64::from(unusable);
        unusable
    }
}

/// True when a beam of the scan (header `h`, ranges first in `data`) measured an
/// obstacle: REP-117's NaN, `−∞`, ranges below `range_min` and beams without a return
/// measure none.
pub fn has_a_return(h: &LaserScanHeader, data: &[f32]) -> bool {
    let scan = RangeScan {
        angle_min: h.angle_min.into(),
        angle_increment: h.angle_increment.into(),
        range_min: h.range_min.into(),
        range_max: h.range_max.into(),
        ranges: &data[..(h.ranges as usize).min(data.len())],
    };
    (0..scan.len()).any(|i| matches!(scan.beam(i), Beam::Hit(_)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_protocol::{Header, Observation, ObservationsHeader};

    fn scan(ranges: u32) -> LaserScanHeader {
        LaserScanHeader {
            header: Header::default(),
            angle_increment: 0.01,
            range_min: 0.1,
            range_max: 30.0,
            ranges,
            ..LaserScanHeader::default()
        }
    }

    #[test]
    fn scans_without_a_return_and_empty_observation_sets_are_unusable() {
        let mut count = LidarCount::default();
        let h = scan(4);
        let nan = [f32::NAN; 4];
        assert!(count.note(Message::Scan(&h, &nan), true), "every beam NaN");
        let nothing = [f32::INFINITY, f32::NEG_INFINITY, 0.01, 31.0];
        assert!(count.note(Message::Scan(&h, &nothing), true), "no return");
        let one = [f32::NAN, 5.0, f32::NAN, f32::NAN];
        assert!(
            !count.note(Message::Scan(&h, &one), true),
            "one hit is enough"
        );
        assert!(
            count.note(Message::Scan(&h, &one), false),
            "refused by the checks"
        );
        let oh = ObservationsHeader::default();
        assert!(count.note(Message::Observations(&oh, &[]), true));
        let seen = [Observation::default()];
        assert!(!count.note(Message::Observations(&oh, &seen), true));
        let truth = fastslam_protocol::GroundTruth::default();
        assert!(
            !count.note(Message::GroundTruth(&truth), false),
            "not lidar"
        );
        assert_eq!(
            count,
            LidarCount {
                messages: 6,
                unusable: 4
            }
        );
    }
}
