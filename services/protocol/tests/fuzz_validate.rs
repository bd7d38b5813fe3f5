//! Property tests of the decode/validation path of every input message type: whatever a
//! publisher sends, validation never panics, and whatever it accepts is finite and within
//! the documented limits. (The `validate_fuzz` bench runs the same generators for 10⁶
//! cases per type.)

mod fuzz_input;

use fastslam_protocol::validate::{
    self, Continuity, MAX_MAP_LANDMARKS, MAX_OBSERVATIONS, MAX_SCAN_BEAMS, MotionLimits,
    StreamCheck,
};
use fuzz_input::Words;
use proptest::prelude::*;

/// Runs `f` on a word source replaying `words` (then zeros).
fn with_words<T>(words: &[u64], f: impl FnOnce(&mut Words) -> T) -> T {
    let mut it = words.iter().copied();
    let mut next = move || it.next().unwrap_or(0);
    f(&mut Words(&mut next))
}

fn words() -> impl Strategy<Value = Vec<u64>> {
    prop::collection::vec(any::<u64>(), 0..400)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, rng_seed: proptest::test_runner::RngSeed::Fixed(5), ..ProptestConfig::default() })]

    #[test]
    fn accepted_odometry_is_finite_and_plausible(words in words()) {
        let limits = MotionLimits::default();
        let (a, b) = with_words(&words, |w| (fuzz_input::odometry(w), fuzz_input::odometry(w)));
        if validate::odometry(&b).is_ok() && validate::odometry_motion(&b, Some(&a), &limits).is_ok() {
            for v in [b.v, b.omega, b.steering, b.x, b.y, b.theta] {
                prop_assert!(v.is_finite());
            }
            prop_assert!(b.v.abs() <= limits.max_speed && b.omega.abs() <= limits.max_yaw_rate);
        }
    }

    #[test]
    fn accepted_ground_truth_is_finite(words in words()) {
        let m = with_words(&words, fuzz_input::ground_truth);
        if validate::ground_truth(&m).is_ok() {
            for v in [m.x, m.y, m.theta, m.v, m.omega, m.steering] {
                prop_assert!(v.is_finite());
            }
        }
    }

    #[test]
    fn accepted_observations_are_finite_and_in_range(words in words()) {
        let (h, items) = with_words(&words, fuzz_input::observations);
        if validate::observations(&h, &items).is_ok() {
            prop_assert_eq!(h.count as usize, items.len());
            prop_assert!(items.len() <= MAX_OBSERVATIONS);
            prop_assert!(h.max_range.is_finite() && h.max_range > 0.0);
            prop_assert!(h.min_bearing <= h.max_bearing);
            for o in &items {
                prop_assert!(o.range > 0.0 && o.range <= h.max_range);
                prop_assert!(o.bearing.is_finite() && o.diameter.is_finite());
            }
        }
    }

    #[test]
    fn accepted_laser_scans_are_readable(words in words()) {
        let (h, data) = with_words(&words, fuzz_input::laser_scan);
        if validate::laser_scan(&h, &data).is_ok() {
            let ranges = h.ranges as usize;
            prop_assert!((1..=MAX_SCAN_BEAMS).contains(&ranges));
            prop_assert_eq!(ranges + h.intensities as usize, data.len());
            prop_assert_eq!(h.ranges_of(&data).len(), ranges);
            prop_assert!(h.angle_increment > 0.0 && h.angle_min.is_finite());
            prop_assert!(h.range_min >= 0.0 && h.range_min < h.range_max && h.range_max.is_finite());
        }
    }

    #[test]
    fn accepted_landmark_maps_are_finite(words in words()) {
        let (h, items) = with_words(&words, fuzz_input::landmark_map);
        if validate::landmark_map(&h, &items).is_ok() {
            prop_assert_eq!(h.count as usize, items.len());
            prop_assert!(items.len() <= MAX_MAP_LANDMARKS);
            for l in &items {
                for v in [l.x, l.y, l.cov_xx, l.cov_xy, l.cov_yy] {
                    prop_assert!(v.is_finite());
                }
            }
        }
    }

    #[test]
    fn stream_check_keeps_stamps_in_order_and_steps_bounded(words in words()) {
        const MAX_JUMP: u64 = 10_000_000_000;
        let headers = with_words(&words, |w| (0..60).map(|_| w.header()).collect::<Vec<_>>());
        let mut check = StreamCheck::new(MAX_JUMP);
        let mut last: Option<fastslam_protocol::Header> = None;
        for h in headers {
            if let Ok(how) = check.accept(h) {
                if let Some(l) = last {
                    prop_assert!(h.stamp_ns >= l.stamp_ns);
                    prop_assert!(h.stamp_ns - l.stamp_ns <= MAX_JUMP);
                    match how {
                        Continuity::Continues => prop_assert!(h.seq > l.seq),
                        Continuity::Restarted => prop_assert!(h.seq < l.seq && h.stamp_ns > l.stamp_ns),
                    }
                }
                last = Some(h);
            }
        }
    }
}
