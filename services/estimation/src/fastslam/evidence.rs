//! Negative evidence (docs/ALGORITHMS.md §1 step 4): a landmark that stays unconfirmed while the
//! sensor keeps looking at it was probably spurious and is removed.
//!
//! A landmark is *tentative* while `hits < min_hits`. Every scan in which a tentative
//! landmark lies inside the sensor footprint (seen from the particle's pose, shrunk by
//! the margins so landmarks at the edge of range do not count) is a *chance*; a tentative
//! landmark that reaches `chances` chances is removed. A confirmed landmark is never
//! removed, so its chances are not counted — which spares a map write per landmark in
//! view per particle per scan.

use super::landmarks::LandmarkMap;
use crate::Result;
use crate::check::{non_negative, require};
use crate::observation::{self, Sensor};
use crate::pose::Pose2;
use serde::{Deserialize, Serialize};

/// Settings of negative evidence; `min_hits = 0` switches it off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NegativeEvidence {
    /// Hits (scans with an assigned observation, creation included) that confirm a
    /// landmark; 0 disables negative evidence.
    pub min_hits: u32,
    /// Chances (scans in view while tentative) after which a still tentative landmark is
    /// removed; ≥ 1 when enabled.
    pub chances: u32,
    /// The footprint's far edge is pulled in by this much for counting chances (m).
    pub margin_range: f64,
    /// Each side edge of the field of view is pulled in by this much (rad).
    pub margin_bearing: f64,
}

impl Default for NegativeEvidence {
    fn default() -> Self {
        Self {
            min_hits: 2,
            chances: 5,
            margin_range: 1.0,
            margin_bearing: 2f64.to_radians(),
        }
    }
}

impl NegativeEvidence {
    /// Checks the counts and margins.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] for `chances = 0` while enabled, or a negative
    /// or non-finite margin.
    pub fn validate(&self) -> Result<()> {
        require(
            self.min_hits == 0 || self.chances > 0,
            "negative_evidence.chances",
            || "must be >= 1 when min_hits > 0".into(),
        )?;
        non_negative("negative_evidence.margin_range", self.margin_range)?;
        non_negative("negative_evidence.margin_bearing", self.margin_bearing)
    }

    /// Counts a chance for every tentative landmark of `map` in view of `sensor` at
    /// `pose` and removes those that have used up their chances. Returns how many were
    /// removed. `map` must track its tentative landmarks below `min_hits`
    /// ([`LandmarkMap::track_tentative`], as the filter's maps do).
    ///
    /// # Performance
    /// O(T log M) for T tentative landmarks (looked up by id: no spatial query);
    /// writes only those in view, allocates only to copy what it writes.
    pub(crate) fn apply(&self, map: &mut LandmarkMap, pose: &Pose2, sensor: &Sensor) -> usize {
        if self.min_hits == 0 {
            return 0;
        }
        debug_assert_eq!(map.tentative_below(), self.min_hits, "untracked map");
        let tentative = map.tentative();
        let mut removed = 0;
        for &id in tentative.iter() {
            let Some((slot, landmark)) = map.locate(id) else {
                continue;
            };
            let z = observation::measure(pose, &landmark.mean);
            if !sensor.sees(&z, self.margin_range, self.margin_bearing) {
                continue;
            }
            let mut expired = false;
            map.update_at(slot, |landmark| {
                landmark.chances = landmark.chances.saturating_add(1);
                expired = landmark.chances >= self.chances;
            });
            if expired && map.remove(id).is_some() {
                removed += 1;
            }
        }
        removed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fastslam::landmarks::Landmark;
    use nalgebra::{Matrix2, Vector2};

    fn landmark(id: u64, x: f64, y: f64, hits: u32) -> Landmark {
        Landmark {
            id,
            mean: Vector2::new(x, y),
            covariance: Matrix2::identity() * 0.01,
            hits,
            chances: 0,
        }
    }

    #[test]
    fn tentative_landmarks_in_view_expire_and_others_stay() {
        let evidence = NegativeEvidence::default();
        let sensor = Sensor::default();
        let pose = Pose2::default();
        let mut map = LandmarkMap::new(10.0).track_tentative(evidence.min_hits);
        map.insert(landmark(0, 10.0, 0.0, 1)); // tentative, in view
        map.insert(landmark(1, 12.0, 3.0, 2)); // confirmed, in view
        map.insert(landmark(2, -10.0, 0.0, 1)); // tentative, behind the sensor
        map.insert(landmark(3, 29.5, 0.0, 1)); // tentative, inside the range margin
        for scan in 1..evidence.chances {
            assert_eq!(evidence.apply(&mut map, &pose, &sensor), 0);
            assert_eq!(map.get(0).unwrap().chances, scan);
        }
        assert_eq!(evidence.apply(&mut map, &pose, &sensor), 1);
        assert!(map.get(0).is_none());
        assert_eq!(
            map.get(1).unwrap().chances,
            0,
            "confirmed landmarks are not counted"
        );
        assert_eq!(map.get(2).unwrap().chances, 0);
        assert_eq!(map.get(3).unwrap().chances, 0);
    }

    #[test]
    fn min_hits_zero_disables_negative_evidence() {
        let evidence = NegativeEvidence {
            min_hits: 0,
            chances: 0,
            ..NegativeEvidence::default()
        };
        assert!(evidence.validate().is_ok());
        let mut map = LandmarkMap::new(10.0);
        map.insert(landmark(0, 10.0, 0.0, 1));
        for _ in 0..10 {
            evidence.apply(&mut map, &Pose2::default(), &Sensor::default());
        }
        assert_eq!(map.len(), 1);
        let bad = NegativeEvidence {
            chances: 0,
            ..NegativeEvidence::default()
        };
        assert!(bad.validate().is_err());
    }
}
