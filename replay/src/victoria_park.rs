//! Victoria Park (ACFR; Guivant & Nebot, IEEE T-RA 2001): a car with a SICK laser driving
//! among trees, with intermittent GPS.
//!
//! How the files map onto the stack's messages:
//! - **Pose reference = the laser.** The filter's pose is the laser's position and
//!   heading (the state of Guivant & Nebot's own model), so observations and raw scans
//!   need no mounting offset. The laser sits at (a, b) = (3.78, 0.50) m from the rear
//!   axle centre; on a car-like vehicle with wheelbase L that point moves *exactly* as
//!   the service's bicycle model (Bailey's: `ẋ = v cos(θ+γ)`, `θ̇ = v sin γ / B`) with
//!   wheelbase `B = a` and the *virtual* speed and steering
//!   `v = v_c·√((1 − b·tanγ/L)² + (a·tanγ/L)²)`, `γ' = atan2(a·tanγ, L − b·tanγ)`, where
//!   `v_c = v_e / (1 − tanγ·H/L)` is the centre-line speed from the encoder speed `v_e`
//!   at the rear left wheel. (Check: the laser's velocity in the vehicle frame is
//!   `(v_c − θ̇ b, θ̇ a)` with `θ̇ = v_c tanγ / L`; the bicycle gives `θ̇ = v sin γ' / a`.)
//!   So `odometry.csv` becomes [`Odometry`](fastslam_protocol::Odometry) with `v` = that
//!   speed, `steering` = γ' and `omega` = θ̇, and the profile runs the bicycle model with
//!   `wheelbase = 3.78`.
//! - `tree_observations.csv`: each laser scan's tree detections. The bearing runs 0…π
//!   across the scan from the laser's right, so the vehicle-frame bearing is `β − π/2`;
//!   the diameter goes into [`Observation::diameter`]; ids are −1 (trees carry no
//!   identity: unknown association only). Every scan of `scan_times.csv` is published,
//!   also those without trees (they are negative evidence).
//! - `gps.csv` → `ground_truth`, sparse (5 Hz, with gaps of up to a minute under the
//!   trees), in the GPS's local frame. GPS measures no heading: `theta` is the course
//!   over ground between the neighbouring fixes ([`course_over_ground`]), an approximation
//!   of the heading. The estimate starts at the origin, so it must be aligned with the
//!   GPS frame (SE(2)) before it is scored, and scored at the GPS times — the client's
//!   job. Where the GPS antenna sits on the car is not documented: errors of the order of
//!   a metre are the lever arm, not the filter.
//! - There are no true tree positions: `truth/landmarks` is published empty.
//!
//! - **Raw scans** instead of the tree detections, with `[sensor] publish = "scans"`
//!   (profile `victoria-park-scans`): `laser_raw_361beams.txt` holds one scan per line,
//!   its time then 361 ranges over 0…180° from the laser's right; its clock runs
//!   [`RAW_LASER_CLOCK_OFFSET_S`] behind the CSV files' (its first scan is
//!   `scan_times.csv`'s first). Each becomes a
//!   [`LaserScanHeader`](fastslam_protocol::LaserScanHeader) with `angle_min` −π/2 and
//!   `angle_increment` π/360, no mounting offset (the pose is the laser's); a range from
//!   [`NO_RETURN_M`] on is the laser's "no return" and goes out as +∞ (REP-117).

use crate::dataset::{self, Clock, DataSet, LaserOutput, RawScan, ScanGroups, SensorSpec};
use crate::text::{self, CSV_BY_TIME, DAT_BY_TIME, DataError, Result, Row, Table};
use fastslam_estimation::Pose2;
use fastslam_estimation::motion::{Bicycle, Control, MotionModel};
use fastslam_protocol::{Header, LaserScanHeader, Observation};
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// Wheelbase L (m), from the data set's documentation.
pub const WHEELBASE_M: f64 = 2.83;
/// Distance H from the centre line to the encoder wheel (rear left) (m).
pub const HALF_TRACK_M: f64 = 0.76;
/// Laser position ahead of the rear axle, a (m): the wheelbase of the laser's bicycle.
pub const LASER_AHEAD_M: f64 = 3.78;
/// Laser position left of the centre line, b (m).
pub const LASER_LEFT_M: f64 = 0.50;

/// The raw scans' file: a time, then [`BEAMS`] ranges per line.
pub const RAW_SCANS_FILE: &str = "laser_raw_361beams.txt";
/// Beams per raw scan: 0…180° in 0.5° steps.
pub const BEAMS: usize = 361;
/// What the raw scans' clock runs behind the CSV files' (s): a raw scan's time plus this
/// is its time in `scan_times.csv`.
pub const RAW_LASER_CLOCK_OFFSET_S: f64 = 20.967;
/// A raw range from this on is the laser's "no return" (the release writes 81.91 m, a
/// few 81.8x m) (m).
pub const NO_RETURN_M: f32 = 81.0;

/// Fixes farther apart in time than this are not differenced for a course (s).
pub const COURSE_MAX_GAP_S: f64 = 2.0;
/// Fixes closer than this are not differenced for a course: GPS noise would dominate (m).
pub const COURSE_MIN_BASELINE_M: f64 = 0.5;

/// The controls of the service's bicycle model that move the laser as the car moves
/// with encoder speed `v_e` (m/s) and steering `gamma` (rad): see the module doc.
pub fn laser_controls(v_e: f64, gamma: f64) -> Control {
    let tan = gamma.tan();
    let v_c = v_e / (1.0 - tan * HALF_TRACK_M / WHEELBASE_M);
    let forward = 1.0 - LASER_LEFT_M * tan / WHEELBASE_M;
    let sideways = LASER_AHEAD_M * tan / WHEELBASE_M;
    Control {
        v: v_c * forward.hypot(sideways),
        omega: v_c * tan / WHEELBASE_M,
        steering: sideways.atan2(forward),
        ..Control::ZERO
    }
}

/// The service's motion model for this data set, noise-free (dead reckoning).
pub fn laser_bicycle() -> MotionModel {
    MotionModel::Bicycle(Bicycle {
        wheelbase: LASER_AHEAD_M,
        sigma_v: 0.0,
        sigma_steering: 0.0,
    })
}

/// Reads the Victoria Park folder `dir` (files plain or gzipped): with the tree
/// detections (observations beyond `sensor.max_range_m` dropped), or with the raw scans
/// when `sensor.publish` asks for them. Lines that cannot be used (malformed, out of time
/// order, a tree of a scan not in `scan_times.csv` or at another time, a range ≤ 0, a raw
/// scan without 361 ranges ≥ 0) are skipped, counted and named in one warning per file.
///
/// # Errors
/// [`DataError`] naming the file for a missing or unreadable one, and a data set without
/// odometry (with what was skipped).
pub fn load(dir: &Path, sensor: &SensorSpec) -> Result<DataSet> {
    text::logged(read(dir, sensor))
}

/// [`load`], with what it skipped (one line per file) returned rather than logged.
fn read(dir: &Path, sensor: &SensorSpec) -> Result<(DataSet, Vec<String>)> {
    sensor.validate()?;
    let odometry = text::read::<3>(dir, "odometry.csv", CSV_BY_TIME)?;
    let gps = text::read::<3>(dir, "gps.csv", CSV_BY_TIME)?;
    if odometry.rows.is_empty() {
        let skipped: String = odometry
            .notice()
            .map(|n| format!("; {n}"))
            .unwrap_or_default();
        return Err(DataError::Unusable(format!(
            "{} has no odometry{skipped}",
            odometry.path.display()
        )));
    }
    let mut notices = vec![odometry.notice(), gps.notice()];
    let laser = match sensor.publish {
        LaserOutput::Observations => Laser::Trees {
            scan_times: text::read::<2>(dir, "scan_times.csv", CSV_BY_TIME)?,
            trees: text::read::<5>(dir, "tree_observations.csv", CSV_BY_TIME)?,
        },
        LaserOutput::Scans => {
            let (raw, notice) = read_raw_scans(dir)?;
            notices.push(notice);
            Laser::Raw(raw)
        }
    };
    let clock = Clock::starting_at(
        [odometry.first_time(), gps.first_time(), laser.first_time()]
            .into_iter()
            .flatten(),
    )?;
    let records: Vec<(f64, Control)> = (odometry.rows.iter())
        .map(|row| {
            let [t, v_e, gamma] = row.values;
            (t, laser_controls(v_e, gamma))
        })
        .collect();
    let ((scans, beyond), raw_scans) = match laser {
        Laser::Trees {
            mut scan_times,
            mut trees,
        } => {
            let groups = self::scans(&mut scan_times, &mut trees, &clock);
            notices.extend([scan_times.notice(), trees.notice()]);
            (sensor.scans(groups), Vec::new())
        }
        Laser::Raw(raw) => ((Vec::new(), 0), raw_messages(&raw, &clock)),
    };
    let fixes: Vec<[f64; 3]> = gps.rows.iter().map(|r| r.values).collect();
    let truth = dataset::truth_track(
        (fixes.iter().zip(course_over_ground(&fixes)))
            .map(|([t, x, y], theta)| (clock.stamp(*t), Pose2::new(*x, *y, theta))),
    );
    let data = DataSet {
        odometry: dataset::odometry(&records, &laser_bicycle(), &clock),
        scans,
        raw_scans,
        truth,
        landmarks: Vec::new(),
        laser_mount: Pose2::default(),
        epoch_s: clock.epoch_s(),
    };
    tracing::info!(
        epoch_s = clock.epoch_s(),
        odometry = data.odometry.len(),
        scans = data.scans.len(),
        raw_scans = data.raw_scans.len(),
        gps = data.truth.len(),
        beyond_range_dropped = beyond,
        "Victoria Park data set read"
    );
    Ok((data, notices.into_iter().flatten().collect()))
}

/// The laser's files a replay reads.
enum Laser {
    /// Scan times and the tree detections per scan.
    Trees {
        scan_times: Table<2>,
        trees: Table<5>,
    },
    /// The raw scans.
    Raw(Vec<RawLaserScan>),
}

impl Laser {
    /// The first scan's time on the CSV files' clock (s).
    fn first_time(&self) -> Option<f64> {
        match self {
            Self::Trees { scan_times, .. } => scan_times.rows.first().map(|r| r.values[1]),
            Self::Raw(raw) => raw.first().map(|s| s.t_s),
        }
    }
}

/// One line of the raw scans' file.
#[derive(Debug, Clone, PartialEq)]
pub struct RawLaserScan {
    /// Time on the CSV files' clock (s): the file's own plus [`RAW_LASER_CLOCK_OFFSET_S`].
    pub t_s: f64,
    /// The [`BEAMS`] ranges from the laser's right to its left (m), as released (81.91 =
    /// no return).
    pub ranges: Vec<f32>,
}

/// Reads [`RAW_SCANS_FILE`] (plain or gzipped) in `dir`, with what it skipped in one
/// line naming the file: a line without a time and 361 finite ranges ≥ 0, or a time going
/// backwards.
///
/// # Errors
/// [`DataError`] naming the file when it is missing or cannot be read at all.
pub fn read_raw_scans(dir: &Path) -> Result<(Vec<RawLaserScan>, Option<String>)> {
    let mut table = text::read::<{ BEAMS + 1 }>(dir, RAW_SCANS_FILE, DAT_BY_TIME)?;
    let scans = table.extract(|row| {
        if row.values[1..].iter().any(|r| *r < 0.0) {
            return Err("ranges must be ≥ 0".into());
        }
        Ok(RawLaserScan {
            t_s: row.values[0] + RAW_LASER_CLOCK_OFFSET_S,
            ranges: row.values[1..].iter().map(|&r| r as f32).collect(),
        })
    });
    Ok((scans, table.notice()))
}

/// The raw scans as messages: the laser's layout (see the module doc), no-return ranges
/// as +∞, `scan_time` the file's mean period.
fn raw_messages(raw: &[RawLaserScan], clock: &Clock) -> Vec<RawScan> {
    let period_s = match (raw.first(), raw.last()) {
        (Some(first), Some(last)) if raw.len() > 1 => {
            (last.t_s - first.t_s) / (raw.len() - 1) as f64
        }
        _ => 0.0,
    };
    (raw.iter().enumerate())
        .map(|(seq, scan)| RawScan {
            header: LaserScanHeader {
                header: Header {
                    stamp_ns: clock.stamp(scan.t_s),
                    seq: seq as u64,
                },
                angle_min: -FRAC_PI_2 as f32,
                angle_increment: (PI / (BEAMS - 1) as f64) as f32,
                time_increment: 0.0,
                scan_time: period_s as f32,
                range_min: 0.0,
                range_max: NO_RETURN_M,
                ranges: BEAMS as u32,
                intensities: 0,
            },
            items: (scan.ranges.iter())
                .map(|&r| if r >= NO_RETURN_M { f32::INFINITY } else { r })
                .collect(),
        })
        .collect()
}

/// Every scan of `scan_times` with its trees, in the vehicle (= laser) frame. A scan
/// time going backwards or an index that is not whole is skipped in `scan_times`; a tree
/// of a scan not there (or at another time), with a range ≤ 0 or a diameter < 0, in
/// `trees`.
fn scans(scan_times: &mut Table<2>, trees: &mut Table<5>, clock: &Clock) -> ScanGroups {
    let mut last = f64::NEG_INFINITY;
    let times = scan_times.extract(|row| {
        let t = row.values[1];
        if t < last {
            return Err(format!("scan time {t} goes backwards"));
        }
        let scan = row.integer(0)?;
        last = t;
        Ok((scan, t))
    });
    let mut index = HashMap::with_capacity(times.len());
    let mut out: Vec<(f64, Vec<Observation>)> = Vec::with_capacity(times.len());
    for (scan, t) in times {
        index.insert(scan, out.len());
        out.push((t, Vec::new()));
    }
    for (k, observation) in trees.extract(|row| tree(row, &index, &out)) {
        out[k].1.push(observation);
    }
    out.into_iter()
        .map(|(t, observations)| (clock.stamp(t), observations))
        .collect()
}

/// The tree of `row` and the index in `scans` of the scan it belongs to, or why the row
/// holds none.
fn tree(
    row: &Row<5>,
    index: &HashMap<u64, usize>,
    scans: &[(f64, Vec<Observation>)],
) -> std::result::Result<(usize, Observation), String> {
    let [t, _, range, bearing, diameter] = row.values;
    let scan = row.integer(1)?;
    let Some(&k) = index.get(&scan) else {
        return Err(format!("scan {scan} is not in scan_times"));
    };
    if (scans[k].0 - t).abs() > 1e-3 {
        return Err(format!(
            "time {t} differs from scan {scan}'s time {}",
            scans[k].0
        ));
    }
    if range <= 0.0 || diameter < 0.0 {
        return Err("range must be > 0 and diameter ≥ 0".into());
    }
    let observation = Observation {
        range,
        bearing: bearing - FRAC_PI_2,
        diameter,
        id: -1,
    };
    Ok((k, observation))
}

/// The direction of travel at each fix `[t, x, y]`: from the fix before to the fix
/// after (each at most [`COURSE_MAX_GAP_S`] away, at least [`COURSE_MIN_BASELINE_M`]
/// apart), else the nearest course known before (or, at the start, after); 0 when the
/// vehicle never moves.
pub fn course_over_ground(fixes: &[[f64; 3]]) -> Vec<f64> {
    let near = |i: usize, j: usize| (fixes[i][0] - fixes[j][0]).abs() <= COURSE_MAX_GAP_S;
    let measured: Vec<Option<f64>> = (0..fixes.len())
        .map(|i| {
            let before = if i > 0 && near(i, i - 1) { i - 1 } else { i };
            let after = if i + 1 < fixes.len() && near(i, i + 1) {
                i + 1
            } else {
                i
            };
            let (dx, dy) = (
                fixes[after][1] - fixes[before][1],
                fixes[after][2] - fixes[before][2],
            );
            (dx.hypot(dy) >= COURSE_MIN_BASELINE_M).then(|| dy.atan2(dx))
        })
        .collect();
    let first = measured.iter().flatten().next().copied().unwrap_or(0.0);
    let mut last = first;
    measured
        .into_iter()
        .map(|c| {
            last = c.unwrap_or(last);
            last
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::text::tests::folder_with;

    #[test]
    fn driving_straight_the_laser_moves_at_the_centre_line_speed() {
        let u = laser_controls(5.0, 0.0);
        assert!((u.v - 5.0).abs() < 1e-12 && u.steering == 0.0 && u.omega == 0.0);
    }

    #[test]
    fn the_laser_bicycle_moves_the_laser_like_the_car_does() {
        // Integrate the car (rear axle centre, centre-line speed) and the laser's bicycle
        // for 4 s of a left turn; the laser must stay at (a, b) in the car's frame.
        let (v_e, gamma, dt) = (4.0, 0.3_f64, 1e-4);
        let v_c = v_e / (1.0 - gamma.tan() * HALF_TRACK_M / WHEELBASE_M);
        let (mut x, mut y, mut th) = (0.0_f64, 0.0_f64, 0.0_f64);
        let model = laser_bicycle();
        let u = laser_controls(v_e, gamma);
        let mut laser = Pose2::new(LASER_AHEAD_M, LASER_LEFT_M, 0.0);
        for _ in 0..40_000 {
            x += v_c * dt * th.cos();
            y += v_c * dt * th.sin();
            th += v_c * dt * gamma.tan() / WHEELBASE_M;
            laser = model.propagate(&laser, &u, dt);
        }
        let (s, c) = th.sin_cos();
        let expected = (
            x + c * LASER_AHEAD_M - s * LASER_LEFT_M,
            y + s * LASER_AHEAD_M + c * LASER_LEFT_M,
        );
        let miss = (laser.x - expected.0).hypot(laser.y - expected.1);
        assert!(miss < 1e-2, "laser {laser:?} vs {expected:?}: {miss} m");
        assert!(fastslam_estimation::wrap_angle(laser.theta - th).abs() < 1e-3);
        assert!((u.omega - v_c * gamma.tan() / WHEELBASE_M).abs() < 1e-12);
    }

    #[test]
    fn the_course_follows_the_track_and_holds_when_standing() {
        let fixes = [
            [0.0, 0.0, 0.0],
            [0.2, 0.0, 0.1],
            [0.4, 0.0, 1.0],
            [0.6, 1.0, 1.0],
            [0.8, 1.0, 1.1],
            [9.0, 1.0, 1.1],
        ];
        let c = course_over_ground(&fixes);
        assert!((c[0] - FRAC_PI_2).abs() < 1e-12, "backfilled: {c:?}");
        assert!((c[2] - 0.9_f64.atan2(1.0)).abs() < 1e-12, "{c:?}");
        assert!(
            (c[5] - c[4]).abs() < 1e-12,
            "a lone fix keeps the course: {c:?}"
        );
        assert_eq!(course_over_ground(&[[0.0, 1.0, 1.0]]), vec![0.0]);
    }

    const ODOMETRY: &str = "t_s,speed_mps,steering_rad\n1.0,0,0\n1.5,2.0,0\n2.0,2.0,0\n";
    const SCANS: &str = "scan_idx,t_s\n0,1.2\n1,1.8\n";
    const GPS: &str = "t_s,x_m,y_m\n0.9,5,5\n1.9,6,5\n";

    fn folder(test: &str, trees: &str) -> std::path::PathBuf {
        folder_with(
            test,
            &[
                ("odometry.csv.gz", ODOMETRY),
                ("scan_times.csv", SCANS),
                ("tree_observations.csv", trees),
                ("gps.csv", GPS),
            ],
        )
    }

    #[test]
    fn trees_are_published_per_scan_in_the_vehicle_frame() {
        let trees = "t_s,scan_idx,range_m,bearing_rad_0_to_pi,diameter_m\n1.2,0,10,1.5707963267948966,0.3\n1.2,0,50,0.5,0.2\n";
        let dir = folder("vp-trees", trees);
        let sensor = SensorSpec {
            max_range_m: 30.0,
            field_of_view_deg: 180.0,
            publish: LaserOutput::Observations,
        };
        let data = load(&dir, &sensor).unwrap();
        assert_eq!(
            data.scans.len(),
            2,
            "the scan without trees is published too"
        );
        let s = &data.scans[0];
        assert_eq!(s.items.len(), 1, "the tree at 50 m is beyond range");
        assert!(s.items[0].bearing.abs() < 1e-12, "π/2 = straight ahead");
        assert_eq!((s.items[0].diameter, s.items[0].id), (0.3, -1));
        assert_eq!(
            s.header.header.stamp_ns, 300_000_000,
            "epoch = first GPS fix"
        );
        assert_eq!((data.truth.len(), data.landmarks.len()), (2, 0));
        assert!(data.truth[0].theta.abs() < 1e-12, "course +x");
        let last = data.odometry.last().unwrap();
        assert!((last.x - 1.0).abs() < 1e-12, "2 m/s over 0.5 s: {last:?}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn trees_of_unknown_scans_or_bad_values_are_skipped_and_named_with_file_and_line() {
        let head = "t_s,scan_idx,range_m,bearing_rad_0_to_pi,diameter_m\n1.2,0,10,1,0.3\n";
        let sensor = SensorSpec {
            max_range_m: 30.0,
            field_of_view_deg: 180.0,
            publish: LaserOutput::Observations,
        };
        for (bad, expected) in [
            (
                "1.2,7,10,1,0.3\n",
                "tree_observations.csv:3: scan 7 is not in scan_times",
            ),
            ("1.3,1,10,1,0.3\n", ":3: time 1.3 differs"),
            ("1.2,0,10,nan,0.3\n", ":3: column 4 is not a finite number"),
            ("1.2,0,-1,1,0.3\n", ":3: range must be > 0"),
            ("1.1,0,10,1,0.3\n", ":3: time 1.1 goes back before 1.2"),
        ] {
            let dir = folder("vp-bad", &format!("{head}{bad}1.8,1,10,1,0.3\n"));
            let (data, notices) = read(&dir, &sensor).unwrap();
            let trees: Vec<usize> = data.scans.iter().map(|s| s.items.len()).collect();
            assert_eq!(trees, [1, 1], "the trees around the bad line are published");
            assert_eq!(notices.len(), 1, "{notices:?}");
            assert!(
                notices[0].contains("1 lines skipped") && notices[0].contains(expected),
                "{notices:?}"
            );
            std::fs::remove_dir_all(dir).unwrap();
        }
        let dir = folder("vp-no-odometry", head);
        std::fs::remove_file(dir.join("odometry.csv.gz")).unwrap();
        std::fs::write(dir.join("odometry.csv"), "t,v,s\n1,2\n").unwrap();
        let err = load(&dir, &sensor).unwrap_err().to_string();
        assert!(
            err.contains("has no odometry") && err.contains("expected 3 columns"),
            "{err}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    /// A raw scans' file: one line per `(time on its own clock, range of every beam)`.
    fn raw_lines(lines: &[(f64, Vec<f64>)]) -> String {
        (lines.iter())
            .map(|(t, ranges)| {
                let ranges: Vec<String> = ranges.iter().map(f64::to_string).collect();
                format!("{t} {}\n", ranges.join(" "))
            })
            .collect()
    }

    #[test]
    fn raw_scans_are_published_on_the_csv_clock_with_no_return_as_infinity() {
        let mut ranges = vec![5.0; BEAMS];
        (ranges[0], ranges[1], ranges[180]) = (81.91, 81.87, 12.5);
        let file = raw_lines(&[
            (1.2 - RAW_LASER_CLOCK_OFFSET_S, ranges.clone()),
            (1.8 - RAW_LASER_CLOCK_OFFSET_S, ranges),
        ]);
        let dir = folder_with(
            "vp-raw",
            &[
                ("odometry.csv", ODOMETRY),
                ("gps.csv", GPS),
                ("laser_raw_361beams.txt.gz", &file),
            ],
        );
        let sensor = SensorSpec {
            max_range_m: 30.0,
            field_of_view_deg: 180.0,
            publish: LaserOutput::Scans,
        };
        let data = load(&dir, &sensor).unwrap();
        assert!(data.scans.is_empty(), "no tree detections with raw scans");
        assert_eq!(data.raw_scans.len(), 2);
        let s = &data.raw_scans[1];
        // The epoch is the first GPS fix (0.9 s); the scan is at 1.8 s on the CSV clock.
        assert_eq!(
            (s.header.header.stamp_ns, s.header.header.seq),
            (900_000_000, 1)
        );
        assert_eq!((s.header.ranges, s.header.intensities), (361, 0));
        assert!(
            (f64::from(s.header.angle_min) + FRAC_PI_2).abs() < 1e-6,
            "from the right"
        );
        assert!(
            (s.header.angle_max() - FRAC_PI_2).abs() < 1e-5,
            "to the left"
        );
        assert!(
            (f64::from(s.header.scan_time) - 0.6).abs() < 1e-6,
            "the mean period"
        );
        assert_eq!(
            &s.items[..2],
            &[f32::INFINITY; 2],
            "81.91 and 81.87: no return"
        );
        assert_eq!((s.items[2], s.items[180]), (5.0, 12.5));
        fastslam_protocol::validate::laser_scan(&s.header, &s.items).unwrap();
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn raw_scans_with_a_missing_beam_or_a_negative_range_are_skipped_and_named() {
        let sensor = SensorSpec {
            max_range_m: 30.0,
            field_of_view_deg: 180.0,
            publish: LaserOutput::Scans,
        };
        let good = |t| (t, vec![5.0; BEAMS]);
        let mut negative = vec![5.0; BEAMS];
        negative[7] = -1.0;
        for (bad, expected) in [
            (
                (0.7, vec![5.0; BEAMS - 1]),
                ":2: expected 362 columns, found 361",
            ),
            ((0.7, negative), ":2: ranges must be ≥ 0"),
        ] {
            let file = raw_lines(&[good(0.5), bad, good(0.9)]);
            let dir = folder_with(
                "vp-raw-bad",
                &[
                    ("odometry.csv", ODOMETRY),
                    ("gps.csv", GPS),
                    ("laser_raw_361beams.txt", &file),
                ],
            );
            let (data, notices) = read(&dir, &sensor).unwrap();
            assert_eq!(data.raw_scans.len(), 2, "the good scans are kept");
            assert_eq!(notices.len(), 1, "{notices:?}");
            assert!(
                notices[0].contains("laser_raw_361beams.txt") && notices[0].contains(expected),
                "{notices:?}"
            );
            std::fs::remove_dir_all(dir).unwrap();
        }
    }
}
