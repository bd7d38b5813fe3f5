//! UTIAS MRCLAM (Leung, Halpern, Barfoot, Liu, IJRR 2011): any data set folder with the
//! released layout, any robot.
//!
//! How the files map onto the stack's messages:
//! - `Robot<r>_Odometry.dat` (time, v, ω): differential-drive odometry,
//!   [`Odometry`](fastslam_protocol::Odometry) `v` and `omega` (steering 0), each record
//!   holding until the next one (see
//!   [`crate::dataset`]); the timing is irregular (≈ 100 Hz with gaps up to a second),
//!   which the service's stamp-order merge handles: it predicts with the interval between
//!   consecutive odometry stamps. Dead reckoning uses the unicycle model.
//! - `Robot<r>_Measurement.dat` (time, barcode, range, bearing): barcodes become subjects
//!   through `Barcodes.dat`; measurements of robots (subjects 1–5) and of barcodes not in
//!   `Barcodes.dat` are dropped (counted in the log). Measurements with the same time
//!   come from one camera frame and form one observations message. The id is the subject
//!   number under known association, −1 under unknown association. The camera sits at
//!   the robot's centre, so range and bearing are already in the vehicle frame.
//! - `Robot<r>_Groundtruth.dat` (Vicon) → `ground_truth`; `Landmark_Groundtruth.dat` →
//!   `truth/landmarks` (id = subject, covariance from the released σx, σy).
//!
//! **Frame.** The service starts its map at the origin, heading +x. The truth (robot and
//! landmarks) is therefore expressed in the frame of the robot's true pose at the first
//! odometry record (where the filter starts), so the client scores without alignment.

use crate::dataset::{self, Association, Clock, DataSet, LaserOutput, ScanGroups, SensorSpec};
use crate::text::{self, DAT_BY_TIME, DAT_TABLE, DataError, Result, Row, Table};
use fastslam_estimation::motion::{Control, MotionModel, Unicycle};
use fastslam_estimation::{Pose2, wrap_angle};
use fastslam_protocol::{MapLandmark, Observation};
use std::collections::HashMap;
use std::path::Path;

/// Subjects that are robots, not landmarks (the data set's convention).
pub const ROBOT_SUBJECTS: std::ops::RangeInclusive<u64> = 1..=5;

/// What to replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Robot number `r` of the `Robot<r>_*.dat` files (1–5 in the released data sets).
    pub robot: u32,
    /// Whether observations carry their landmark's subject number.
    pub association: Association,
    /// Range and field of view published with every observation message.
    pub sensor: SensorSpec,
}

/// Reads robot `options.robot` of the MRCLAM data set in `dir` (files plain or gzipped).
/// Lines that cannot be used (malformed, out of time order, a range ≤ 0, an id that is
/// not a whole number) are skipped, counted and named in one warning per file.
///
/// # Errors
/// [`DataError`] naming the file for a missing or unreadable one, and a data set without
/// odometry or ground truth (with what was skipped); a profile asking for raw scans
/// (MRCLAM has a camera, no laser).
pub fn load(dir: &Path, options: &Options) -> Result<DataSet> {
    text::logged(read(dir, options))
}

/// [`load`], with what it skipped (one line per file) returned rather than logged.
fn read(dir: &Path, options: &Options) -> Result<(DataSet, Vec<String>)> {
    options.sensor.validate()?;
    if options.sensor.publish == LaserOutput::Scans {
        return Err(DataError::Unusable(
            "sensor.publish = \"scans\": MRCLAM has no raw scans (its sensor is a camera); \
             use \"observations\""
                .into(),
        ));
    }
    let r = options.robot;
    let mut barcodes = text::read::<2>(dir, "Barcodes.dat", DAT_TABLE)?;
    let subject_of = subjects(&mut barcodes);
    let mut landmarks = text::read::<5>(dir, "Landmark_Groundtruth.dat", DAT_TABLE)?;
    let odometry = text::read::<3>(dir, &format!("Robot{r}_Odometry.dat"), DAT_BY_TIME)?;
    let mut measurements = text::read::<4>(dir, &format!("Robot{r}_Measurement.dat"), DAT_BY_TIME)?;
    let truth = text::read::<4>(dir, &format!("Robot{r}_Groundtruth.dat"), DAT_BY_TIME)?;
    let (Some(start_s), Some(_)) = (odometry.first_time(), truth.first_time()) else {
        let skipped: String = ([odometry.notice(), truth.notice()].into_iter().flatten())
            .map(|n| format!("; {n}"))
            .collect();
        return Err(DataError::Unusable(format!(
            "robot {r} in {} needs odometry and ground truth{skipped}",
            dir.display()
        )));
    };
    let clock = Clock::starting_at(
        [
            odometry.first_time(),
            measurements.first_time(),
            truth.first_time(),
        ]
        .into_iter()
        .flatten(),
    )?;
    let frame = Frame::at(interpolate(&truth.rows, start_s));

    let records: Vec<(f64, Control)> = (odometry.rows.iter())
        .map(|row| {
            let [t, v, omega] = row.values;
            let steering = 0.0;
            (
                t,
                Control {
                    v,
                    omega,
                    steering,
                    ..Control::ZERO
                },
            )
        })
        .collect();
    let model = MotionModel::Unicycle(Unicycle::default());
    let (scans, dropped) = observations(&mut measurements, &subject_of, options, &clock);
    let (scans, beyond) = options.sensor.scans(scans);
    let data = DataSet {
        odometry: dataset::odometry(&records, &model, &clock),
        scans,
        truth: dataset::truth_track(truth.rows.iter().map(|row| {
            let [t, x, y, theta] = row.values;
            (clock.stamp(t), frame.pose(Pose2::new(x, y, theta)))
        })),
        landmarks: true_map(&mut landmarks, &frame),
        raw_scans: Vec::new(),
        laser_mount: Pose2::default(),
        epoch_s: clock.epoch_s(),
    };
    tracing::info!(
        robot = r,
        epoch_s = clock.epoch_s(),
        odometry = data.odometry.len(),
        scans = data.scans.len(),
        truth = data.truth.len(),
        landmarks = data.landmarks.len(),
        robots_dropped = dropped.robots,
        unknown_barcodes_dropped = dropped.unknown,
        beyond_range_dropped = beyond,
        "MRCLAM data set read"
    );
    let notices = [
        barcodes.notice(),
        landmarks.notice(),
        odometry.notice(),
        measurements.notice(),
        truth.notice(),
    ];
    Ok((data, notices.into_iter().flatten().collect()))
}

/// Barcode → subject from `Barcodes.dat`; a row whose numbers are not whole is skipped.
fn subjects(table: &mut Table<2>) -> HashMap<u64, u64> {
    (table
        .extract(|row| Ok((row.integer(1)?, row.integer(0)?)))
        .into_iter())
    .collect()
}

/// Measurements not published, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Dropped {
    robots: usize,
    unknown: usize,
}

/// Landmark observations grouped by camera frame (equal times), robots and unknown
/// barcodes left out; a range ≤ 0 or a barcode that is not whole is skipped in `table`.
fn observations(
    table: &mut Table<4>,
    subject_of: &HashMap<u64, u64>,
    options: &Options,
    clock: &Clock,
) -> (ScanGroups, Dropped) {
    let sightings = table.extract(|row| {
        let [t, _, range, bearing] = row.values;
        if range <= 0.0 {
            return Err(format!("range must be > 0, got {range}"));
        }
        Ok((clock.stamp(t), row.integer(1)?, range, bearing))
    });
    let mut groups: ScanGroups = Vec::new();
    let mut dropped = Dropped::default();
    for (stamp_ns, barcode, range, bearing) in sightings {
        let subject = match subject_of.get(&barcode) {
            None => {
                dropped.unknown += 1;
                continue;
            }
            Some(s) if ROBOT_SUBJECTS.contains(s) => {
                dropped.robots += 1;
                continue;
            }
            Some(&s) => s,
        };
        let observation = Observation {
            range,
            bearing: wrap_angle(bearing),
            diameter: 0.0,
            id: options.association.wire_id(subject),
        };
        match groups.last_mut() {
            Some((stamp, group)) if *stamp == stamp_ns => group.push(observation),
            _ => groups.push((stamp_ns, vec![observation])),
        }
    }
    (groups, dropped)
}

/// The true landmarks in the start frame, id = subject number; a row whose subject is
/// not whole is skipped in `table`.
fn true_map(table: &mut Table<5>, frame: &Frame) -> Vec<MapLandmark> {
    table.extract(|row| {
        let [_, x, y, sx, sy] = row.values;
        let (px, py) = frame.point(x, y);
        let (cov_xx, cov_xy, cov_yy) = frame.covariance(sx * sx, sy * sy);
        Ok(MapLandmark {
            id: row.integer(0)?,
            x: px,
            y: py,
            cov_xx,
            cov_xy,
            cov_yy,
            observations: 0,
        })
    })
}

/// The Vicon pose at `t_s`, linearly interpolated (heading along the shorter arc); the
/// first or last pose outside the recorded span.
fn interpolate(rows: &[Row<4>], t_s: f64) -> Pose2 {
    let pose = |r: &Row<4>| Pose2::new(r.values[1], r.values[2], r.values[3]);
    let i = rows.partition_point(|r| r.values[0] < t_s);
    match (i.checked_sub(1).and_then(|k| rows.get(k)), rows.get(i)) {
        (Some(a), Some(b)) if b.values[0] > a.values[0] => {
            let f = (t_s - a.values[0]) / (b.values[0] - a.values[0]);
            let (pa, pb) = (pose(a), pose(b));
            Pose2::new(
                pa.x + f * (pb.x - pa.x),
                pa.y + f * (pb.y - pa.y),
                pa.theta + f * wrap_angle(pb.theta - pa.theta),
            )
        }
        (_, Some(r)) | (Some(r), None) => pose(r),
        (None, None) => Pose2::default(),
    }
}

/// The robot's start frame: maps Vicon coordinates to coordinates relative to the pose
/// the filter starts at.
#[derive(Debug, Clone, Copy)]
struct Frame {
    origin: Pose2,
}

impl Frame {
    fn at(origin: Pose2) -> Self {
        Self { origin }
    }

    fn point(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.origin.theta.sin_cos();
        let (dx, dy) = (x - self.origin.x, y - self.origin.y);
        (c * dx + s * dy, -s * dx + c * dy)
    }

    fn pose(&self, p: Pose2) -> Pose2 {
        let (x, y) = self.point(p.x, p.y);
        Pose2::new(x, y, p.theta - self.origin.theta)
    }

    /// `Rᵀ diag(xx, yy) R`: an axis-aligned covariance seen from the start frame.
    fn covariance(&self, xx: f64, yy: f64) -> (f64, f64, f64) {
        let (s, c) = self.origin.theta.sin_cos();
        (
            c * c * xx + s * s * yy,
            -s * c * xx + s * c * yy,
            s * s * xx + c * c * yy,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::text::tests::folder_with;

    const BARCODES: &str = "# Subject # Barcode #\n1 5\n2 14\n6 63\n7 81\n";
    const LANDMARKS: &str = "# Subject x y sx sy\n6 1.0 3.0 0.1 0.2\n7 0.0 4.0 0.1 0.1\n";
    // The robot stands at (1, 1) facing +y; landmark 6 is 2 m ahead of it.
    const TRUTH: &str = "100.0 1.0 1.0 1.5707963267948966\n101.0 1.0 1.0 1.5707963267948966\n103.0 1.0 2.0 1.5707963267948966\n";
    const ODOMETRY: &str = "100.5 0.0 0.0\n101.0 0.5 0.0\n103.0 0.0 0.0\n";
    const MEASUREMENTS: &str =
        "100.6 63 2.0 0.0\n100.6 14 1.0 0.1\n100.6 99 1.0 0.1\n102.0 81 2.5 0.3\n";

    fn options(association: Association) -> Options {
        Options {
            robot: 1,
            association,
            sensor: SensorSpec {
                max_range_m: 5.0,
                field_of_view_deg: 70.0,
                publish: LaserOutput::Observations,
            },
        }
    }

    fn folder(test: &str, measurements: &str) -> std::path::PathBuf {
        folder_with(
            test,
            &[
                ("Barcodes.dat", BARCODES),
                ("Landmark_Groundtruth.dat", LANDMARKS),
                ("Robot1_Groundtruth.dat.gz", TRUTH),
                ("Robot1_Odometry.dat", ODOMETRY),
                ("Robot1_Measurement.dat", measurements),
            ],
        )
    }

    #[test]
    fn a_profile_asking_for_raw_scans_is_refused_with_its_reason() {
        let dir = folder("mrclam-scans", MEASUREMENTS);
        let mut options = options(Association::Known);
        options.sensor.publish = LaserOutput::Scans;
        let err = load(&dir, &options).unwrap_err().to_string();
        assert!(err.contains("MRCLAM has no raw scans"), "{err}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn barcodes_become_subjects_and_robots_are_dropped() {
        let dir = folder("mrclam-ids", MEASUREMENTS);
        let data = load(&dir, &options(Association::Known)).unwrap();
        assert_eq!(data.scans.len(), 2, "one message per camera frame");
        let ids: Vec<Vec<i64>> = (data.scans.iter())
            .map(|s| s.items.iter().map(|o| o.id).collect())
            .collect();
        assert_eq!(
            ids,
            vec![vec![6], vec![7]],
            "robot 2 and barcode 99 dropped"
        );
        assert_eq!(data.scans[0].header.header.stamp_ns, 600_000_000);
        let unknown = load(&dir, &options(Association::Unknown)).unwrap();
        assert!(
            unknown
                .scans
                .iter()
                .flat_map(|s| &s.items)
                .all(|o| o.id == -1)
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn truth_and_landmarks_are_in_the_frame_where_the_filter_starts() {
        let dir = folder("mrclam-frame", MEASUREMENTS);
        let data = load(&dir, &options(Association::Known)).unwrap();
        // Epoch 100 s (truth starts first); the filter starts at the first odometry, 100.5 s.
        assert_eq!(data.truth[0].header.stamp_ns, 0);
        assert_eq!(data.odometry[0].header.stamp_ns, 500_000_000);
        let (t, l) = (&data.truth[2], &data.landmarks[0]);
        assert!((t.x - 1.0).abs() < 1e-12 && t.y.abs() < 1e-12 && t.theta.abs() < 1e-12);
        assert!(
            (l.x - 2.0).abs() < 1e-12 && l.y.abs() < 1e-12,
            "landmark 6 2 m ahead"
        );
        assert_eq!(l.id, 6);
        // σx = 0.1 along Vicon x = the start frame's −y.
        assert!((l.cov_yy - 0.01).abs() < 1e-12 && (l.cov_xx - 0.04).abs() < 1e-12);
        // The observation of landmark 6 agrees with its true position in that frame.
        let o = data.scans[0].items[0];
        assert!((o.range - l.x.hypot(l.y)).abs() < 1e-12 && o.bearing.abs() < 1e-12);
        // Dead reckoning: 0.5 m/s from 101 s to 103 s along +x (the start heading).
        let last = data.odometry.last().unwrap();
        assert!((last.x - 1.0).abs() < 1e-12 && last.y.abs() < 1e-12);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn bad_measurements_are_skipped_and_named_with_file_and_line() {
        for (bad, expected) in [
            ("100.7 63 NaN 0.0\n", "Robot1_Measurement.dat:2: column 3"),
            (
                "100.7 63 -2.0 0.0\n",
                "Robot1_Measurement.dat:2: range must be > 0",
            ),
            (
                "100.7 6.5 2.0 0.0\n",
                "Robot1_Measurement.dat:2: column 2 must be a whole",
            ),
            (
                "100.5 63 2.0 0.0\n",
                "Robot1_Measurement.dat:2: time 100.5 goes back",
            ),
        ] {
            let dir = folder(
                "mrclam-bad",
                &format!("100.6 63 2.0 0.0\n{bad}102.0 81 2.5 0.3\n"),
            );
            let (data, notices) = read(&dir, &options(Association::Known)).unwrap();
            let ids: Vec<i64> = data
                .scans
                .iter()
                .flat_map(|s| &s.items)
                .map(|o| o.id)
                .collect();
            assert_eq!(ids, [6, 7], "the lines around the bad one are replayed");
            assert_eq!(notices.len(), 1, "{notices:?}");
            assert!(
                notices[0].contains("1 lines skipped") && notices[0].contains(expected),
                "{notices:?}"
            );
            std::fs::remove_dir_all(dir).unwrap();
        }
        let dir = folder("mrclam-clean", MEASUREMENTS);
        assert!(
            read(&dir, &options(Association::Known))
                .unwrap()
                .1
                .is_empty()
        );
        std::fs::write(dir.join("Robot1_Odometry.dat"), "x y z\n").unwrap();
        let err = load(&dir, &options(Association::Known))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("needs odometry and ground truth")
                && err.contains("Robot1_Odometry.dat: 1 lines skipped"),
            "{err}"
        );
        std::fs::remove_dir_all(dir).unwrap();
        let dir = folder("mrclam-robot", MEASUREMENTS);
        let robot2 = Options {
            robot: 2,
            ..options(Association::Known)
        };
        let err = load(&dir, &robot2).unwrap_err().to_string();
        assert!(err.contains("Robot2_Odometry.dat"), "{err}");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
