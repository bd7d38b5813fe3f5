//! The bag reader on bags written by an independent implementation: the pure-Python
//! `rosbags` library (`tests/python/write_bag.py`), in MCAP and SQLite storage, with
//! zstd chunk, file and message compression, tf-only odometry through an intermediate
//! frame, an off-centre laser, two scan topics, an undecodable message, multi-echo scans
//! and point clouds; and ROS 1 bags converted from them by `rosbags-convert`
//! (uncompressed, bz2 and lz4 chunks).
//!
//! Python comes from a virtual environment under the cargo target directory, built on
//! first use ([`common::python_venv`]); without Python, venv or PyPI the test fails
//! saying which step failed.

mod common;

use common::{rosbags_bin, rosbags_convert, run_ok};
use fastslam_replay::rosbag::{self, OdometrySource, TopicChoice};
use fastslam_replay::text::DataError;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The ROS 1 bags converted from the `mcap` bag, by chunk compression: `ros1_none.bag`…
const ROS1_COMPRESSIONS: [&str; 3] = ["none", "bz2", "lz4"];

/// The bags `write_bag.py` wrote (once per test run) and what they hold; beside them the
/// ROS 1 bags `rosbags-convert` made of the `mcap` bag (each holding what it holds) and of
/// `long_file_zstd` (`long.bag`, lz4 chunks), of `multi_echo` and of `cloud`
/// (`multi_echo.bag`, `cloud.bag`), and `tf1.bag`, the uncompressed one as
/// `tf1_bag.py` rewrites it: frame ids with a leading slash, `tf/tfMessage`.
fn bags() -> &'static (PathBuf, Value) {
    static BAGS: OnceLock<(PathBuf, Value)> = OnceLock::new();
    BAGS.get_or_init(|| {
        let python = rosbags_bin().join("python3");
        let out =
            Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("rosbags-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out).unwrap();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/write_bag.py");
        run_ok("write_bag.py", Command::new(&python).arg(script).arg(&out));
        let expected = std::fs::read_to_string(out.join("expected.json")).unwrap();
        let mut expected: Value = serde_json::from_str(&expected).unwrap();
        let convert = |source: &str, target: &Path, compression: &str, more: &[&str]| {
            rosbags_convert(&out.join(source), &out.join(target), compression, more);
        };
        for compression in ROS1_COMPRESSIONS {
            let name = format!("ros1_{compression}.bag");
            convert("mcap", Path::new(&name), compression, &[]);
            expected[name] = expected["mcap"].clone();
        }
        convert("long_file_zstd", Path::new("long.bag"), "lz4", &[]);
        convert("multi_echo", Path::new("multi_echo.bag"), "lz4", &[]);
        convert("cloud", Path::new("cloud.bag"), "bz2", &[]);
        expected["multi_echo.bag"] = expected["multi_echo"].clone();
        // One recording in two files, a folder of its own: the scans, then the transforms.
        let split = Path::new("ros1_split");
        std::fs::create_dir_all(out.join(split)).unwrap();
        for (file, topics) in [
            ("part_2.bag", &["/tf", "/tf_static"][..]),
            ("part_10.bag", &["/base_scan", "/chatter"][..]),
        ] {
            let include = [&["--include-topic"][..], topics].concat();
            convert("mcap", &split.join(file), "bz2", &include);
        }
        expected["ros1_split"] = expected["mcap"].clone();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/tf1_bag.py");
        run_ok(
            "tf1_bag.py",
            Command::new(&python)
                .arg(script)
                .arg(out.join("ros1_none.bag"))
                .arg(out.join("tf1.bag")),
        );
        expected["tf1.bag"] = expected["mcap"].clone();
        (out.clone(), expected)
    })
}

/// Whether two data sets are the same, NaN ranges included (`Debug` prints every value
/// exactly).
fn same(a: &fastslam_replay::dataset::DataSet, b: &fastslam_replay::dataset::DataSet) -> bool {
    format!("{a:?}") == format!("{b:?}")
}

fn load(name: &str, choice: &TopicChoice) -> Result<rosbag::Bag, DataError> {
    rosbag::load(&bags().0.join(name), choice)
}

/// Checks a tf-only bag against what the script wrote.
fn check_tf_only_bag(name: &str) -> rosbag::Bag {
    let bag = load(name, &TopicChoice::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let expected = &bags().1[name];
    assert_eq!(bag.scan_topic, "/base_scan");
    assert_eq!(
        bag.odometry,
        OdometrySource::Tf {
            odom_frame: "odom".into(),
            base_frame: "base_link".into()
        }
    );
    let epoch_ns = expected["epoch_ns"].as_u64().unwrap();
    assert_eq!(bag.data.epoch_s, epoch_ns as f64 * 1e-9);
    let odometry = expected["odometry"].as_array().unwrap();
    assert_eq!(bag.data.odometry.len(), odometry.len(), "{name}");
    for (got, want) in bag.data.odometry.iter().zip(odometry) {
        assert_eq!(got.header.stamp_ns, want["stamp_ns"].as_u64().unwrap());
        for (value, key) in [(got.x, "x"), (got.y, "y"), (got.theta, "theta")] {
            let want = want[key].as_f64().unwrap();
            assert!(
                (value - want).abs() < 1e-12,
                "{name} {key}: {value} vs {want}"
            );
        }
        assert_eq!((got.v, got.omega, got.steering), (0.0, 0.0, 0.0));
    }
    let m = bag.data.laser_mount;
    let mount: Vec<f64> = (expected["mount"].as_array().unwrap().iter())
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!((m.x - mount[0]).abs() < 1e-12, "{m:?}");
    assert!((m.y - mount[1]).abs() < 1e-12, "{m:?}");
    assert!((m.theta - mount[2]).abs() < 1e-12, "{m:?}");
    assert!(bag.mount_from_tf);
    assert_eq!(bag.laser_frame, "laser");
    let scans = expected["scans"].as_array().unwrap();
    assert_eq!(bag.data.raw_scans.len(), scans.len(), "{name}");
    for (k, (got, want)) in bag.data.raw_scans.iter().zip(scans).enumerate() {
        assert_eq!(
            got.header.header.stamp_ns,
            want["stamp_ns"].as_u64().unwrap(),
            "{name} scan {k}"
        );
        assert_eq!(got.header.header.seq, k as u64);
        let ranges: Vec<f32> = (want["ranges"].as_array().unwrap().iter())
            .map(|r| r.as_str().unwrap().parse().unwrap())
            .collect();
        assert_eq!(got.items.len(), ranges.len());
        for (g, w) in got.items.iter().zip(&ranges) {
            assert!(
                g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                "{name} scan {k}: {g} vs {w}"
            );
        }
        assert!(got.header.angle_increment > 0.0);
    }
    // A no-return stays a no-return, and the NaN stays invalid.
    assert_eq!(bag.data.raw_scans[0].items[1], f32::INFINITY);
    assert!(bag.data.raw_scans[0].items[3].is_nan());
    assert_eq!(bag.skipped.len(), 1, "{:?}", bag.skipped);
    assert_eq!(
        (bag.skipped[0].name.as_str(), bag.skipped[0].count),
        ("/chatter", 1)
    );
    bag
}

/// The tests (their names hold `rosbag`, so `cargo test rosbag` runs them).
mod written_by_rosbags {
    use super::*;

    #[test]
    fn an_mcap_bag_with_zstd_chunks_and_tf_odometry_reads_exactly() {
        let bag = check_tf_only_bag("mcap");
        assert!(bag.scan_stamps.is_clean() && bag.odometry_stamps.is_clean());
        assert!(bag.warnings.is_empty(), "{:?}", bag.warnings);
        // The storage file alone reads the same.
        let file = bags().0.join("mcap/mcap.mcap");
        let alone = rosbag::load(&file, &TopicChoice::default()).unwrap();
        assert!(
            same(&alone.data, &bag.data),
            "the file alone reads otherwise"
        );
        println!("{}", bag.summary());
    }

    #[test]
    fn a_sqlite_bag_reads_exactly_with_a_duplicate_dropped_and_a_stamp_nudged() {
        let bag = check_tf_only_bag("sqlite");
        assert_eq!((bag.scan_stamps.duplicates, bag.scan_stamps.nudged), (1, 1));
        assert!(bag.odometry_stamps.is_clean());
        assert!(
            bag.summary()
                .contains("scan stamps: 0 reordered, 1 duplicates dropped, 1 nudged")
        );
    }

    #[test]
    fn compressed_bags_read_like_plain_ones() {
        let plain = check_tf_only_bag("mcap");
        for name in ["sqlite_file_zstd", "mcap_message_zstd"] {
            assert!(
                same(&check_tf_only_bag(name).data, &plain.data),
                "{name} differs"
            );
        }
    }

    #[test]
    fn multi_echo_scans_read_their_first_echo_in_rosbag2_and_ros1_bags() {
        let plain = check_tf_only_bag("mcap");
        for name in ["multi_echo", "multi_echo.bag"] {
            let bag = check_tf_only_bag(name);
            assert!(same(&bag.data, &plain.data), "{name} differs");
            assert!(bag.warnings.is_empty(), "{name}: {:?}", bag.warnings);
            let summary = bag.summary();
            assert!(
                summary.contains("MultiEchoLaserScan's first echoes"),
                "{summary}"
            );
        }
    }

    #[test]
    fn a_point_cloud_named_by_the_flag_is_cut_to_a_scan_and_never_picked_unasked() {
        let err = load("cloud", &TopicChoice::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("no sensor_msgs/msg/LaserScan or"), "{err}");
        assert!(
            err.contains(
                "a sensor_msgs/msg/PointCloud2 topic named there is cut to a scan: /points, \
                 /camera/points)"
            ),
            "{err}"
        );
        assert!(
            err.contains("/points (sensor_msgs/msg/PointCloud2, 5 messages)"),
            "{err}"
        );
        let choice = TopicChoice {
            scan_topic: Some("/points".into()),
            ..TopicChoice::default()
        };
        let bag = load("cloud", &choice).unwrap();
        assert_eq!(
            (bag.scan_topic.as_str(), bag.laser_frame.as_str()),
            ("/points", "velodyne")
        );
        assert!(bag.mount_from_tf);
        assert!((bag.data.laser_mount.x - 0.1).abs() < 1e-12);
        let expected = bags().1["cloud"]["clouds"].as_array().unwrap();
        assert_eq!(bag.data.raw_scans.len(), expected.len());
        for (scan, want) in bag.data.raw_scans.iter().zip(expected) {
            assert_eq!(
                scan.header.header.stamp_ns,
                want["stamp_ns"].as_u64().unwrap()
            );
            assert_eq!(scan.items.len(), 720);
            let beams = want["beams"].as_object().unwrap();
            for (i, r) in scan.items.iter().enumerate() {
                match beams.get(&i.to_string()) {
                    Some(w) => {
                        let w = w.as_f64().unwrap();
                        assert!((f64::from(*r) - w).abs() < 1e-5, "beam {i}: {r} vs {w}");
                    }
                    None => assert!(r.is_nan(), "beam {i} holds {r}"),
                }
            }
        }
        let summary = bag.summary();
        assert!(summary.contains("PointCloud2 cut to scans"), "{summary}");
        assert!(bag.skipped.iter().any(|t| t.name == "/camera/points"));
        // The same clouds in a ROS 1 bag.
        let ros1 = load("cloud.bag", &choice).unwrap();
        assert!(same(&ros1.data, &bag.data), "the ROS 1 bag reads otherwise");
    }

    #[test]
    fn a_few_point_clouds_replay_through_the_processes_to_the_end() {
        // Five messages are sent before the service takes its first: the replay stays
        // until they are received.
        let prefix = common::prefix("cloud_replay");
        let dir = common::folder(&prefix);
        let out = dir.join("run");
        let result = Command::new(common::LAUNCHER)
            .args(["replay", "rosbag"])
            .arg(bags().0.join("cloud"))
            .args([
                "--scan-topic",
                "/points",
                "--prefix",
                &prefix,
                "--timeout-s",
                "120",
            ])
            .arg("--out")
            .arg(&out)
            .output()
            .expect("starting the launcher");
        common::assert_success(&result);
        let m = common::metrics(&out);
        assert_eq!(m["complete"], true);
        assert_eq!(common::num(&m, "/estimate/poses"), 5.0);
        common::assert_no_leftovers_and_remove(&prefix, &dir);
    }

    #[test]
    fn two_scan_topics_need_a_choice() {
        let err = load("two_scans", &TopicChoice::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(
                "2 sensor_msgs/msg/LaserScan or sensor_msgs/msg/MultiEchoLaserScan topics"
            ),
            "{err}"
        );
        assert!(
            err.contains("/front/scan (sensor_msgs/msg/LaserScan, 4 messages)"),
            "{err}"
        );
        assert!(
            err.contains("/rear/scan (sensor_msgs/msg/LaserScan, 4 messages)"),
            "{err}"
        );
        assert!(err.contains("--scan-topic"), "{err}");
        let choice = TopicChoice {
            scan_topic: Some("/rear/scan".into()),
            ..TopicChoice::default()
        };
        let bag = load("two_scans", &choice).unwrap();
        assert_eq!(bag.odometry, OdometrySource::Topic("/odom".into()));
        assert_eq!(
            (bag.laser_frame.as_str(), bag.base_frame.as_str()),
            ("rear_laser", "base_link")
        );
        let m = bag.data.laser_mount;
        assert!((m.x + 0.3).abs() < 1e-12 && m.y.abs() < 1e-12, "{m:?}");
        assert!(
            (m.theta.abs() - std::f64::consts::PI).abs() < 1e-12,
            "{m:?}"
        );
        let expected = bags().1["two_scans"]["odometry"].as_array().unwrap();
        assert_eq!(bag.data.odometry.len(), expected.len());
        for (got, want) in bag.data.odometry.iter().zip(expected) {
            assert_eq!(got.header.stamp_ns, want["stamp_ns"].as_u64().unwrap());
            for (value, key) in [
                (got.x, "x"),
                (got.theta, "theta"),
                (got.v, "v"),
                (got.omega, "omega"),
            ] {
                assert!((value - want[key].as_f64().unwrap()).abs() < 1e-12, "{key}");
            }
        }
        assert_eq!(bag.skipped.len(), 1);
        assert_eq!(bag.skipped[0].name, "/front/scan");
    }

    #[test]
    fn an_undecodable_message_is_skipped_with_a_warning_naming_topic_and_index() {
        let bag = load("bad_message", &TopicChoice::default()).unwrap();
        assert_eq!(bag.data.raw_scans.len(), 4, "the other four scans are read");
        let skipped: Vec<&String> = (bag.warnings.iter())
            .filter(|w| w.contains("do not decode"))
            .collect();
        let [warning] = skipped[..] else {
            panic!("one warning about it: {:?}", bag.warnings);
        };
        assert!(
            warning.contains("1 messages skipped that do not decode")
                && warning.contains("bad_message/bad_message.mcap: /scan message 2: "),
            "{warning}"
        );
    }

    #[test]
    fn compressed_files_cut_short_keep_what_came_before_the_cut_or_are_refused() {
        let dir = bags().0.join("cut_zstd");
        std::fs::create_dir_all(&dir).unwrap();
        // Why the file `cut` holding `bytes` is refused.
        let refusal = |cut: &Path, bytes: &[u8]| {
            std::fs::write(cut, bytes).unwrap();
            let err = rosbag::load(cut, &TopicChoice::default()).unwrap_err();
            err.to_string()
        };
        // MCAP compressed whole, cut in half: the messages before the cut, one warning.
        let source = bags().0.join("long_file_zstd/long_file_zstd.mcap.zstd");
        let whole = rosbag::load(&source, &TopicChoice::default()).unwrap();
        assert_eq!(whole.data.raw_scans.len(), 3000, "{:?}", whole.warnings);
        let bytes = std::fs::read(&source).unwrap();
        let cut = dir.join("cut.mcap.zstd");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let bag = rosbag::load(&cut, &TopicChoice::default()).unwrap();
        let scans = bag.data.raw_scans.len();
        assert!(scans > 0 && scans < 3000, "{scans} scans");
        let cuts: Vec<&String> = (bag.warnings.iter())
            .filter(|w| w.contains("cut short"))
            .collect();
        let [warning] = cuts[..] else {
            panic!("one warning about the cut: {:?}", bag.warnings);
        };
        assert!(warning.contains("cut.mcap.zstd: cut short"), "{warning}");
        assert!(
            warning.contains("bytes after decompression read"),
            "{warning}"
        );
        // Cut before its first whole block: refused, saying so.
        let err = refusal(&cut, &bytes[..bytes.len() / 100]);
        assert!(
            err.contains("cut.mcap.zstd: the zstd-compressed file is cut short"),
            "{err}"
        );
        // A database compressed whole and cut: SQLite needs all of it, so it is refused.
        let source = bags()
            .0
            .join("long_sqlite_file_zstd/long_sqlite_file_zstd.db3.zstd");
        let bytes = std::fs::read(&source).unwrap();
        let err = refusal(&dir.join("cut.db3.zstd"), &bytes[..bytes.len() / 2]);
        assert!(
            err.contains("cut.db3.zstd: the zstd-compressed database is cut short"),
            "{err}"
        );
    }

    #[test]
    fn a_truncated_mcap_file_is_read_up_to_the_cut_or_refused_never_a_panic() {
        let source = bags().0.join("mcap/mcap.mcap");
        let bytes = std::fs::read(&source).unwrap();
        let dir = bags().0.join("cut");
        std::fs::create_dir_all(&dir).unwrap();
        let cut = dir.join("cut.mcap");
        // Cut before its first message: refused, naming the file.
        std::fs::write(&cut, &bytes[..bytes.len() / 64]).unwrap();
        let err = rosbag::load(&cut, &TopicChoice::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("cut.mcap: MCAP file cut short"), "{err}");
        // Cut in half: the messages before the cut, with a warning.
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let bag = rosbag::load(&cut, &TopicChoice::default()).unwrap();
        assert!(!bag.data.odometry.is_empty(), "{bag:?}");
        let [warning] = &bag.warnings[..] else {
            panic!("one warning: {:?}", bag.warnings);
        };
        assert!(
            warning.contains("cut.mcap: cut short inside a record"),
            "{warning}"
        );
        assert!(!warning.contains("decompression"), "{warning}");
        // The same half followed by the file's closing magic, as a whole file whose record
        // length is corrupt reads: refused as corrupt, not taken for a cut.
        let closing = &bytes[bytes.len() - 8..];
        std::fs::write(&cut, [&bytes[..bytes.len() / 2], closing].concat()).unwrap();
        let err = rosbag::load(&cut, &TopicChoice::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("cut.mcap: corrupt MCAP file"), "{err}");
        // Anywhere it is cut: an error naming the file, or the whole part read with a
        // warning.
        for k in 0..64 {
            let end = bytes.len() * k / 64;
            std::fs::write(&cut, &bytes[..end]).unwrap();
            match rosbag::load(&cut, &TopicChoice::default()) {
                Err(e) => assert!(e.to_string().contains("cut.mcap"), "cut at {end}: {e}"),
                Ok(bag) => assert!(
                    !bag.warnings.is_empty(),
                    "cut at {end} read without warning"
                ),
            }
        }
    }

    #[test]
    fn ros1_bags_read_like_the_rosbag2_bag_they_were_converted_from() {
        let rosbag2 = check_tf_only_bag("mcap");
        let names = ROS1_COMPRESSIONS.map(|c| format!("ros1_{c}.bag"));
        // And one as recorded before tf2: `/base_link`, `tf/tfMessage`.
        for name in names.iter().map(String::as_str).chain(["tf1.bag"]) {
            let bag = check_tf_only_bag(name);
            assert!(same(&bag.data, &rosbag2.data), "{name} differs");
            assert!(bag.warnings.is_empty(), "{name}: {:?}", bag.warnings);
            assert!(
                bag.summary().contains("10 scans from /base_scan"),
                "{}",
                bag.summary()
            );
        }
        // A folder of ROS 1 bags reads as one bag; a folder that mixes them with rosbag2
        // files is refused.
        assert!(same(&check_tf_only_bag("ros1_split").data, &rosbag2.data));
        let mixed = bags().0.join("mixed");
        std::fs::create_dir_all(&mixed).unwrap();
        std::fs::copy(bags().0.join("ros1_none.bag"), mixed.join("a.bag")).unwrap();
        std::fs::copy(bags().0.join("mcap/mcap.mcap"), mixed.join("a.mcap")).unwrap();
        let err = load("mixed", &TopicChoice::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("holds both rosbag2 storage files (a.mcap…) and ROS 1 bags (a.bag…)"),
            "{err}"
        );
        // Its frames named as they were recorded, with tf's slash, read the same.
        let slashed = TopicChoice {
            odom_frame: Some("/odom".into()),
            base_frame: Some("/base_link".into()),
            ..TopicChoice::default()
        };
        let bag = load("tf1.bag", &slashed).unwrap();
        assert!(same(&bag.data, &rosbag2.data), "tf1.bag with slashed flags");
    }

    #[test]
    fn a_ros1_bag_cut_short_or_never_closed_keeps_its_whole_chunks() {
        let source = bags().0.join("long.bag");
        let whole = rosbag::load(&source, &TopicChoice::default()).unwrap();
        assert_eq!(whole.data.raw_scans.len(), 3000, "{:?}", whole.warnings);
        // The bag has no mounting (no tf): that warning aside, the storage's only.
        let storage = |bag: &rosbag::Bag| -> Vec<String> {
            (bag.warnings.iter())
                .filter(|w| !w.contains("no transform base_link→laser"))
                .cloned()
                .collect()
        };
        assert!(storage(&whole).is_empty(), "{:?}", whole.warnings);
        let bytes = std::fs::read(&source).unwrap();
        let dir = bags().0.join("cut_ros1");
        std::fs::create_dir_all(&dir).unwrap();
        let cut = dir.join("cut.bag");
        // Cut in half: the chunks before the cut, one warning.
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let bag = rosbag::load(&cut, &TopicChoice::default()).unwrap();
        let scans = bag.data.raw_scans.len();
        assert!(scans > 0 && scans < 3000, "{scans} scans");
        let [warning] = &storage(&bag)[..] else {
            panic!("one warning: {:?}", bag.warnings);
        };
        assert!(
            warning.contains("cut.bag: cut short inside a record"),
            "{warning}"
        );
        // Never closed: the bag header's index position still 0, every message read.
        let at = (bytes.windows(10).position(|w| w == b"index_pos=")).unwrap() + 10;
        let mut open = bytes.clone();
        open[at..at + 8].fill(0);
        std::fs::write(&cut, &open).unwrap();
        let bag = rosbag::load(&cut, &TopicChoice::default()).unwrap();
        assert_eq!(bag.data.raw_scans.len(), 3000);
        let [warning] = &storage(&bag)[..] else {
            panic!("one warning: {:?}", bag.warnings);
        };
        assert!(warning.contains("cut.bag: no index"), "{warning}");
        // Cut before its first message: refused, naming the file.
        std::fs::write(&cut, &bytes[..bytes.len() / 1000]).unwrap();
        let err = rosbag::load(&cut, &TopicChoice::default()).unwrap_err();
        assert!(
            err.to_string()
                .contains("cut.bag: ROS 1 bag cut short before its first message"),
            "{err}"
        );
        // Anywhere it is cut: an error naming the file, or the whole chunks read with a
        // warning.
        for k in 0..64 {
            let end = bytes.len() * k / 64;
            std::fs::write(&cut, &bytes[..end]).unwrap();
            match rosbag::load(&cut, &TopicChoice::default()) {
                Err(e) => assert!(e.to_string().contains("cut.bag"), "cut at {end}: {e}"),
                Ok(bag) => assert!(!storage(&bag).is_empty(), "cut at {end} without warning"),
            }
        }
        // A chunk whose stated size is not what it decompresses to: refused as corrupt,
        // naming the file.
        let size = (bytes.windows(5).position(|w| w == b"size=")).unwrap() + 5;
        let mut corrupt = bytes.clone();
        corrupt[size..size + 4].copy_from_slice(&7u32.to_le_bytes());
        std::fs::write(&cut, &corrupt).unwrap();
        let err = rosbag::load(&cut, &TopicChoice::default()).unwrap_err();
        assert!(
            err.to_string()
                .contains("cut.bag: corrupt ROS 1 bag: a lz4 chunk decompresses to"),
            "{err}"
        );
    }
}
