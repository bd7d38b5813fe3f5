//! A bag's laser scans as the protocol carries them, and the stamp order every stream
//! must keep.
//!
//! Scans ([`scan`]):
//! - **Ranges follow REP-117**: +∞ (no return), −∞ (too close) and NaN (invalid) are kept
//!   as they are; a finite reading above `range_max` becomes +∞ and one below `range_min`
//!   becomes −∞, so a driver that writes "no return" as a large number is read the same
//!   as one that writes +∞. Intensities are dropped.
//! - **Beams sweep counter-clockwise**: a scan with a negative `angle_increment` (a
//!   clockwise scanner), or from a laser mounted upside down (its beams turn the other
//!   way in the robot's frame), has its ranges reversed and its first angle moved to the
//!   other end, so `angle_increment > 0` as the protocol requires. The reversed beams were
//!   measured last to first, which a positive `time_increment` cannot say: it becomes 0
//!   (the scan is treated as instantaneous).
//!
//! Stamps ([`order`]): within a stream stamps must strictly increase. Messages are sorted
//! by stamp (stably, so equal stamps keep their recorded order); a message equal to one
//! already kept at the same stamp is dropped as a duplicate, any other message at or
//! before the previous stamp is moved to 1 ns after it.

use super::cdr;
use fastslam_protocol::{Header, LaserScanHeader, validate};

/// How a stream's stamps were put in order.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StampRepairs {
    /// Messages recorded with a stamp older than one before them (sorted into place).
    pub reordered: usize,
    /// Exact duplicates (same stamp, same content) dropped.
    pub duplicates: usize,
    /// Messages moved 1 ns past the previous one to keep stamps strictly increasing.
    pub nudged: usize,
}

impl StampRepairs {
    /// Whether nothing had to be repaired.
    pub fn is_clean(&self) -> bool {
        *self == Self::default()
    }
}

impl std::fmt::Display for StampRepairs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} reordered, {} duplicates dropped, {} nudged by 1 ns",
            self.reordered, self.duplicates, self.nudged
        )
    }
}

/// `items` `(stamp_ns, value)` with strictly increasing stamps (see the module doc);
/// `same` says whether two values are duplicates.
pub fn order<T>(
    mut items: Vec<(u64, T)>,
    same: impl Fn(&T, &T) -> bool,
) -> (Vec<(u64, T)>, StampRepairs) {
    let mut repairs = StampRepairs::default();
    let mut newest: Option<u64> = None;
    for (t, _) in &items {
        if newest.is_some_and(|n| *t < n) {
            repairs.reordered += 1;
        }
        newest = newest.max(Some(*t));
    }
    items.sort_by_key(|(t, _)| *t);
    let mut out: Vec<(u64, T)> = Vec::with_capacity(items.len());
    let (mut group_stamp, mut group_start) = (None, 0);
    for (t, value) in items {
        if group_stamp == Some(t) {
            if out[group_start..]
                .iter()
                .any(|(_, kept)| same(kept, &value))
            {
                repairs.duplicates += 1;
                continue;
            }
        } else {
            group_stamp = Some(t);
            group_start = out.len();
        }
        let stamp = match out.last() {
            Some((previous, _)) if t <= *previous => {
                repairs.nudged += 1;
                previous.saturating_add(1)
            }
            _ => t,
        };
        out.push((stamp, value));
    }
    (out, repairs)
}

/// What [`scan`] changed besides the ranges.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScanFixes {
    /// The beams were reversed (see the module doc).
    pub reversed: bool,
    /// A negative or non-finite `time_increment` or `scan_time` was set to 0.
    pub timing_zeroed: bool,
}

/// The range after REP-117 (see the module doc).
pub fn rep117(r: f32, range_min: f32, range_max: f32) -> f32 {
    if !r.is_finite() {
        r
    } else if r > range_max {
        f32::INFINITY
    } else if r < range_min {
        f32::NEG_INFINITY
    } else {
        r
    }
}

/// The wire header (stamp and seq left 0) and ranges of `msg`, beams counter-clockwise in
/// the laser's frame, or in its upright frame when `mirrored` (mounted upside down);
/// `None` for a scan without beams.
///
/// # Errors
/// When the scan's layout is not one the protocol carries (non-finite angles, range
/// limits that bound nothing, a zero increment, more beams than allowed).
pub fn scan(
    msg: &cdr::LaserScan,
    mirrored: bool,
) -> Result<Option<(LaserScanHeader, Vec<f32>, ScanFixes)>, String> {
    let n = msg.ranges.len();
    if n == 0 {
        return Ok(None);
    }
    for (field, v) in [
        ("angle_min", msg.angle_min),
        ("angle_increment", msg.angle_increment),
        ("range_min", msg.range_min),
        ("range_max", msg.range_max),
    ] {
        if !v.is_finite() {
            return Err(format!("{field} is {v}"));
        }
    }
    if !(msg.range_min >= 0.0 && msg.range_min < msg.range_max) {
        return Err(format!(
            "range_min {} and range_max {} must satisfy 0 ≤ range_min < range_max",
            msg.range_min, msg.range_max
        ));
    }
    let mut ranges: Vec<f32> = (msg.ranges.iter())
        .map(|&r| rep117(r, msg.range_min, msg.range_max))
        .collect();
    let sign = if mirrored { -1.0 } else { 1.0 };
    let mut angle_min = sign * f64::from(msg.angle_min);
    let mut increment = sign * f64::from(msg.angle_increment);
    let reversed = increment < 0.0;
    if reversed {
        angle_min += (n - 1) as f64 * increment;
        increment = -increment;
        ranges.reverse();
    }
    let timing = |v: f32| (v.is_finite() && v >= 0.0).then_some(v);
    let timing_zeroed = timing(msg.time_increment).is_none() || timing(msg.scan_time).is_none();
    let header = LaserScanHeader {
        header: Header::default(),
        angle_min: angle_min as f32,
        angle_increment: increment as f32,
        time_increment: if reversed {
            0.0
        } else {
            timing(msg.time_increment).unwrap_or(0.0)
        },
        scan_time: timing(msg.scan_time).unwrap_or(0.0),
        range_min: msg.range_min,
        range_max: msg.range_max,
        ranges: u32::try_from(n).unwrap_or(u32::MAX),
        intensities: 0,
    };
    validate::laser_scan(&header, &ranges).map_err(|r| r.to_string())?;
    Ok(Some((
        header,
        ranges,
        ScanFixes {
            reversed,
            timing_zeroed,
        },
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    fn msg(angle_min: f32, increment: f32, ranges: &[f32]) -> cdr::LaserScan {
        cdr::LaserScan {
            angle_min,
            angle_increment: increment,
            time_increment: 0.001,
            scan_time: 0.1,
            range_min: 0.1,
            range_max: 10.0,
            ranges: ranges.to_vec(),
            ..Default::default()
        }
    }

    #[test]
    fn ranges_outside_the_limits_become_rep117_infinities() {
        let raw = [
            5.0,
            10.0,
            12.0,
            0.05,
            0.1,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let (h, ranges, fixes) = scan(&msg(-1.0, 0.25, &raw), false).unwrap().unwrap();
        assert_eq!(
            &ranges[..5],
            [5.0, 10.0, f32::INFINITY, f32::NEG_INFINITY, 0.1]
        );
        assert_eq!(ranges[5], f32::INFINITY);
        assert_eq!(ranges[6], f32::NEG_INFINITY);
        assert!(ranges[7].is_nan());
        assert_eq!((h.angle_min, h.angle_increment, h.ranges), (-1.0, 0.25, 8));
        assert_eq!((h.time_increment, h.intensities), (0.001, 0));
        assert_eq!(fixes, ScanFixes::default());
    }

    #[test]
    fn a_clockwise_scan_is_reversed_to_sweep_counter_clockwise() {
        let (h, ranges, fixes) = scan(&msg(FRAC_PI_2, -0.5, &[1.0, 2.0, 3.0]), false)
            .unwrap()
            .unwrap();
        // Beams at π/2, π/2 − 0.5, π/2 − 1 become π/2 − 1, π/2 − 0.5, π/2.
        assert!((h.angle_min - (FRAC_PI_2 - 1.0)).abs() < 1e-6);
        assert_eq!(h.angle_increment, 0.5);
        assert_eq!(ranges, [3.0, 2.0, 1.0]);
        assert_eq!(h.time_increment, 0.0);
        assert!(fixes.reversed);
        // The same scanner upside down turns counter-clockwise again: beam order kept.
        let (h, ranges, fixes) = scan(&msg(FRAC_PI_2, -0.5, &[1.0, 2.0, 3.0]), true)
            .unwrap()
            .unwrap();
        assert_eq!((h.angle_min, h.angle_increment), (-FRAC_PI_2, 0.5));
        assert_eq!(
            (ranges, h.time_increment, fixes.reversed),
            (vec![1.0, 2.0, 3.0], 0.001, false)
        );
        // A counter-clockwise scanner upside down: angles mirrored, beams reversed.
        let (h, ranges, _) = scan(&msg(-1.0, 0.5, &[1.0, 2.0, 3.0]), true)
            .unwrap()
            .unwrap();
        assert_eq!((h.angle_min, h.angle_increment), (0.0, 0.5));
        assert_eq!(ranges, [3.0, 2.0, 1.0]);
    }

    #[test]
    fn layouts_the_protocol_cannot_carry_are_errors() {
        assert!(scan(&msg(0.0, 0.1, &[]), false).unwrap().is_none());
        assert!(
            scan(&msg(f32::NAN, 0.1, &[1.0]), false)
                .unwrap_err()
                .contains("angle_min")
        );
        assert!(scan(&msg(0.0, 0.0, &[1.0, 2.0]), false).is_err());
        let mut bad = msg(0.0, 0.1, &[1.0]);
        bad.range_max = 0.0;
        assert!(scan(&bad, false).unwrap_err().contains("range_min"));
        bad = msg(0.0, 0.1, &[1.0]);
        bad.time_increment = -0.1;
        let (h, _, fixes) = scan(&bad, false).unwrap().unwrap();
        assert_eq!((h.time_increment, fixes.timing_zeroed), (0.0, true));
    }

    #[test]
    fn stamps_are_sorted_deduplicated_and_nudged_apart() {
        let items = vec![
            (10, 'a'),
            (30, 'b'),
            (20, 'c'),
            (30, 'b'),
            (30, 'd'),
            (31, 'e'),
        ];
        let (out, repairs) = order(items, |a, b| a == b);
        assert_eq!(out, [(10, 'a'), (20, 'c'), (30, 'b'), (31, 'd'), (32, 'e')]);
        assert_eq!(
            repairs,
            StampRepairs {
                reordered: 1,
                duplicates: 1,
                nudged: 2
            }
        );
        let (clean, repairs) = order(vec![(1, 0), (2, 0)], |a, b| a == b);
        assert_eq!(clean.len(), 2);
        assert!(repairs.is_clean());
    }
}
