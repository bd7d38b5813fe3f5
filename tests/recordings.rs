//! A user's own recordings through the real processes: `fastslam-stack replay rosbag`
//! and `replay carmen` read a bag or a log without ground truth, play it through the
//! service and the client, and score the trajectories on the Freiburg benchmark's
//! relations, among them logs rewritten with the laser off the base and with a slip of
//! the front end. Bad files end in one line and a non-zero exit.

mod common;

use common::*;
use fastslam_estimation::Pose2;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn data(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(relative)
}

/// Runs `fastslam-stack replay <args>` under `prefix` into `out`.
fn replay(prefix: &str, out: &Path, args: &[&str]) -> Output {
    replay_on_threads(prefix, out, args, None)
}

/// [`replay`] with the processes' rayon pools at `threads` threads (the machine's cores
/// when `None`).
fn replay_on_threads(prefix: &str, out: &Path, args: &[&str], threads: Option<usize>) -> Output {
    let mut command = Command::new(LAUNCHER);
    if let Some(n) = threads {
        command.env("RAYON_NUM_THREADS", n.to_string());
    }
    command
        .arg("replay")
        .args(args)
        .args(["--prefix", prefix, "--timeout-s", "600", "--out"])
        .arg(out)
        .output()
        .expect("starting the launcher")
}

/// Replays `args` (a recording, flags), expects success without truth and returns the
/// metrics.
fn replay_recording(name: &str, args: &[&str]) -> (PathBuf, serde_json::Value, String) {
    replay_recording_on_threads(name, args, None)
}

/// [`replay_recording`] on `threads` rayon threads.
fn replay_recording_on_threads(
    name: &str,
    args: &[&str],
    threads: Option<usize>,
) -> (PathBuf, serde_json::Value, String) {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let out = dir.join("run");
    let result = replay_on_threads(&prefix, &out, args, threads);
    assert_success(&result);
    let stdout = String::from_utf8_lossy(&result.stdout).into_owned();
    assert!(stdout.contains("no ground truth"), "{stdout}");
    assert_no_leftovers(&prefix);
    for file in [
        "estimate.tum",
        "smoothed.tum",
        "map.pgm",
        "map.yaml",
        "run.mcap",
        "metrics.json",
    ] {
        assert!(
            out.join(file).is_file(),
            "{file} missing in {}",
            out.display()
        );
    }
    let m = metrics(&out);
    assert_eq!(m["complete"], true, "{m}");
    assert_eq!(m["ground_truth"], false, "{m}");
    assert!(
        m["estimate"].get("ate_rmse_m").is_none(),
        "no truth, no ATE: {m}"
    );
    (out, m, stdout)
}

/// The raw odometry of MIT CSAIL scored on its relations: the benchmark's published
/// figure, 1.681 ± 5.294 m, to within 1 %; the real-time pose and the loop-closing
/// back-end's trajectory scored on the same relations, each well below it.
fn assert_mit_dead_reckoning(m: &serde_json::Value) {
    let mean = num(m, "/dead_reckoning/relations/trans_mean_m");
    assert!((mean - 1.681).abs() < 0.01 * 1.681, "{mean}");
    assert!(num(m, "/dead_reckoning/relations/count") > 1000.0, "{m}");
    for trajectory in ["estimate", "smoothed"] {
        let error = num(m, &format!("/{trajectory}/relations/trans_mean_m"));
        assert!(error < 0.2 * mean, "{trajectory}: {error} m");
    }
    assert!(num(m, "/smoothed/solves") > 1.0, "{m}");
}

/// The flags of `replay carmen LOG`, scored on MIT CSAIL's relations, with `particles`.
fn carmen_on_mit_relations(log: &Path, particles: usize) -> Vec<String> {
    let relations = data("freiburg/mit-csail/mit-csail.relations");
    let (log, relations) = (log.display().to_string(), relations.display().to_string());
    let particles = particles.to_string();
    [
        "carmen",
        &log,
        "--relations",
        &relations,
        "--particles",
        &particles,
    ]
    .map(String::from)
    .to_vec()
}

#[test]
fn a_carmen_log_replays_without_truth_and_is_scored_on_its_relations() {
    let args = carmen_on_mit_relations(&data("freiburg/mit-csail/mit-csail.clf.gz"), 5);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    // The same log on one rayon thread and on two, side by side: loop closure runs on a
    // thread of its own, and what it publishes must not depend on how fast it is.
    let ((one, m, stdout), (two, _, _)) = std::thread::scope(|s| {
        let one = s.spawn(|| replay_recording_on_threads("carmen1", &args, Some(1)));
        let two = s.spawn(|| replay_recording_on_threads("carmen2", &args, Some(2)));
        (one.join().unwrap(), two.join().unwrap())
    });
    assert_mit_dead_reckoning(&m);
    assert!(stdout.contains("relations"), "{stdout}");
    assert_eq!(reproducible(&one), reproducible(&two));
    for file in ["estimate.tum", "smoothed.tum", "map.pgm"] {
        let read = |out: &Path| std::fs::read(out.join(file)).unwrap();
        assert!(
            read(&one) == read(&two),
            "{file} differs between 1 and 2 threads"
        );
    }
}

#[test]
fn a_ros2_bag_and_its_ros1_conversion_replay_alike_with_default_flags_and_mount_from_tf() {
    let bag = data("ros2/mit-csail");
    let ros1 = folder(&prefix("ros1conv")).join("mit-csail.bag");
    rosbags_convert(&bag, &ros1, "lz4", &[]);
    let relations = data("freiburg/mit-csail/mit-csail.relations");
    let run = |name: &str, bag: &Path| {
        replay_recording(
            name,
            &[
                "rosbag",
                bag.to_str().unwrap(),
                "--relations",
                relations.to_str().unwrap(),
                "--particles",
                "5",
            ],
        )
    };
    let ((out, m, _), (ros1_out, _, _)) = std::thread::scope(|s| {
        let ros2 = s.spawn(|| run("rosbag", &bag));
        let ros1 = s.spawn(|| run("rosbag1", &ros1));
        (ros2.join().unwrap(), ros1.join().unwrap())
    });
    assert_mit_dead_reckoning(&m);
    let config = std::fs::read_to_string(out.join("service.toml")).unwrap();
    assert!(config.contains("mount"), "{config}");
    assert!(config.contains("model = \"increment\""), "{config}");
    assert_eq!(reproducible(&out), reproducible(&ros1_out));
}

#[test]
fn a_bag_without_odometry_is_refused_and_mapped_with_the_laser_s_odometry() {
    // The MIT CSAIL bag without its odometry (`/odom` and the odometry in `/tf`), written
    // by rosbags: only the scans and the laser's mounting are left.
    let bag = folder(&prefix("laseronly")).join("scans.bag");
    let drop_odometry = ["--exclude-topic", "/odom", "/tf"];
    rosbags_convert(&data("ros2/mit-csail"), &bag, "lz4", &drop_odometry);
    let bag = bag.to_str().unwrap();
    assert_refused("laseronly0", &["rosbag", bag], "--odometry laser");
    mapped_by_laser_odometry("laseronly1", bag, &[]);
}

/// Replays the MIT CSAIL scans of `bag` (with `flags`) on odometry made from them, five
/// particles, scored on the log's relations; checks the odometry made is well below the
/// wheels' 1.681 m on the same relations, and the map built on it within centimetres.
/// Returns the run folder.
fn mapped_by_laser_odometry(name: &str, bag: &str, flags: &[&str]) -> PathBuf {
    let relations = data("freiburg/mit-csail/mit-csail.relations");
    let relations = relations.to_str().unwrap();
    let common = [
        "--odometry",
        "laser",
        "--relations",
        relations,
        "--particles",
        "5",
    ];
    let args = [&["rosbag", bag][..], flags, &common].concat();
    let (out, m, _) = replay_recording(name, &args);
    let odometry = num(&m, "/dead_reckoning/relations/trans_mean_m");
    assert!(odometry < 0.5, "{odometry} m");
    for trajectory in ["estimate", "smoothed"] {
        let error = num(&m, &format!("/{trajectory}/relations/trans_mean_m"));
        assert!(error < 0.1, "{trajectory}: {error} m");
    }
    out
}

#[test]
fn a_3d_lidar_s_point_clouds_map_like_the_scans_they_hold() {
    // The MIT CSAIL bag as a 3D lidar on the laser's mounting would have recorded it
    // (rosbags writes each scan as three rings of points with the floor and the ceiling
    // nearer), without odometry.
    let bag = folder(&prefix("clouds")).join("clouds");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/scans_to_clouds.py");
    run_ok(
        "scans_to_clouds.py",
        Command::new(rosbags_bin().join("python3"))
            .arg(script)
            .arg(data("ros2/mit-csail"))
            .arg(&bag),
    );
    let bag = bag.to_str().unwrap();
    let out = mapped_by_laser_odometry("clouds1", bag, &["--scan-topic", "/points"]);
    let log = std::fs::read_to_string(out.join("logs/replay-recording.log")).unwrap();
    assert!(
        log.contains("1988 scans from /points (sensor_msgs/msg/PointCloud2 cut to scans"),
        "{log}"
    );
}

/// A failed replay: non-zero exit, one `error:` line naming `what`, no panic.
fn assert_refused(name: &str, args: &[&str], what: &str) {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let result = replay(&prefix, &dir.join("run"), args);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success(), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(errors[0].contains(what), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_no_leftovers(&prefix);
}

#[test]
fn a_log_with_a_bad_line_and_cut_short_replays_what_it_can_with_a_warning_for_each() {
    let prefix = prefix("damaged");
    let dir = folder(&prefix);
    std::fs::create_dir_all(&dir).unwrap();
    // MIT CSAIL's first 400 lines with a garbage line after line 100, gzipped, and the
    // stream cut at two thirds.
    let text = gzipped_text("freiburg/mit-csail/mit-csail.clf.gz");
    let mut lines: Vec<&str> = text.lines().take(400).collect();
    lines.insert(100, "FLASER 361 this is not a scan");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all((lines.join("\n") + "\n").as_bytes()).unwrap();
    let whole = gz.finish().unwrap();
    let log = dir.join("damaged.clf.gz");
    std::fs::write(&log, &whole[..whole.len() * 2 / 3]).unwrap();
    let (warnings, scans) = replay_damaged(&prefix, &dir, &["carmen", log.to_str().unwrap()]);
    let [bad, cut] = &warnings[..] else {
        panic!("two warnings: {warnings:?}");
    };
    assert!(
        bad.contains("1 malformed lines skipped") && bad.contains("damaged.clf.gz:101:"),
        "{bad}"
    );
    assert!(cut.contains("ends early after line"), "{cut}");
    assert!((150.0..399.0).contains(&scans), "{scans} scans scored");
}

#[test]
fn a_bag_cut_short_replays_the_messages_before_the_cut_with_a_warning() {
    let prefix = prefix("cutbag");
    let dir = folder(&prefix);
    std::fs::create_dir_all(&dir).unwrap();
    let bag = std::fs::read(data("ros2/mit-csail/mit-csail_mcap.mcap")).unwrap();
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bag[..bag.len() / 4]).unwrap();
    let (warnings, scans) = replay_damaged(&prefix, &dir, &["rosbag", cut.to_str().unwrap()]);
    let [warning] = &warnings[..] else {
        panic!("one warning: {warnings:?}");
    };
    assert!(
        warning.contains("cut.mcap: cut short inside a record"),
        "{warning}"
    );
    assert!((100.0..1000.0).contains(&scans), "{scans} scans scored");
}

/// Replays the damaged recording `args` names (5 particles) into `dir`, which must
/// succeed: its `warning:` lines and the number of poses scored.
fn replay_damaged(prefix: &str, dir: &Path, args: &[&str]) -> (Vec<String>, f64) {
    let args = [args, &["--particles", "5"]].concat();
    let result = replay(prefix, &dir.join("run"), &args);
    assert_success(&result);
    let stderr = String::from_utf8_lossy(&result.stderr);
    let warnings = (stderr.lines())
        .filter(|l| l.starts_with("warning:"))
        .map(str::to_owned)
        .collect();
    assert_no_leftovers(prefix);
    (warnings, num(&metrics(&dir.join("run")), "/estimate/poses"))
}

#[test]
fn broken_recordings_are_one_line_each() {
    let dir = folder(&prefix("broken"));
    std::fs::create_dir_all(&dir).unwrap();
    // A file with no CARMEN line: refused, with the first line that is not one.
    let garbage = dir.join("garbage.clf");
    std::fs::write(&garbage, "hello world\nFLASER 180 this is not a scan\n").unwrap();
    assert_refused(
        "garbage",
        &["carmen", garbage.to_str().unwrap()],
        "garbage.clf:1:",
    );
    // A bag cut short before its first message.
    let bag = std::fs::read(data("ros2/mit-csail/mit-csail_mcap.mcap")).unwrap();
    let cut_bag = dir.join("stub.mcap");
    std::fs::write(&cut_bag, &bag[..3000]).unwrap();
    assert_refused(
        "stubbag",
        &["rosbag", cut_bag.to_str().unwrap()],
        "stub.mcap",
    );
    // Relations need a recording's clock.
    assert_refused(
        "relnotrec",
        &["mrclam", "--relations", garbage.to_str().unwrap()],
        "--relations",
    );
}

/// The text of the gzipped data file at `relative` (under `data/`).
fn gzipped_text(relative: &str) -> String {
    let gz = std::fs::File::open(data(relative)).unwrap();
    std::io::read_to_string(flate2::read::MultiGzDecoder::new(gz)).unwrap()
}

/// MIT CSAIL's log rewritten with its laser off the base: only its FLASER lines are
/// kept, each as a ROBOTLASER1 line with the scan and the laser's pose as recorded and the
/// base at `laser ∘ mount⁻¹`, so the odometry is the base's.
fn mounted_log(mount: &Pose2, path: &Path) {
    let text = gzipped_text("freiburg/mit-csail/mit-csail.clf.gz");
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for fields in text
        .lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
    {
        if fields.first() != Some(&"FLASER") {
            continue;
        }
        let n: usize = fields[1].parse().unwrap();
        let number = |i: usize| -> f64 { fields[2 + n + i].parse().unwrap() };
        let laser = Pose2::new(number(0), number(1), number(2));
        let base = laser.compose(&mount.inverse());
        let (ranges, stamps) = (fields[2..2 + n].join(" "), fields[8 + n..].join(" "));
        let fov = std::f64::consts::PI;
        writeln!(
            out,
            "ROBOTLASER1 0 {:?} {fov:?} {:?} 81.91 0.01 0 {n} {ranges} 0 {:?} {:?} {:?} {:?} {:?} \
             {:?} 0 0 0.5 0.1 0 {stamps}",
            -fov / 2.0,
            fov / (n - 1) as f64,
            laser.x,
            laser.y,
            laser.theta,
            base.x,
            base.y,
            base.theta,
        )
        .unwrap();
    }
}

#[test]
fn a_laser_off_the_base_is_scored_by_the_laser_s_motions() {
    let dir = folder(&prefix("mountedlog"));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("mit-csail-mounted.clf");
    mounted_log(&Pose2::new(0.35, -0.12, 0.14), &log);
    let args = carmen_on_mit_relations(&log, 10);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    // The base's raw odometry moved onto the laser is the log's laser poses: the
    // published raw-odometry figure, and the estimates as good as without a mount.
    // (Ten particles: with five, seed 1 slips on this log, the laser's position being
    // the more uncertain for its lever on the base's heading.)
    let (out, m, _) = replay_recording("mounted", &args);
    assert_mit_dead_reckoning(&m);
    let client = std::fs::read_to_string(out.join("logs/client.log")).unwrap();
    let x_m = (client.split("x_m=").nth(1))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|x| x.parse::<f64>().ok());
    assert!(x_m.is_some_and(|x| (x - 0.35).abs() < 1e-6), "{client}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// ACES's log with a slip written into it: from `SLIP_START_S` after the first line, for
/// `SLIP_S`, its scans carry no reading (0, invalid) and its odometry turns by an extra
/// `SLIP_DEG`, spread evenly over that time (every pose from then on is turned about the
/// pose at the start), so the front end comes back to the building's start that far off.
/// Only the FLASER lines are kept.
fn slipped_aces(path: &Path) {
    const SLIP_START_S: f64 = 730.0;
    const SLIP_S: f64 = 60.0;
    const SLIP_DEG: f64 = 30.0;
    let text = gzipped_text("freiburg/aces/aces.clf.gz");
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let (mut first, mut pivot) = (None, None);
    for line in text.lines() {
        let mut fields: Vec<String> = line.split_whitespace().map(String::from).collect();
        if fields.first().map(String::as_str) != Some("FLASER") {
            continue;
        }
        let n: usize = fields[1].parse().unwrap();
        let stamp: f64 = fields[8 + n].parse().unwrap();
        let t = stamp - *first.get_or_insert(stamp);
        if t >= SLIP_START_S {
            let pose = |f: &[String], i: usize| {
                let v = |j: usize| f[i + j].parse::<f64>().unwrap();
                Pose2::new(v(0), v(1), v(2))
            };
            let pivot: Pose2 = *pivot.get_or_insert_with(|| pose(&fields, 5 + n));
            let turn = SLIP_DEG.to_radians() * ((t - SLIP_START_S) / SLIP_S).min(1.0);
            let turned = pivot
                .compose(&Pose2::new(0.0, 0.0, turn))
                .compose(&pivot.inverse());
            for at in [2 + n, 5 + n] {
                let p = turned.compose(&pose(&fields, at));
                fields[at..at + 3].clone_from_slice(&[p.x, p.y, p.theta].map(|v| format!("{v:?}")));
            }
            if t < SLIP_START_S + SLIP_S {
                fields[2..2 + n].fill("0".into());
            }
        }
        writeln!(out, "{}", fields.join(" ")).unwrap();
    }
}

#[test]
fn a_front_end_that_slipped_30_degrees_rejoins_the_map_by_the_wide_search() {
    let dir = folder(&prefix("slippedlog"));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("aces-slipped.clf");
    slipped_aces(&log);
    // The same settings with the wide search off.
    let profile = dir.join("no-wide-search.toml");
    let mut narrow = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("replay/profiles/planar-laser.toml"),
    )
    .unwrap();
    assert!(narrow.trim_end().ends_with("enabled = true"), "{narrow}");
    narrow.push_str("wide_search_every = 0\n");
    std::fs::write(&profile, narrow).unwrap();
    let relations = data("freiburg/aces/aces.relations");
    let args = ["carmen", log.to_str().unwrap(), "--relations"];
    let with_wide: Vec<&str> = [&args[..], &[relations.to_str().unwrap()]].concat();
    let without: Vec<&str> = [&with_wide[..], &["--profile", profile.to_str().unwrap()]].concat();
    let ((wide_out, wide, _), (_, usual, _)) = std::thread::scope(|s| {
        let wide = s.spawn(|| replay_recording("slipwide", &with_wide));
        let usual = s.spawn(|| replay_recording("slipusual", &without));
        (wide.join().unwrap(), usual.join().unwrap())
    });
    let error = |m: &serde_json::Value| num(m, "/smoothed/relations/trans_mean_m");
    println!(
        "final trajectory with the wide search {:.4} m, without it {:.4} m",
        error(&wide),
        error(&usual)
    );
    // Seed 1, the default: 0.126 m with the wide search, 0.864 m without; the log as
    // recorded gives 0.046 m, and the relations across the minute without scans stay
    // off. (Seeds 2 and 3 get back without it too: 0.064 and 0.051 m.)
    assert!(error(&wide) < 0.25, "with the wide search: {wide}");
    assert!(error(&usual) > 0.4, "without it: {usual}");
    let service = std::fs::read_to_string(wide_out.join("logs/service.log")).unwrap();
    assert!(
        service.contains("wide loop-closure search matched"),
        "{service}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
