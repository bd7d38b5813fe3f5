//! What became of the stack's inputs: those the service dropped or rejected and those a
//! resumed service skipped (from its status), and the lidar messages that carried nothing
//! the filter can use (counted by the client); with the summary's warnings about them.

use crate::recording::Recording;
use fastslam_estimation::scan::{Beam, RangeScan};
use fastslam_protocol::LaserScanHeader;
use fastslam_protocol::message::Message;
use fastslam_protocol::status::RejectionKind;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What became of the inputs: rejections by reason ([`RejectionKind::name`]) as the
/// service's newest status counted them, what a resumed service skipped, and the lidar
/// messages without anything usable.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct InputAccount {
    /// Every reason with its count, zeros included.
    pub rejected: BTreeMap<String, u64>,
    /// All reasons together.
    pub rejected_total: u64,
    /// Inputs the service skipped because the checkpoint it resumed from already holds
    /// them (0 when it did not resume): the poses of those inputs are not this run's.
    #[serde(default)]
    pub skipped_resumed: u64,
    /// Lidar messages the client received: raw scans or observation sets.
    #[serde(default)]
    pub lidar_messages: u64,
    /// Of those, the ones that carried nothing the filter can use: a scan without a
    /// single return (every beam NaN, too close, or without a return), an observation set
    /// without an observation, or a message the checks refused.
    #[serde(default)]
    pub lidar_unusable: u64,
}

impl InputAccount {
    /// The counts of `rec`.
    pub fn of(rec: &Recording) -> Self {
        let rejected: BTreeMap<String, u64> = (RejectionKind::ALL.iter())
            .filter(|&&kind| kind != RejectionKind::Covered)
            .map(|&kind| (kind.name().to_string(), rec.rejections[kind as usize]))
            .collect();
        Self {
            rejected_total: rejected.values().sum(),
            rejected,
            skipped_resumed: rec.rejections[RejectionKind::Covered as usize],
            lidar_messages: rec.lidar.messages,
            lidar_unusable: rec.lidar.unusable,
        }
    }

    /// The reasons with a count, as `name count` joined by `, ` (empty when none).
    pub fn nonzero(&self) -> String {
        let parts: Vec<String> = (self.rejected.iter())
            .filter(|(_, n)| **n > 0)
            .map(|(name, n)| format!("{name} {n}"))
            .collect();
        parts.join(", ")
    }

    /// The warnings a run's summary gives about its inputs, one line each; none when
    /// every input was used.
    pub fn warnings(&self) -> Vec<String> {
        let mut lines = Vec::new();
        if self.rejected_total > 0 {
            lines.push(format!(
                "the service dropped or rejected {} inputs ({}): see /inputs in metrics.json \
                 and logs/service.log",
                self.rejected_total,
                self.nonzero()
            ));
        }
        if self.lidar_messages > 0 && self.lidar_unusable == self.lidar_messages {
            lines.push(format!(
                "none of the {} lidar messages carried anything usable (scans without a \
                 return: every beam NaN, too close or beyond range; or no observation): the \
                 estimate is dead reckoning (/inputs/lidar_unusable in metrics.json)",
                self.lidar_messages
            ));
        }
        if self.skipped_resumed > 0 {
            lines.push(format!(
                "the service resumed from a checkpoint and skipped {} inputs it already \
                 held: the run is scored only from the checkpoint on \
                 (/inputs/skipped_resumed in metrics.json)",
                self.skipped_resumed
            ));
        }
        lines
    }
}

/// The lidar messages received and how many carried nothing usable.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LidarCount {
    /// Raw scans or observation sets received.
    pub messages: u64,
    /// Those without anything the filter can use (see [`InputAccount::lidar_unusable`]).
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
    use fastslam_protocol::status::REJECTION_KINDS;
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

    #[test]
    fn a_lidar_stream_that_never_contributes_and_a_resumed_run_are_warned_about() {
        let mut rec = Recording::default();
        assert!(InputAccount::of(&rec).warnings().is_empty(), "all is well");
        rec.lidar = LidarCount {
            messages: 40,
            unusable: 40,
        };
        rec.rejections = [0; REJECTION_KINDS];
        rec.rejections[RejectionKind::Covered as usize] = 1083;
        let account = InputAccount::of(&rec);
        assert_eq!(account.rejected_total, 0, "skipped is not rejected");
        assert!(!account.rejected.contains_key("covered"));
        assert_eq!(account.skipped_resumed, 1083);
        let warnings = account.warnings();
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].contains("none of the 40") && warnings[0].contains("dead reckoning"));
        assert!(warnings[1].contains("resumed") && warnings[1].contains("1083"));
        rec.lidar.unusable = 39;
        assert_eq!(
            InputAccount::of(&rec).warnings().len(),
            1,
            "one scan counts"
        );
    }
}
