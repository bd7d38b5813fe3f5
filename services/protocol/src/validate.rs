//! Checks every receiver applies before it uses a message: a bad message is reported
//! with its reason and skipped, never allowed to crash the receiver or poison the filter.

use crate::{
    GroundTruth, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation, ObservationsHeader,
    OccupancyGridHeader, Odometry, Particle, ParticlesHeader, TrajectoryHeader, TrajectoryPose,
};

/// Most observations one message may carry.
pub const MAX_OBSERVATIONS: usize = 4096;
/// Most landmarks one map message may carry.
pub const MAX_MAP_LANDMARKS: usize = 1 << 20;
/// Most beams one scan may carry.
pub const MAX_SCAN_BEAMS: usize = 1 << 16;
/// Most poses one trajectory message may carry (a day at 10 Hz).
pub const MAX_TRAJECTORY_POSES: usize = 1 << 20;
/// Most particles one particle cloud may carry.
pub const MAX_PARTICLES: usize = 1 << 20;
/// Most cells one occupancy grid may carry (a 1 km square at 0.25 m).
pub const MAX_GRID_CELLS: usize = 1 << 24;

/// Why a message was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Rejection {
    /// A field that must be a finite number is NaN or infinite.
    #[error("non-finite `{field}`")]
    NonFinite {
        /// The field's name.
        field: &'static str,
    },
    /// A value is outside its allowed range.
    #[error("`{field}` = {value} out of range: {reason}")]
    OutOfRange {
        /// The field's name.
        field: &'static str,
        /// The rejected value.
        value: f64,
        /// The allowed range, in words.
        reason: &'static str,
    },
    /// The header's count disagrees with the slice length, or exceeds the limit.
    #[error("header count {count} but {len} items (limit {limit})")]
    BadCount {
        /// Count the header claims.
        count: u64,
        /// Items actually in the slice.
        len: usize,
        /// The limit for this message type.
        limit: usize,
    },
    /// A count in the header is outside what the message type allows (a scan of no
    /// beams, or of more than [`MAX_SCAN_BEAMS`]).
    #[error("header `{field}` = {count}: must be {min} to {max}")]
    CountOutOfRange {
        /// The count's field.
        field: &'static str,
        /// The count the header claims.
        count: u64,
        /// The fewest allowed.
        min: usize,
        /// The most allowed.
        max: usize,
    },
    /// An observation's landmark id cannot be one under known association: negative
    /// (−1 means "unknown") or beyond [`MAX_MAP_LANDMARKS`].
    #[error("landmark id {id}: known association needs ids 0 to {max}")]
    BadLandmarkId {
        /// The rejected id.
        id: i64,
        /// The largest id allowed.
        max: usize,
    },
    /// The stamp is older than the stream's previous message.
    #[error("stamp {stamp_ns} ns goes back before {previous_ns} ns")]
    StampBackwards {
        /// This message's stamp.
        stamp_ns: u64,
        /// The previous message's stamp.
        previous_ns: u64,
    },
    /// The sequence number repeats (or goes back without the stamp advancing, which a
    /// restarted publisher would do).
    #[error("seq {seq} already seen (newest {newest})")]
    Duplicate {
        /// This message's sequence number.
        seq: u64,
        /// The newest sequence number accepted on the stream.
        newest: u64,
    },
    /// The stamp jumps further ahead of the stream's previous stamp than allowed.
    #[error("stamp {stamp_ns} ns jumps more than {max_ns} ns past {previous_ns} ns")]
    StampJump {
        /// This message's stamp.
        stamp_ns: u64,
        /// The previous message's stamp.
        previous_ns: u64,
        /// The largest allowed step.
        max_ns: u64,
    },
    /// Odometry implies a motion no vehicle makes: a speed or yaw rate over its limit, or
    /// a dead-reckoned pose that jumps further than the speed limit allows.
    #[error("odometry `{field}` = {value} beyond the plausible {limit}")]
    Teleport {
        /// The implausible quantity.
        field: &'static str,
        /// Its value (m/s, rad/s or m).
        value: f64,
        /// The limit it broke.
        limit: f64,
    },
}

impl Rejection {
    /// The counter this rejection belongs to in [`crate::ServiceStatus::rejections`].
    pub fn kind(&self) -> crate::status::RejectionKind {
        use crate::status::RejectionKind as K;
        match self {
            Self::NonFinite { .. } => K::NonFinite,
            Self::OutOfRange { .. } => K::OutOfRange,
            Self::BadCount { .. } | Self::CountOutOfRange { .. } => K::BadCount,
            Self::BadLandmarkId { .. } => K::OutOfRange,
            Self::StampBackwards { .. } => K::StampBackwards,
            Self::Duplicate { .. } => K::Duplicate,
            Self::StampJump { .. } => K::StampJump,
            Self::Teleport { .. } => K::Teleport,
        }
    }
}

fn finite(field: &'static str, v: f64) -> Result<(), Rejection> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Rejection::NonFinite { field })
    }
}

fn count(count: u32, len: usize, limit: usize) -> Result<(), Rejection> {
    if count as usize == len && len <= limit {
        Ok(())
    } else {
        Err(Rejection::BadCount {
            count: count.into(),
            len,
            limit,
        })
    }
}

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

/// Per-stream stamp order: remembers the newest stamp and rejects older ones.
#[derive(Debug, Default, Clone)]
pub struct StampOrder {
    last_ns: Option<u64>,
}

impl StampOrder {
    /// Accepts `stamp_ns` when it is not older than the previous accepted stamp.
    ///
    /// # Errors
    /// [`Rejection::StampBackwards`] otherwise (the stream's state is left unchanged).
    pub fn accept(&mut self, stamp_ns: u64) -> Result<(), Rejection> {
        match self.last_ns {
            Some(previous_ns) if stamp_ns < previous_ns => Err(Rejection::StampBackwards {
                stamp_ns,
                previous_ns,
            }),
            _ => {
                self.last_ns = Some(stamp_ns);
                Ok(())
            }
        }
    }

    /// The newest accepted stamp: the stream's watermark.
    pub fn last(&self) -> Option<u64> {
        self.last_ns
    }
}

/// How a message continued its stream, when [`StreamCheck::accept`] took it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Continuity {
    /// The next message of the same publisher (or the stream's first).
    Continues,
    /// The sequence number went back while the stamp advanced: a restarted publisher,
    /// which numbers its messages from 0 again. Per-publisher state (a dead-reckoned
    /// pose) starts afresh.
    Restarted,
}

/// Per-stream header checks: stamps never go back and never jump further ahead than
/// `max_jump_ns`, sequence numbers never repeat — except that a publisher restart (seq
/// back, stamp forward) is accepted, and after [`StreamCheck::resync`] (the stream went
/// quiet) one jump of any size forward is.
#[derive(Debug, Clone)]
pub struct StreamCheck {
    max_jump_ns: u64,
    last: Option<crate::Header>,
    resync: bool,
}

impl StreamCheck {
    /// A check allowing stamp steps of at most `max_jump_ns`.
    pub fn new(max_jump_ns: u64) -> Self {
        Self {
            max_jump_ns,
            last: None,
            resync: false,
        }
    }

    /// Accepts `h` when it continues the stream (see the type's doc); the stream's
    /// state is updated only then.
    ///
    /// # Errors
    /// [`Rejection::StampBackwards`], [`Rejection::Duplicate`] or
    /// [`Rejection::StampJump`].
    pub fn accept(&mut self, h: crate::Header) -> Result<Continuity, Rejection> {
        let Some(last) = self.last else {
            self.last = Some(h);
            self.resync = false;
            return Ok(Continuity::Continues);
        };
        if h.stamp_ns < last.stamp_ns {
            return Err(Rejection::StampBackwards {
                stamp_ns: h.stamp_ns,
                previous_ns: last.stamp_ns,
            });
        }
        let restarted = h.seq < last.seq && h.stamp_ns > last.stamp_ns;
        if h.seq <= last.seq && !restarted {
            return Err(Rejection::Duplicate {
                seq: h.seq,
                newest: last.seq,
            });
        }
        if !self.resync && h.stamp_ns - last.stamp_ns > self.max_jump_ns {
            return Err(Rejection::StampJump {
                stamp_ns: h.stamp_ns,
                previous_ns: last.stamp_ns,
                max_ns: self.max_jump_ns,
            });
        }
        self.last = Some(h);
        self.resync = false;
        Ok(if restarted {
            Continuity::Restarted
        } else {
            Continuity::Continues
        })
    }

    /// Lets the next message jump ahead by any amount: call it when the stream went
    /// quiet, so a publisher that returns after a long pause is not rejected forever.
    pub fn resync(&mut self) {
        self.resync = true;
    }

    /// The newest accepted stamp: the stream's watermark.
    pub fn last(&self) -> Option<u64> {
        self.last.map(|h| h.stamp_ns)
    }
}

/// Limits of plausible odometry (a vehicle cannot teleport).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionLimits {
    /// Largest plausible |v| (m/s).
    pub max_speed: f64,
    /// Largest plausible |ω| (rad/s).
    pub max_yaw_rate: f64,
    /// Slack on the dead-reckoned position step beyond `max_speed · dt` (m).
    pub pose_slack: f64,
}

impl Default for MotionLimits {
    /// 30 m/s, 10 rad/s, 0.5 m: far beyond any ground robot, far below a teleport.
    fn default() -> Self {
        Self {
            max_speed: 30.0,
            max_yaw_rate: 10.0,
            pose_slack: 0.5,
        }
    }
}

/// Checks odometry `m` (already [`odometry`]-valid) against `limits`, and its
/// dead-reckoned position against `previous`, the stream's last accepted message from
/// the same publisher: the step may be at most `max_speed · dt + pose_slack`.
///
/// # Errors
/// [`Rejection::Teleport`] naming `v`, `omega` or `pose_step`.
pub fn odometry_motion(
    m: &Odometry,
    previous: Option<&Odometry>,
    limits: &MotionLimits,
) -> Result<(), Rejection> {
    for (field, value, limit) in [
        ("v", m.v, limits.max_speed),
        ("omega", m.omega, limits.max_yaw_rate),
    ] {
        if value.abs() > limit {
            return Err(Rejection::Teleport {
                field,
                value,
                limit,
            });
        }
    }
    if let Some(p) = previous {
        let dt = m.header.stamp_ns.saturating_sub(p.header.stamp_ns) as f64 * 1e-9;
        let step = (m.x - p.x).hypot(m.y - p.y);
        let limit = limits.max_speed * dt + limits.pose_slack;
        if step.is_nan() || step > limit {
            return Err(Rejection::Teleport {
                field: "pose_step",
                value: step,
                limit,
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
    fn stamp_order_rejects_going_back_and_keeps_watermark() {
        let mut s = StampOrder::default();
        assert!(s.accept(10).is_ok());
        assert!(s.accept(10).is_ok());
        assert!(s.accept(9).is_err());
        assert_eq!(s.last(), Some(10));
        assert!(s.accept(11).is_ok());
    }

    fn h(stamp_ns: u64, seq: u64) -> crate::Header {
        crate::Header { stamp_ns, seq }
    }

    #[test]
    fn stream_check_rejects_duplicates_backwards_and_far_jumps() {
        let mut s = StreamCheck::new(100);
        assert_eq!(s.accept(h(10, 0)), Ok(Continuity::Continues));
        assert_eq!(
            s.accept(h(10, 1)),
            Ok(Continuity::Continues),
            "equal stamps"
        );
        assert!(matches!(
            s.accept(h(20, 1)),
            Err(Rejection::Duplicate { seq: 1, .. })
        ));
        assert!(matches!(
            s.accept(h(5, 2)),
            Err(Rejection::StampBackwards { .. })
        ));
        assert!(matches!(
            s.accept(h(111, 2)),
            Err(Rejection::StampJump { .. })
        ));
        assert_eq!(s.last(), Some(10), "rejections leave the state alone");
        assert_eq!(s.accept(h(110, 2)), Ok(Continuity::Continues));
    }

    #[test]
    fn stream_check_takes_a_restarted_publisher_and_a_resync() {
        let mut s = StreamCheck::new(100);
        s.accept(h(10, 7)).unwrap();
        assert!(matches!(
            s.accept(h(10, 0)),
            Err(Rejection::Duplicate { .. })
        ));
        assert_eq!(s.accept(h(20, 0)), Ok(Continuity::Restarted));
        assert_eq!(s.accept(h(30, 1)), Ok(Continuity::Continues));
        assert!(s.accept(h(10_000, 2)).is_err());
        s.resync();
        assert_eq!(s.accept(h(10_000, 2)), Ok(Continuity::Continues));
        assert!(s.accept(h(20_000, 3)).is_err(), "one jump per resync");
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

    #[test]
    fn odometry_motion_rejects_teleports() {
        let limits = MotionLimits::default();
        let at = |t_s: f64, x: f64, v: f64| Odometry {
            header: h((t_s * 1e9) as u64, 0),
            v,
            x,
            ..Default::default()
        };
        let a = at(1.0, 0.0, 1.0);
        assert_eq!(odometry_motion(&a, None, &limits), Ok(()));
        assert_eq!(
            odometry_motion(&at(1.1, 0.1, 1.0), Some(&a), &limits),
            Ok(())
        );
        for (bad, field) in [
            (at(1.1, 50.0, 1.0), "pose_step"),
            (at(1.1, 0.1, 99.0), "v"),
            (at(1.1, f64::NAN, 1.0), "pose_step"),
        ] {
            assert!(
                matches!(odometry_motion(&bad, Some(&a), &limits), Err(Rejection::Teleport { field: f, .. }) if f == field),
                "{field}"
            );
        }
        let spin = Odometry { omega: -11.0, ..a };
        assert!(odometry_motion(&spin, None, &limits).is_err());
    }
}
