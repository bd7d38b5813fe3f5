//! The CARMEN reader's tests: each message type, the mount, stamps, no return, bad lines.

use super::*;
use fastslam_protocol::validate;
use std::io::Write;

/// Writes `bytes` to a fresh file `name` in the temp dir.
fn file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = std::env::temp_dir().join(format!("carmen-{}-{name}", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    path
}

fn gzip(text: &str) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(text.as_bytes()).unwrap();
    gz.finish().unwrap()
}

fn load_bytes(name: &str, bytes: &[u8]) -> Result<CarmenLog> {
    let path = file(name, bytes);
    let log = load(&path);
    std::fs::remove_file(path).unwrap();
    log
}

fn load_text(name: &str, text: &str) -> Result<CarmenLog> {
    load_bytes(name, text.as_bytes())
}

fn join(values: &[f64]) -> String {
    values.iter().map(|v| format!(" {v}")).collect()
}

fn flaser(ranges: &[f64], pose: [f64; 3], t: f64) -> String {
    flaser_at(ranges, pose, pose, t)
}

/// A FLASER line with the laser's pose `laser` and the odometry's `odometry`.
fn flaser_at(ranges: &[f64], laser: [f64; 3], odometry: [f64; 3], t: f64) -> String {
    let (n, r, l, o) = (ranges.len(), join(ranges), join(&laser), join(&odometry));
    format!("FLASER {n}{r}{l}{o} {t} host 0.5\n")
}

fn odom([x, y, th]: [f64; 3], tv: f64, rv: f64, t: f64) -> String {
    format!("ODOM {x} {y} {th} {tv} {rv} 0 {t} host 0.5\n")
}

fn robotlaser(ranges: &[f64], laser: [f64; 3], robot: [f64; 3], t: f64) -> String {
    let (n, r, l, p) = (ranges.len(), join(ranges), join(&laser), join(&robot));
    format!("ROBOTLASER1 0 -1.5 3.0 0.75 40 0.01 0 {n}{r} 2 7 8{l}{p} 0.4 0.1 0 0 0 {t} h 1\n")
}

fn close(a: Pose2, b: [f64; 3]) -> bool {
    (a.x - b[0]).abs() < 1e-12 && (a.y - b[1]).abs() < 1e-12 && (a.theta - b[2]).abs() < 1e-12
}

#[test]
fn flaser_and_odom_lines_become_scans_and_poses() {
    let text = "# a comment\n\n".to_owned()
        + &odom([0.0; 3], 0.3, 0.05, 100.0)
        + &flaser(&[1.0, 2.0, 81.83], [1.0, 2.0, 0.5], 100.25)
        + &odom([1.5, 2.0, 0.5], 0.2, -0.1, 100.5);
    let log = load_text("kinds.clf", &text).unwrap();
    let d = &log.data;
    // Stamp 0 is the first published record's time: the laser line's.
    assert_eq!((d.epoch_s, log.duration_s), (100.25, 0.0));
    let row = |o: &Odometry| (o.header.stamp_ns, o.header.seq, o.x, o.theta, o.v, o.omega);
    let odo: Vec<_> = d.odometry.iter().map(row).collect();
    // The laser line's pose is the odometry; ODOM lines are read, not published.
    assert_eq!(odo, [(0, 0, 1.0, 0.5, 0.0, 0.0)]);
    let (s, h) = (&d.raw_scans[0], &d.raw_scans[0].header);
    assert_eq!((h.header.stamp_ns, h.header.seq), (0, 0));
    assert!((f64::from(h.angle_min) + FRAC_PI_2).abs() < 1e-7);
    assert!((h.angle_max() - FRAC_PI_2).abs() < 1e-6);
    assert_eq!(s.items, [1.0, 2.0, f32::INFINITY]);
    validate::laser_scan(h, &s.items).unwrap();
    assert_eq!(d.laser_mount, Pose2::default());
    assert!(d.truth.is_empty() && d.landmarks.is_empty() && d.scans.is_empty());
    let m = &log.messages;
    assert_eq!((m.flaser, m.robotlaser1, m.odom), (1, 0, 2));
}

#[test]
fn robotlaser1_lines_carry_angles_range_and_mount() {
    let ranges = [3.0, 39.995, 5.0, 0.0, 6.0];
    let text = robotlaser(&ranges, [1.2, 0.1, 0.05], [1.0, 0.0, 0.0], 7.0);
    let log = load_text("robotlaser.log", &text).unwrap();
    let (s, h) = (&log.data.raw_scans[0], log.data.raw_scans[0].header);
    assert_eq!((h.angle_min, h.angle_increment), (-1.5, 0.75));
    assert_eq!((h.range_max, h.ranges), (39.99, 5));
    let r = &s.items;
    assert!(r[1].is_infinite() && r[3].is_nan() && r[4] == 6.0, "{r:?}");
    let o = log.data.odometry[0];
    assert_eq!((o.x, o.v, o.omega), (1.0, 0.4, 0.1));
    assert!(close(log.data.laser_mount, [0.2, 0.1, 0.05]));
    assert_eq!(log.messages.robotlaser1, 1);
    // The mount is robot⁻¹ ⊕ laser: 0.3 m ahead of a robot facing +y, turned 0.1 rad.
    let (laser, robot) = ([2.0, 1.3, FRAC_PI_2 + 0.1], [2.0, 1.0, FRAC_PI_2]);
    let turned = robotlaser(&[1.0; 4], laser, robot, 1.0);
    let same = robotlaser(&[1.0; 4], [5.3, 1.0, 0.1], [5.0, 1.0, 0.0], 2.0);
    let mount = load_text("mount.log", &(turned.clone() + &same))
        .unwrap()
        .data
        .laser_mount;
    assert!(close(mount, [0.3, 0.0, 0.1]), "{mount:?}");
    let aside = robotlaser(&[1.0; 4], [5.0, 1.3, 0.1], [5.0, 1.0, 0.0], 2.0);
    let err = load_text("mount.log", &(turned + &aside)).unwrap_err();
    let err = err.to_string();
    assert!(err.contains("mount.log") && err.contains("varies"), "{err}");
    assert!(err.contains("line 1:") && err.contains("line 2:"), "{err}");
}

#[test]
fn flaser_laser_poses_give_the_mount_or_a_warning() {
    // The laser 0.3 m ahead of a robot facing +y, turned 0.1 rad, on both lines.
    let turned = flaser_at(
        &[1.0; 4],
        [2.0, 1.3, FRAC_PI_2 + 0.1],
        [2.0, 1.0, FRAC_PI_2],
        1.0,
    );
    let same = flaser_at(&[1.0; 4], [5.3, 1.0, 0.1], [5.0, 1.0, 0.0], 2.0);
    let log = load_text("flaser-mount.clf", &(turned.clone() + &same)).unwrap();
    assert!(close(log.data.laser_mount, [0.3, 0.0, 0.1]), "{log:?}");
    assert!(log.warnings.is_empty(), "{:?}", log.warnings);
    let o = log.data.odometry[1];
    assert_eq!(
        (o.x, o.y, o.theta),
        (5.0, 1.0, 0.0),
        "the odometry is the robot's"
    );
    // Laser poses that wander from the odometry are another trajectory: no mount.
    let wandered = flaser_at(&[1.0; 4], [5.0, 1.6, 0.0], [5.0, 1.0, 0.0], 2.0);
    let log = load_text("flaser-corrected.clf", &(turned + &wandered)).unwrap();
    assert_eq!(log.data.laser_mount, Pose2::default());
    let [warning] = &log.warnings[..] else {
        panic!("one warning: {:?}", log.warnings);
    };
    assert!(
        warning.contains("flaser-corrected.clf") && warning.contains("line 2:"),
        "{warning}"
    );
    // Beside ROBOTLASER1 lines at the origin, such FLASER lines are at the origin too.
    let at_origin = robotlaser(&[1.0; 4], [7.0, 1.0, 0.0], [7.0, 1.0, 0.0], 3.0);
    let first = flaser_at(&[1.0; 4], [2.0, 1.3, 0.1], [2.0, 1.0, 0.0], 1.0);
    let log = load_text("flaser-mixed.clf", &(first + &wandered + &at_origin)).unwrap();
    assert_eq!(log.data.laser_mount, Pose2::default());
    assert_eq!(log.warnings.len(), 1, "{:?}", log.warnings);
}

#[test]
fn gzipped_and_plain_logs_read_the_same_whatever_their_name() {
    let text = odom([0.0; 3], 0.0, 0.0, 5.0) + &flaser(&[1.0, 50.0], [0.1, 0.0, 0.0], 5.5);
    let plain = load_text("same.clf.gz", &text).unwrap();
    let gzipped = load_bytes("same.clf", &gzip(&text)).unwrap();
    assert_eq!(plain.data, gzipped.data);
    assert_eq!(plain.messages, gzipped.messages);
}

#[test]
fn a_log_cut_short_keeps_the_lines_before_with_a_warning() {
    // Ranges that differ from line to line, so the compressed stream grows with the lines.
    let text: String = (0..50)
        .map(|i| {
            let ranges: Vec<f64> = (0..90)
                .map(|b| 1.0 + f64::from((i * 7 + b * 13) % 97) / 10.0)
                .collect();
            flaser(&ranges, [0.0; 3], f64::from(i + 1))
        })
        .collect();
    let whole = gzip(&text);
    let log = load_bytes("cut.clf.gz", &whole[..whole.len() / 2]).unwrap();
    let scans = log.data.raw_scans.len();
    assert!((1..50).contains(&scans), "{scans} of 50 scans read");
    let [warning] = &log.warnings[..] else {
        panic!("one warning: {:?}", log.warnings);
    };
    assert!(
        warning.contains("cut.clf.gz") && warning.contains("ends early after line"),
        "{warning}"
    );
    // Cut before its first line ends, nothing is read: refused, naming the file.
    let err = load_bytes("stub.clf.gz", &whole[..30]).unwrap_err();
    assert!(matches!(err, DataError::Io { .. }), "{err}");
    assert!(err.to_string().contains("stub.clf.gz"), "{err}");
    // Cut after comment lines only: refused, saying where it ended.
    // (Two gzip members, the second cut in its header.)
    let comments = gzip(&"# comment\n".repeat(10));
    let early = [comments, whole[..10].to_vec()].concat();
    let err = load_bytes("early.clf.gz", &early).unwrap_err();
    assert!(matches!(err, DataError::Unusable(_)), "{err}");
    let err = err.to_string();
    assert!(
        err.contains("no laser line") && err.contains("ends early after line"),
        "{err}"
    );
}

#[test]
fn other_message_types_are_counted_by_name() {
    let text = "PARAM robot_x 1 host 0\nSYNC 1 host 0\nPARAM a b c\nRAWLASER1 1 2\n".to_owned()
        + &flaser(&[1.0, 2.0], [0.0; 3], 1.0);
    let log = load_text("skip.clf", &text).unwrap();
    let skipped = &log.messages.skipped;
    let count = |name: &str| skipped.get(name).copied();
    assert_eq!(skipped.len(), 3);
    assert_eq!(
        (count("PARAM"), count("RAWLASER1"), count("SYNC")),
        (Some(2), Some(1), Some(1))
    );
    let summary = log.to_string();
    assert!(summary.contains("1 scans") && summary.contains("PARAM 2, RAWLASER1 1"));
}

#[test]
fn bad_lines_are_skipped_and_named_with_file_and_line() {
    let good = flaser(&[1.0, 2.0], [0.0; 3], 1.0);
    let cases = [
        (
            "FLASER 2 1.0 x 0 0 0 0 0 0 1 h 0",
            "field 4 is not a number",
        ),
        (
            "FLASER 3 1 2 0 0 0 0 0 0 1 h 0",
            "expected 14 fields, found 13",
        ),
        ("FLASER 2 1 2 0 0 0 0 nan 0 1 h 0", "odom_y is not finite"),
        ("FLASER -2 1 2", "the beam count is not from 2"),
        ("ODOM 1 2 3 4 5 6 inf h 0", "ipc_timestamp is not finite"),
        ("ODOM 1 2 3", "ODOM: expected 10 fields, found 4"),
        (
            "ROBOTLASER1 0 0 3 0.1 40 0 0 2 1 1 999",
            "the remission count",
        ),
        ("12.5 3 4", "`12.5` is not a message type"),
    ];
    for (bad, expected) in cases {
        let later = flaser(&[3.0, 4.0], [0.0; 3], 2.0);
        let log = load_text("bad.clf", &format!("{good}\n{bad}\n{later}")).unwrap();
        assert_eq!(log.data.raw_scans.len(), 2, "the lines around it are read");
        assert_eq!(log.messages.malformed, 1);
        let [warning] = &log.warnings[..] else {
            panic!("one warning: {:?}", log.warnings);
        };
        assert!(
            warning.contains("1 malformed lines skipped")
                && warning.contains("bad.clf:3:")
                && warning.contains(expected),
            "{warning}"
        );
        assert!(log.to_string().contains("skipped malformed 1"), "{log}");
    }
    // A bad ODOM line is counted as malformed, not as an ODOM line.
    let log = load_text("badodom.clf", &format!("{good}ODOM 1 2\n")).unwrap();
    assert_eq!((log.messages.odom, log.messages.malformed), (0, 1));
    // Five bad lines: the warning names the first three.
    let bad = "FLASER 2 1 2\n".repeat(5);
    let log = load_text("bad5.clf", &format!("{good}{bad}")).unwrap();
    assert_eq!(log.messages.malformed, 5);
    let warning = &log.warnings[0];
    assert!(
        warning.contains("bad5.clf:4:")
            && !warning.contains("bad5.clf:5:")
            && warning.ends_with("; …)"),
        "{warning}"
    );
    let err = load_text("laserless.clf", &odom([0.0; 3], 0.0, 0.0, 1.0)).unwrap_err();
    let err = err.to_string();
    assert!(err.contains("laserless.clf: no laser line"), "{err}");
    // A file with no readable line at all (not a CARMEN log): refused with the reasons.
    let err = load_text("notes.clf", "hello world\nFLASER x\n").unwrap_err();
    assert!(matches!(err, DataError::Unusable(_)), "{err}");
    let err = err.to_string();
    assert!(
        err.contains("no laser line") && err.contains("notes.clf:1: `hello` is not a message type"),
        "{err}"
    );
}

#[test]
fn the_longest_reading_means_no_return_and_bad_readings_are_nan() {
    let ranges = [81.83, 81.825, 81.8, 5.0, 0.0, -1.0, f64::NAN, f64::INFINITY];
    let text = flaser(&ranges, [0.0; 3], 1.0) + &flaser(&[3.0, 4.0], [0.0; 3], 2.0);
    let log = load_text("noreturn.clf", &text).unwrap();
    assert!((log.flaser_max_range_m.unwrap() - 81.83).abs() < 1e-5);
    let (s, last) = (&log.data.raw_scans[0], &log.data.raw_scans[1]);
    assert!((s.header.range_max - 81.82).abs() < 1e-5, "{:?}", s.header);
    assert_eq!(
        last.header.range_max, s.header.range_max,
        "one maximum per log"
    );
    assert_eq!(s.items[..4], [f32::INFINITY, f32::INFINITY, 81.8, 5.0]);
    assert!(s.items[4..].iter().all(|r| r.is_nan()), "{:?}", s.items);
    let none = load_text("noreading.clf", &flaser(&[0.0, f64::NAN], [0.0; 3], 1.0));
    let err = none.unwrap_err().to_string();
    assert!(err.contains("no maximum range"), "{err}");
}

#[test]
fn bursts_of_equal_or_backward_stamps_are_dropped_or_nudged() {
    let (p, q) = ([1.0, 2.0, 0.3], [1.3, 2.0, 0.3]);
    let text = [
        flaser(&[1.0, 2.0], [0.9, 2.0, 0.3], 9.5),
        flaser(&[1.0, 2.0], p, 10.0),
        flaser(&[1.0, 2.0], p, 10.0), // the same pose and beams, same time: dropped
        flaser(&[1.0, 3.0], [1.1, 2.0, 0.3], 10.0), // another pose: nudged
        flaser(&[1.0, 4.0], q, 8.0),  // out of order: sorted first
        odom([5.0, 5.0, 0.0], 0.0, 0.0, 10.0), // read, not published
    ];
    let log = load_text("burst.clf", &text.concat()).unwrap();
    let row = |o: &Odometry| (o.header.stamp_ns, o.x);
    let odo: Vec<_> = log.data.odometry.iter().map(row).collect();
    let s = 500_000_000;
    assert_eq!(
        odo,
        [(0, 1.3), (3 * s, 0.9), (4 * s, 1.0), (4 * s + 1, 1.1)]
    );
    let repairs = |r: StampRepairs| (r.nudged, r.dropped);
    assert_eq!(repairs(log.odometry_repairs), (1, 1));
    let stamp = |r: &RawScan| r.header.header.stamp_ns;
    let scans: Vec<u64> = log.data.raw_scans.iter().map(stamp).collect();
    assert_eq!(scans, [0, 3 * s, 4 * s, 4 * s + 1]);
    assert_eq!(repairs(log.scan_repairs), (1, 1));
    assert_eq!(log.messages.odom, 1);
    let mut check = validate::StreamCheck::new(u64::MAX);
    for o in &log.data.odometry {
        check.accept(o.header).unwrap();
    }
}
