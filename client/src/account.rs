//! What became of the stack's inputs: those the service dropped or rejected and those a
//! resumed service skipped (from its status), and the lidar messages that carried nothing
//! the filter can use (counted by the client); with the summary's warnings about them.

use crate::recording::Recording;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lidar_count::LidarCount;
    use fastslam_protocol::status::REJECTION_KINDS;

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
