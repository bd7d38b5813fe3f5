//! Checks of one message on its own: numbers finite, counts matching the payload and
//! within the limits, values in their ranges.

use super::*;
use crate::{
    GroundTruth, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation, ObservationsHeader,
    OccupancyGridHeader, Odometry, Particle, ParticlesHeader, TrajectoryHeader, TrajectoryPose,
};

/// Checks a ground-truth pose: all numbers finite.
pub fn ground_truth(m: &GroundTruth) -> Result<(), Rejection> {
    for (field, v) in [
        ("x", m.x),
        ("y", m.y),
        ("theta", m.theta),
        ("v", m.v),
        ("omega", m.omega),
        ("steering", m.steering),
    ] {
        finite(field, v)?;
    }
    Ok(())
}

/// Checks odometry: all numbers finite.
pub fn odometry(m: &Odometry) -> Result<(), Rejection> {
    for (field, v) in [
        ("v", m.v),
        ("omega", m.omega),
        ("steering", m.steering),
        ("x", m.x),
        ("y", m.y),
        ("theta", m.theta),
    ] {
        finite(field, v)?;
    }
    Ok(())
}

/// Checks a scan's observations: count matches, sensor description sane, every range
/// positive and within the sensor's maximum, every bearing finite.
pub fn observations(h: &ObservationsHeader, items: &[Observation]) -> Result<(), Rejection> {
    count(h.count, items.len(), MAX_OBSERVATIONS)?;
    finite("max_range", h.max_range)?;
    finite("min_bearing", h.min_bearing)?;
    finite("max_bearing", h.max_bearing)?;
    if h.max_range <= 0.0 {
        return Err(Rejection::OutOfRange {
            field: "max_range",
            value: h.max_range,
            reason: "must be > 0",
        });
    }
    if h.min_bearing > h.max_bearing {
        return Err(Rejection::OutOfRange {
            field: "min_bearing",
            value: h.min_bearing,
            reason: "must be ≤ max_bearing",
        });
    }
    for o in items {
        finite("range", o.range)?;
        finite("bearing", o.bearing)?;
        finite("diameter", o.diameter)?;
        if o.range <= 0.0 || o.range > h.max_range {
            return Err(Rejection::OutOfRange {
                field: "range",
                value: o.range,
                reason: "must be in (0, max_range]",
            });
        }
    }
    Ok(())
}

/// Checks that every observation carries a landmark id usable under known association:
/// 0 to [`MAX_MAP_LANDMARKS`] − 1.
pub fn known_ids(items: &[Observation]) -> Result<(), Rejection> {
    let max = MAX_MAP_LANDMARKS - 1;
    let usable = |id: i64| usize::try_from(id).is_ok_and(|id| id <= max);
    match items.iter().find(|o| !usable(o.id)) {
        Some(o) => Err(Rejection::BadLandmarkId { id: o.id, max }),
        None => Ok(()),
    }
}

/// Checks a raw scan's header against its slice: counts (1 ≤ ranges ≤
/// [`MAX_SCAN_BEAMS`], intensities 0 or one per range, slice length = ranges +
/// intensities), finite angles, times and limits, times not negative, a positive
/// increment, a sweep of at most one turn, and `0 ≤ range_min < range_max`.
///
/// Individual ranges are not judged here: REP-117 makes `+∞` (no return), `−∞` (too
/// close), NaN (invalid) and values outside `[range_min, range_max]` legitimate beam
/// values, each meaning "no obstacle measured along this beam". Receivers treat them
/// so; a scan is rejected only when its header or counts make it unreadable.
/// Intensities are carried, not used, and not checked.
pub fn laser_scan(h: &LaserScanHeader, data: &[f32]) -> Result<(), Rejection> {
    let ranges = h.ranges as usize;
    if !(1..=MAX_SCAN_BEAMS).contains(&ranges) {
        return Err(Rejection::CountOutOfRange {
            field: "ranges",
            count: ranges as u64,
            min: 1,
            max: MAX_SCAN_BEAMS,
        });
    }
    let expected = ranges + h.intensities as usize;
    let intensities_ok = h.intensities == 0 || h.intensities == h.ranges;
    if !intensities_ok || expected != data.len() {
        return Err(Rejection::BadCount {
            count: expected as u64,
            len: data.len(),
            limit: 2 * MAX_SCAN_BEAMS,
        });
    }
    for (field, v) in [
        ("angle_min", h.angle_min),
        ("angle_increment", h.angle_increment),
        ("time_increment", h.time_increment),
        ("scan_time", h.scan_time),
        ("range_min", h.range_min),
        ("range_max", h.range_max),
    ] {
        finite(field, v.into())?;
    }
    for (field, v) in [
        ("time_increment", h.time_increment),
        ("scan_time", h.scan_time),
    ] {
        if v < 0.0 {
            return Err(Rejection::OutOfRange {
                field,
                value: v.into(),
                reason: "must be ≥ 0",
            });
        }
    }
    let sweep = f64::from(h.angle_increment) * (ranges - 1) as f64;
    if h.angle_increment <= 0.0 || sweep > std::f64::consts::TAU + 1e-4 {
        return Err(Rejection::OutOfRange {
            field: "angle_increment",
            value: h.angle_increment.into(),
            reason: "must be > 0 with (ranges − 1) · angle_increment ≤ 2π",
        });
    }
    if !(h.range_min >= 0.0 && h.range_min < h.range_max) {
        return Err(Rejection::OutOfRange {
            field: "range_min",
            value: h.range_min.into(),
            reason: "must satisfy 0 ≤ range_min < range_max",
        });
    }
    Ok(())
}

/// Checks an occupancy grid: resolution finite and > 0, origin finite, `width · height`
/// cells (at most [`MAX_GRID_CELLS`]) equal to the slice length, every cell −1 or 0..=100.
pub fn occupancy_grid(h: &OccupancyGridHeader, cells: &[i8]) -> Result<(), Rejection> {
    let count = h.cells().filter(|&n| n <= MAX_GRID_CELLS);
    if count != Some(cells.len()) {
        return Err(Rejection::BadCount {
            count: u64::from(h.width) * u64::from(h.height),
            len: cells.len(),
            limit: MAX_GRID_CELLS,
        });
    }
    for (field, v) in [
        ("resolution", h.resolution),
        ("origin_x", h.origin_x),
        ("origin_y", h.origin_y),
        ("origin_theta", h.origin_theta),
    ] {
        finite(field, v)?;
    }
    if h.resolution <= 0.0 {
        return Err(Rejection::OutOfRange {
            field: "resolution",
            value: h.resolution,
            reason: "must be > 0",
        });
    }
    if let Some(&bad) = cells.iter().find(|&&c| !(-1..=100).contains(&c)) {
        return Err(Rejection::OutOfRange {
            field: "cells",
            value: bad.into(),
            reason: "must be -1 (unknown) or 0..=100",
        });
    }
    Ok(())
}

/// Checks a landmark map: count matches and every number finite.
pub fn landmark_map(h: &LandmarkMapHeader, items: &[MapLandmark]) -> Result<(), Rejection> {
    count(h.count, items.len(), MAX_MAP_LANDMARKS)?;
    for l in items {
        for (field, v) in [
            ("x", l.x),
            ("y", l.y),
            ("cov_xx", l.cov_xx),
            ("cov_xy", l.cov_xy),
            ("cov_yy", l.cov_yy),
        ] {
            finite(field, v)?;
        }
    }
    Ok(())
}

/// Checks a trajectory: the count matches the slice, every value is finite and the
/// stamps do not go backwards.
///
/// # Errors
/// The first problem found.
pub fn trajectory(h: &TrajectoryHeader, items: &[TrajectoryPose]) -> Result<(), Rejection> {
    count(h.count, items.len(), MAX_TRAJECTORY_POSES)?;
    finite("chi2_per_dof", h.chi2_per_dof)?;
    let mut order = StampOrder::default();
    for p in items {
        for (field, v) in [("x", p.x), ("y", p.y), ("theta", p.theta)] {
            finite(field, v)?;
        }
        order.accept(p.stamp_ns)?;
    }
    Ok(())
}

/// Checks a particle cloud: the count matches the slice, every value is finite and every
/// weight ≥ 0.
///
/// # Errors
/// The first problem found.
pub fn particles(h: &ParticlesHeader, items: &[Particle]) -> Result<(), Rejection> {
    count(h.count, items.len(), MAX_PARTICLES)?;
    for p in items {
        for (field, v) in [
            ("x", p.x),
            ("y", p.y),
            ("theta", p.theta),
            ("weight", p.weight),
        ] {
            finite(field, v)?;
        }
        if p.weight < 0.0 {
            return Err(Rejection::OutOfRange {
                field: "weight",
                value: p.weight,
                reason: "must be ≥ 0",
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ranges: &[f64]) -> (ObservationsHeader, Vec<Observation>) {
        let items: Vec<Observation> = ranges
            .iter()
            .map(|&range| Observation {
                range,
                bearing: 0.1,
                diameter: 0.0,
                id: -1,
            })
            .collect();
        let h = ObservationsHeader {
            count: items.len() as u32,
            max_range: 30.0,
            min_bearing: -1.5,
            max_bearing: 1.5,
            ..Default::default()
        };
        (h, items)
    }

    #[test]
    fn observations_accept_a_good_scan() {
        let (h, items) = scan(&[1.0, 29.9]);
        assert_eq!(observations(&h, &items), Ok(()));
    }

    #[test]
    fn observations_reject_nan_negative_and_over_range() {
        for bad in [f64::NAN, -1.0, 0.0, 30.5, f64::INFINITY] {
            let (h, items) = scan(&[1.0, bad]);
            assert!(observations(&h, &items).is_err(), "range {bad} accepted");
        }
    }

    #[test]
    fn observations_reject_count_mismatch() {
        let (mut h, items) = scan(&[1.0, 2.0]);
        h.count = 3;
        assert!(matches!(
            observations(&h, &items),
            Err(Rejection::BadCount {
                count: 3,
                len: 2,
                ..
            })
        ));
    }

    fn laser(ranges: &[f32], intensities: usize) -> (LaserScanHeader, Vec<f32>) {
        let mut data = ranges.to_vec();
        data.extend(std::iter::repeat_n(1.0, intensities));
        let h = LaserScanHeader {
            angle_min: -1.5,
            angle_increment: 0.01,
            range_min: 0.1,
            range_max: 30.0,
            ranges: ranges.len() as u32,
            intensities: intensities as u32,
            ..Default::default()
        };
        (h, data)
    }

    #[test]
    fn laser_scan_accepts_rep117_beam_values() {
        let odd = [2.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 0.0, 99.0];
        let (h, data) = laser(&odd, 0);
        assert_eq!(laser_scan(&h, &data), Ok(()));
        let (h, data) = laser(&odd, odd.len());
        assert_eq!(laser_scan(&h, &data), Ok(()), "with intensities");
        assert_eq!(h.ranges_of(&data).len(), 6);
        assert_eq!(h.intensities_of(&data), &[1.0; 6]);
    }

    #[test]
    fn laser_scan_rejects_bad_counts_and_headers() {
        let (mut h, data) = laser(&[1.0, 2.0, 3.0], 0);
        h.ranges = 4;
        assert!(matches!(
            laser_scan(&h, &data),
            Err(Rejection::BadCount { .. })
        ));
        let (mut h, data) = laser(&[1.0, 2.0, 3.0], 3);
        h.intensities = 2;
        assert!(matches!(
            laser_scan(&h, &data),
            Err(Rejection::BadCount { .. })
        ));
        let (mut h, data) = laser(&[1.0, 2.0], 0);
        h.angle_min = f32::NAN;
        assert_eq!(
            laser_scan(&h, &data),
            Err(Rejection::NonFinite { field: "angle_min" })
        );
        for (increment, range_min, range_max) in
            [(0.0, 0.1, 30.0), (4.0, 0.1, 30.0), (0.01, 5.0, 5.0)]
        {
            let (mut h, data) = laser(&[1.0, 2.0, 3.0], 0);
            (h.angle_increment, h.range_min, h.range_max) = (increment, range_min, range_max);
            assert!(
                matches!(laser_scan(&h, &data), Err(Rejection::OutOfRange { .. })),
                "{increment} {range_min} {range_max}"
            );
        }
        for field in ["time_increment", "scan_time"] {
            let (mut h, data) = laser(&[1.0, 2.0], 0);
            *(if field == "scan_time" {
                &mut h.scan_time
            } else {
                &mut h.time_increment
            }) = -0.001;
            assert!(
                matches!(laser_scan(&h, &data), Err(Rejection::OutOfRange { field: f, .. }) if f == field),
                "negative {field}"
            );
        }
    }

    #[test]
    fn a_scan_of_no_beams_or_too_many_names_the_real_limit() {
        let (h, _) = laser(&[], 0);
        let none = laser_scan(&h, &[]).unwrap_err();
        assert_eq!(none.to_string(), "header `ranges` = 0: must be 1 to 65536");
        let beams = vec![1.0; 100_000];
        let (mut h, data) = laser(&beams, 0);
        h.angle_increment = 1e-5;
        let many = laser_scan(&h, &data).unwrap_err();
        assert_eq!(
            many.to_string(),
            "header `ranges` = 100000: must be 1 to 65536"
        );
        assert_eq!(many.kind(), crate::status::RejectionKind::BadCount);
        let (h, data) = laser(&vec![1.0; MAX_SCAN_BEAMS], 0);
        let (h, data) = (
            LaserScanHeader {
                angle_increment: 1e-5,
                ..h
            },
            data,
        );
        assert_eq!(laser_scan(&h, &data), Ok(()), "the limit itself");
    }

    #[test]
    fn known_association_needs_ids_from_0_to_the_map_limit() {
        let with = |id: i64| Observation {
            id,
            ..Default::default()
        };
        let max = MAX_MAP_LANDMARKS as i64 - 1;
        assert_eq!(known_ids(&[with(0), with(7), with(max)]), Ok(()));
        for id in [-1, -7, max + 1, 1 << 62] {
            let e = known_ids(&[with(3), with(id)]).unwrap_err();
            assert_eq!(
                e,
                Rejection::BadLandmarkId {
                    id,
                    max: max as usize
                }
            );
            assert_eq!(e.kind(), crate::status::RejectionKind::OutOfRange);
        }
    }

    #[test]
    fn occupancy_grid_checks_size_numbers_and_cell_values() {
        let h = OccupancyGridHeader {
            resolution: 0.1,
            width: 3,
            height: 2,
            ..Default::default()
        };
        assert_eq!(occupancy_grid(&h, &[-1, 0, 100, 50, 0, -1]), Ok(()));
        assert!(matches!(
            occupancy_grid(&h, &[0; 5]),
            Err(Rejection::BadCount { .. })
        ));
        assert!(occupancy_grid(&h, &[0, 0, 0, 0, 0, 101]).is_err());
        assert!(occupancy_grid(&h, &[0, 0, 0, 0, 0, -2]).is_err());
        let nan = OccupancyGridHeader {
            origin_x: f64::NAN,
            ..h
        };
        assert!(occupancy_grid(&nan, &[0; 6]).is_err());
        let huge = OccupancyGridHeader {
            width: u32::MAX,
            height: u32::MAX,
            ..h
        };
        assert!(occupancy_grid(&huge, &[0; 6]).is_err());
    }

    #[test]
    fn odometry_rejects_non_finite() {
        let m = Odometry {
            v: f64::NAN,
            ..Default::default()
        };
        assert_eq!(odometry(&m), Err(Rejection::NonFinite { field: "v" }));
    }

    #[test]
    fn particles_need_their_count_finite_poses_and_weights_of_at_least_zero() {
        let p = Particle {
            x: 1.0,
            y: 2.0,
            theta: 0.5,
            weight: 0.5,
        };
        let header = |count| ParticlesHeader {
            count,
            ..Default::default()
        };
        assert_eq!(particles(&header(2), &[p, p]), Ok(()));
        assert!(matches!(
            particles(&header(3), &[p, p]),
            Err(Rejection::BadCount { .. })
        ));
        let nan = Particle { y: f64::NAN, ..p };
        assert_eq!(
            particles(&header(1), &[nan]),
            Err(Rejection::NonFinite { field: "y" })
        );
        let negative = Particle { weight: -0.1, ..p };
        assert!(matches!(
            particles(&header(1), &[negative]),
            Err(Rejection::OutOfRange {
                field: "weight",
                ..
            })
        ));
    }
}
