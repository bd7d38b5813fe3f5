//! Recorded data through the real processes: `fastslam-stack replay` starts the data
//! set's replay process, the FastSLAM service and the client; the tests judge what the
//! client recorded.
//!
//! MRCLAM's truth (Vicon) and Victoria Park's (GPS) live in frames the filter cannot know
//! (MRCLAM robot 1's heading drifts unobserved for 35 s before it maps most landmarks),
//! so the profiles make the client align each trajectory onto the truth (least-squares
//! SE(2)) before scoring, and the tests judge the client's aligned ATE.

mod common;

use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

/// Runs `fastslam-stack replay <args>` under `prefix` into `out`; fails the test with the
/// launcher's output unless it finished.
fn replay(prefix: &str, out: &Path, args: &[&str]) -> serde_json::Value {
    let result = Command::new(LAUNCHER)
        .arg("replay")
        .args(args)
        .args(["--prefix", prefix, "--timeout-s", "600", "--out"])
        .arg(out)
        .output()
        .expect("starting the launcher");
    assert_success(&result);
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        stdout.contains("ATE RMSE")
            && (stdout.contains("landmark RMSE") || stdout.contains("no true landmarks")),
        "{stdout}"
    );
    assert_eq!(
        leftovers(prefix),
        (vec![], vec![]),
        "processes or shared memory left"
    );
    let m = metrics(out);
    assert_eq!(m["complete"], true, "{m}");
    assert_eq!(m["alignment"]["method"], "se2", "the profile aligns: {m}");
    m
}

/// Replays data set `set` from the repository's `data/<folder>` with `flags`, under a
/// fresh prefix named after `name` ([`replay`]); the test's folder, the run folder and
/// the metrics.
fn replay_data(
    name: &str,
    set: &str,
    folder_name: &str,
    flags: &[&str],
) -> (PathBuf, PathBuf, serde_json::Value) {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let out = dir.join("run");
    let data = data(folder_name);
    let args = [&[set, "--data", data.to_str().unwrap()][..], flags].concat();
    let m = replay(&prefix, &out, &args);
    (dir, out, m)
}

/// The client's aligned ATE RMSE of the estimate and of dead reckoning (m).
fn ates(m: &serde_json::Value) -> (f64, f64) {
    (
        num(m, "/estimate/ate_rmse_m"),
        num(m, "/dead_reckoning/ate_rmse_m"),
    )
}

fn mrclam(association: &str) -> (serde_json::Value, f64, f64) {
    let (dir, _, m) = replay_data(
        &format!("mrclam{association}"),
        "mrclam",
        "mrclam7",
        &["--association", association],
    );
    // One estimate per camera frame with a landmark in it.
    assert!(num(&m, "/estimate/poses") > 1500.0, "{m}");
    assert_eq!(
        num(&m, "/map/truth"),
        15.0,
        "the true landmarks arrived: {m}"
    );
    assert_eq!(
        m["filter"]["unknown_association"],
        association == "unknown",
        "the service's status says how it associates: {m}"
    );
    let (estimate, dead_reckoning) = ates(&m);
    std::fs::remove_dir_all(&dir).ok();
    (m, estimate, dead_reckoning)
}

#[test]
fn mrclam_with_barcodes_as_ids_beats_dead_reckoning_and_maps_each_landmark_once() {
    let (m, estimate, dead_reckoning) = mrclam("known");
    assert_eq!(
        num(&m, "/map/estimated"),
        15.0,
        "one landmark per barcode: {m}"
    );
    assert!(
        estimate < 0.5 * dead_reckoning,
        "ATE {estimate} m vs dead reckoning {dead_reckoning} m"
    );
}

#[test]
fn mrclam_with_unknown_association_beats_dead_reckoning() {
    let (m, estimate, dead_reckoning) = mrclam("unknown");
    assert!(num(&m, "/map/estimated") >= 10.0, "{m}");
    assert!(
        estimate < 0.5 * dead_reckoning,
        "ATE {estimate} m vs dead reckoning {dead_reckoning} m"
    );
}

#[test]
fn victoria_park_follows_the_gps_loop_far_better_than_dead_reckoning() {
    let (dir, _, m) = replay_data("victoriapark", "victoria-park", "victoria_park", &[]);
    assert_eq!(num(&m, "/map/truth"), 0.0, "no true tree map: {m}");
    assert!(num(&m, "/map/estimated") > 50.0, "trees mapped: {m}");
    // Every laser scan made an observation step, and the scoring is at the GPS fixes.
    assert_eq!(num(&m, "/filter/steps"), 7249.0, "{m}");
    assert_eq!(m["scored_at"], "truth", "{m}");
    assert!(
        num(&m, "/estimate/poses") > 4000.0,
        "GPS fixes compared: {m}"
    );
    let (estimate, dead_reckoning) = ates(&m);
    assert!(
        estimate < 20.0 && estimate < 0.2 * dead_reckoning,
        "ATE at the GPS points {estimate} m vs dead reckoning {dead_reckoning} m"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn victoria_park_raw_scans_matched_against_particle_grids_beat_dead_reckoning() {
    // Grid FastSLAM on the raw scans; ten particles drawn from the motion prior keep the
    // run short.
    let (dir, out, m) = replay_data(
        "victoriaraw",
        "victoria-park",
        "victoria_park",
        &[
            "--profile",
            "victoria-park-scans",
            "--particles",
            "10",
            "--optimizer",
            "none",
        ],
    );
    let settings = std::fs::read_to_string(out.join("service.toml")).unwrap();
    assert!(settings.contains("kind = \"grid\""), "{settings}");
    // Every raw scan of the release made a filter step; the map is a grid.
    assert_eq!(num(&m, "/filter/steps"), 7230.0, "{m}");
    assert_eq!(num(&m, "/map/estimated"), 0.0, "no landmarks: {m}");
    for file in ["map.pgm", "map.yaml"] {
        assert!(out.join(file).is_file(), "{file} in the run folder");
    }
    let (estimate, dead_reckoning) = ates(&m);
    assert!(
        estimate < 0.5 * dead_reckoning,
        "ATE at the GPS points {estimate} m vs dead reckoning {dead_reckoning} m"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_data_folder_or_profile_is_reported_with_its_reason() {
    let prefix = prefix("replaybad");
    let dir = folder(&prefix);
    let run = |args: &[&str]| {
        Command::new(LAUNCHER)
            .arg("replay")
            .args(args)
            .args(["--prefix", &prefix, "--out"])
            .arg(dir.join("run"))
            .output()
            .unwrap()
    };
    let missing = run(&["mrclam", "--data", "/no/such/folder"]);
    assert!(!missing.status.success());
    let err = String::from_utf8_lossy(&missing.stderr);
    assert!(err.contains("/no/such/folder"), "{err}");
    let mrclam = data("mrclam7");
    let profile = run(&[
        "mrclam",
        "--data",
        mrclam.to_str().unwrap(),
        "--profile",
        "nope",
    ]);
    assert!(!profile.status.success());
    let err = String::from_utf8_lossy(&profile.stderr);
    assert!(
        err.contains("nope") && err.contains("victoria-park"),
        "{err}"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn lines_a_data_set_cannot_use_are_skipped_with_one_warning_per_file() {
    use std::io::Write;
    let prefix = prefix("replayskip");
    let dir = folder(&prefix);
    let copy = dir.join("mrclam7");
    std::fs::create_dir_all(&copy).unwrap();
    for file in std::fs::read_dir(data("mrclam7")).unwrap() {
        let file = file.unwrap().path();
        std::fs::copy(&file, copy.join(file.file_name().unwrap())).unwrap();
    }
    // A second gzip member after the recorded one: a line that is no record, and a
    // sighting with a negative range.
    let measurements = copy.join("Robot1_Measurement.dat.gz");
    let file = std::fs::OpenOptions::new()
        .append(true)
        .open(&measurements)
        .unwrap();
    let mut member = flate2::write::GzEncoder::new(file, flate2::Compression::fast());
    member
        .write_all(b"garbage\n9999999999.0 14 -1.0 0.0\n")
        .unwrap();
    member.finish().unwrap();
    let result = Command::new(LAUNCHER)
        .args(["replay", "mrclam", "--data"])
        .arg(&copy)
        .args(["--prefix", &prefix, "--timeout-s", "600", "--out"])
        .arg(dir.join("run"))
        .output()
        .unwrap();
    assert_success(&result);
    let err = String::from_utf8_lossy(&result.stderr);
    let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(
        warnings[0].contains("Robot1_Measurement.dat.gz: 2 lines skipped")
            && warnings[0].contains("expected 4 columns, found 1: `garbage`")
            && warnings[0].contains("range must be > 0, got -1"),
        "{err}"
    );
    assert_eq!(metrics(&dir.join("run"))["complete"], true);
    assert_no_leftovers_and_remove(&prefix, &dir);
}
