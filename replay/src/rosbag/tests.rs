//! Tests of topic choice, odometry from tf and the sample bag shipped in `data/ros2/`.

use super::*;
use crate::rosbag::cdr::tests::{Writer, scan_bytes};
use std::f64::consts::FRAC_PI_2;

fn topic(name: &str, type_name: &str, count: usize) -> Topic {
    Topic {
        name: name.into(),
        type_name: type_name.into(),
        encoding: "cdr".into(),
        count,
    }
}

fn reader<'a>(contents: &'a Contents) -> Reader<'a> {
    Reader {
        path: Path::new("bag"),
        contents,
        warnings: Vec::new(),
        used: BTreeSet::new(),
        rejected: BTreeSet::new(),
        skipped_messages: Skipped::default(),
    }
}

fn raw(topic: usize, index: usize, receive_ns: u64, data: Vec<u8>) -> RawMessage {
    RawMessage {
        topic,
        file: 0,
        index,
        receive_ns,
        data: Ok(data),
    }
}

#[test]
fn the_one_topic_of_a_type_is_chosen_and_several_are_listed_with_the_flag() {
    let contents = Contents {
        files: vec!["bag/bag_0.mcap".into()],
        topics: vec![
            topic("/front/scan", LASER_SCAN, 12),
            topic("/rear/scan", LASER_SCAN, 11),
            topic("/odom", ODOMETRY, 30),
            topic("/chatter", "std_msgs/msg/String", 2),
        ],
        ..Contents::default()
    };
    let mut r = reader(&contents);
    assert_eq!(r.choose(&[ODOMETRY], None, "--odom-topic").unwrap(), 2);
    let err = r
        .choose(&[LASER_SCAN], None, "--scan-topic")
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("bag: 2 sensor_msgs/msg/LaserScan topics"),
        "{err}"
    );
    assert!(
        err.contains("/front/scan (sensor_msgs/msg/LaserScan, 12 messages)"),
        "{err}"
    );
    assert!(
        err.contains("/rear/scan (sensor_msgs/msg/LaserScan, 11 messages)"),
        "{err}"
    );
    assert!(err.ends_with("pick one with --scan-topic"), "{err}");
    assert_eq!(
        r.choose(&[LASER_SCAN], Some("/rear/scan"), "--scan-topic")
            .unwrap(),
        1
    );
    let err = r
        .choose(&[LASER_SCAN], Some("/chatter"), "--scan-topic")
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("no sensor_msgs/msg/LaserScan topic `/chatter`")
    );
    assert_eq!(r.used.iter().copied().collect::<Vec<_>>(), [1, 2]);
}

#[test]
fn no_scan_topic_lists_what_the_bag_holds() {
    let contents = Contents {
        topics: vec![
            topic("/odom", ODOMETRY, 3),
            topic("/points", "sensor_msgs/msg/PointCloud2", 4),
        ],
        ..Contents::default()
    };
    let err = reader(&contents)
        .build(&TopicChoice::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(
            "no sensor_msgs/msg/LaserScan or sensor_msgs/msg/MultiEchoLaserScan topic; \
             the bag's topics:"
        ),
        "{err}"
    );
    assert!(
        err.contains("/points (sensor_msgs/msg/PointCloud2, 4 messages)"),
        "{err}"
    );
    assert!(err.contains("--scan-topic"), "{err}");
}

/// A `TFMessage` with one transform `parent → child` at `(x, y, yaw)`.
fn tf_bytes(sec: i32, parent: &str, child: &str, x: f64, y: f64, yaw: f64) -> Vec<u8> {
    let mut w = Writer::new(true);
    w.u32(1).header(sec, 0, parent).string(child);
    for v in [x, y, 0.0, 0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()] {
        w.f64(v);
    }
    w.bytes
}

#[test]
fn odometry_comes_from_tf_through_an_intermediate_frame() {
    let fields = [-1.0, 1.0, 0.5, 0.0, 0.1, 0.1, 10.0];
    let mut scan = scan_bytes(true, "laser", fields, &[1.0, 2.0, 50.0, 0.0, 4.0]);
    // Stamp 0: the receive time stands in.
    scan[4..12].fill(0);
    let mut messages = vec![
        raw(0, 0, 15_000_000_000, scan),
        raw(
            2,
            0,
            0,
            tf_bytes(1, "base_footprint", "base_link", 0.5, 0.0, 0.0),
        ),
        raw(2, 1, 0, tf_bytes(1, "base_link", "laser", 0.2, -0.1, 0.3)),
    ];
    for (k, x) in [10.0, 11.0, 12.0].into_iter().enumerate() {
        messages.push(raw(
            1,
            k,
            0,
            tf_bytes(10 + k as i32, "odom", "base_footprint", x, 0.0, FRAC_PI_2),
        ));
    }
    let contents = Contents {
        files: vec!["bag.db3".into()],
        topics: vec![
            topic("/base_scan", LASER_SCAN, 1),
            topic(TF_TOPIC, TF_MESSAGE, 3),
            topic(TF_STATIC_TOPIC, TF_MESSAGE, 2),
        ],
        messages,
        ..Contents::default()
    };
    let bag = reader(&contents).build(&TopicChoice::default()).unwrap();
    assert_eq!(
        bag.odometry,
        OdometrySource::Tf {
            odom_frame: "odom".into(),
            base_frame: "base_link".into()
        }
    );
    let odo = &bag.data.odometry;
    assert_eq!(odo.len(), 3);
    assert_eq!(bag.data.epoch_s, 10.0);
    assert_eq!(odo[2].header.stamp_ns, 2_000_000_000);
    // base_link sits 0.5 m ahead of base_footprint, which faces +y.
    assert!((odo[2].x - 12.0).abs() < 1e-12 && (odo[2].y - 0.5).abs() < 1e-12);
    assert!((odo[2].theta - FRAC_PI_2).abs() < 1e-12);
    let m = bag.data.laser_mount;
    assert!(
        (m.x - 0.2).abs() < 1e-12 && (m.y + 0.1).abs() < 1e-12 && (m.theta - 0.3).abs() < 1e-12
    );
    let scan = &bag.data.raw_scans[0];
    assert_eq!(scan.header.header.stamp_ns, 5_000_000_000);
    assert_eq!(
        scan.items,
        [1.0, 2.0, f32::INFINITY, f32::NEG_INFINITY, 4.0]
    );
    assert!(bag.skipped.is_empty() && bag.warnings.is_empty(), "{bag:?}");
    // A bad base frame: the error lists what tf holds and the flags.
    let choice = TopicChoice {
        base_frame: Some("base".into()),
        ..TopicChoice::default()
    };
    let err = reader(&contents).build(&choice).unwrap_err().to_string();
    assert!(err.contains("no moving transform odom→base"), "{err}");
    assert!(err.contains("odom→base_footprint (3)"), "{err}");
    assert!(err.contains("--odom-frame and --base-frame"), "{err}");
}

#[test]
fn an_undecodable_message_is_skipped_and_named_by_file_topic_and_index() {
    // One good scan, one cut short and one that did not decompress: the good one is
    // decoded, the others skipped and named.
    let good = scan_bytes(
        true,
        "laser",
        [-1.0, 1.0, 0.5, 0.0, 0.1, 0.1, 10.0],
        &[1.0; 5],
    );
    let contents = Contents {
        files: vec!["a.mcap".into(), "b.mcap".into()],
        topics: vec![topic("/scan", LASER_SCAN, 2)],
        messages: vec![
            raw(0, 0, 1, good.clone()),
            RawMessage {
                file: 1,
                ..raw(0, 1, 2, good[..30].to_vec())
            },
            RawMessage {
                data: Err("zstd-compressed message does not decompress: cut".into()),
                ..raw(0, 2, 3, Vec::new())
            },
        ],
        ..Contents::default()
    };
    let mut r = reader(&contents);
    let scans = r.decode(0, cdr::laser_scan);
    assert_eq!(scans.len(), 1);
    assert_eq!(scans[0].2.index, 0, "the good one, with its message");
    // Read again (as tf is, once per question): still two messages skipped.
    assert_eq!(r.decode(0, cdr::laser_scan).len(), 1);
    let skipped = r.rejected_messages().unwrap();
    assert!(
        skipped.starts_with("2 messages skipped that do not decode or hold values no sensor reports (b.mcap: /scan message 1: "),
        "{skipped}"
    );
    assert!(
        skipped.contains("a.mcap: /scan message 2: zstd-compressed message does not decompress"),
        "{skipped}"
    );
}

#[test]
fn the_sample_bag_reads_whole() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ros2/mit-csail");
    let bag = load(&dir, &TopicChoice::default()).unwrap();
    assert_eq!(bag.data.raw_scans.len(), 1988);
    assert_eq!(bag.data.odometry.len(), 1988);
    assert_eq!(bag.scan_topic, "/scan");
    assert_eq!(bag.odometry, OdometrySource::Topic("/odom".into()));
    assert_eq!(
        (bag.laser_frame.as_str(), bag.base_frame.as_str()),
        ("laser", "base_link")
    );
    assert!(bag.mount_from_tf);
    assert_eq!(bag.data.laser_mount, Pose2::default());
    assert!((bag.data.epoch_s - 1_134_864_629.895_182).abs() < 1e-6);
    let first = &bag.data.raw_scans[0];
    assert_eq!(first.header.header.stamp_ns, 0);
    assert_eq!((first.items.len(), first.header.range_max), (361, 80.0));
    // The log's no-return readings (81.91 m) lie beyond range_max: +∞.
    assert!(first.items.contains(&f32::INFINITY));
    let last = bag.data.odometry.last().unwrap();
    assert_eq!(last.header.stamp_ns, 423_997_024_000);
    assert!(bag.data.truth.is_empty() && bag.data.scans.is_empty());
    assert_eq!(
        bag.skipped,
        [TopicCount {
            name: TF_TOPIC.into(),
            type_name: TF_MESSAGE.into(),
            count: 1988
        }]
    );
    assert!(bag.warnings.is_empty(), "{:?}", bag.warnings);
    assert!(bag.scan_stamps.is_clean() && bag.odometry_stamps.is_clean());
    let line = bag.summary();
    assert!(
        line.starts_with("1988 scans from /scan (frame laser, mounted at x 0.000 m"),
        "{line}"
    );
    // The storage file alone reads the same.
    let file = load(&dir.join("mit-csail_mcap.mcap"), &TopicChoice::default()).unwrap();
    assert_eq!(file.data, bag.data);
}

#[test]
fn only_the_scan_topic_named_is_kept_and_a_cloud_only_when_named() {
    let named = |scan_topic: Option<&str>, odometry| TopicChoice {
        scan_topic: scan_topic.map(str::to_string),
        odometry,
        ..TopicChoice::default()
    };
    let kept =
        |choice: &TopicChoice, name: &str, type_name: &str| match keep(choice, name, type_name) {
            Keep::Nothing => "nothing",
            Keep::Bytes => "bytes",
            Keep::Reduced(_) => "reduced",
        };
    let any = named(None, OdometryChoice::Recorded);
    assert_eq!(kept(&any, "/scan", LASER_SCAN), "bytes");
    assert_eq!(kept(&any, "/echoes", MULTI_ECHO_LASER_SCAN), "bytes");
    assert_eq!(kept(&any, "/points", POINT_CLOUD), "nothing");
    assert_eq!(kept(&any, "/odom", ODOMETRY), "bytes");
    assert_eq!(kept(&any, TF_TOPIC, TF_MESSAGE), "bytes");
    assert_eq!(kept(&any, "/chatter", "std_msgs/msg/String"), "nothing");
    let points = named(Some("/points"), OdometryChoice::Laser);
    assert_eq!(kept(&points, "/points", POINT_CLOUD), "reduced");
    assert_eq!(kept(&points, "/camera/points", POINT_CLOUD), "nothing");
    assert_eq!(kept(&points, "/scan", LASER_SCAN), "nothing");
    assert_eq!(kept(&points, "/odom", ODOMETRY), "nothing");
    assert_eq!(kept(&points, TF_STATIC_TOPIC, TF_MESSAGE), "bytes");
}
