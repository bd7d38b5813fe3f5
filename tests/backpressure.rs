//! As fast as possible nothing is dropped and nothing depends on the wall clock: a
//! stream whose queue in the service is full waits in shared memory (its publisher
//! waits) instead of losing its oldest input, and no sensor deadline applies.

mod common;

use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Seconds of data kept, and the stretch without a single observation inside them.
const KEPT_S: f64 = 400.0;
const BLIND_S: std::ops::Range<f64> = 50.0..350.0;

/// The first 400 s of MRCLAM robot 1, whose camera sees nothing from 50 s to 350 s (some
/// 30,000 odometry records between two observations), written as a data set in `dir`.
fn blind_stretch(dir: &Path) -> PathBuf {
    mrclam_clip(
        &dir.join("blind"),
        |t| t < KEPT_S,
        |t| !BLIND_S.contains(&t),
    )
}

#[test]
fn a_long_blind_stretch_with_a_small_queue_loses_nothing_and_repeats_exactly() {
    let prefix = prefix("blind");
    let dir = folder(&prefix);
    let data = blind_stretch(&dir);
    let config = dir.join("service.toml");
    std::fs::write(&config, "[input]\nmax_queue = 256\n").unwrap();
    let mut runs = Vec::new();
    for k in 0..3 {
        let out = dir.join(format!("run{k}"));
        let result = Command::new(LAUNCHER)
            .args(["replay", "mrclam", "--data"])
            .arg(&data)
            .arg("--config")
            .arg(&config)
            .args(["--prefix", &prefix, "--timeout-s", "600", "--out"])
            .arg(&out)
            .output()
            .expect("starting the launcher");
        assert_success(&result);
        let m = metrics(&out);
        assert_eq!(
            num(&m, "/inputs/rejected_total"),
            0.0,
            "run {k} dropped or rejected inputs: {m}"
        );
        assert!(num(&m, "/estimate/poses") > 50.0, "{m}");
        let log = std::fs::read_to_string(out.join("logs/service.log")).unwrap();
        assert!(
            !log.contains("degraded"),
            "a deadline fired as fast as possible: {log}"
        );
        runs.push(reproducible(&out));
    }
    assert_eq!(runs[0], runs[1], "runs 0 and 1 differ");
    assert_eq!(runs[0], runs[2], "runs 0 and 2 differ");
    assert_no_leftovers_and_remove(&prefix, &dir);
}
