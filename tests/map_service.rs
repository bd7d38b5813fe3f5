//! The `map/get` request–response service through the real processes: `map-get` asks a
//! running stack for its map mid-run and gets a plausible one; with no service there it
//! fails in one line.

mod common;

use common::*;
use fastslam_service::map_file;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// `fastslam-stack map-get` on the stack `prefix` (root as the launcher sets it).
fn map_get(prefix: &str, out: &std::path::Path, timeout_s: &str) -> Output {
    let root = fastslam_stack::stack_root(prefix);
    Command::new(LAUNCHER)
        .args(["map-get", "--prefix", prefix, "--iox-root"])
        .arg(&root)
        .arg("--out")
        .arg(out)
        .args(["--timeout-s", timeout_s])
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .expect("starting map-get")
}

#[test]
fn map_get_returns_the_current_map_of_a_running_stack() {
    let prefix = prefix("mapget");
    let dir = folder(&prefix);
    let run = dir.join("run");
    // Real-time pacing keeps the service alive long enough to be asked; the short route
    // (12 s) bounds how long the launcher runs on once the service has stopped.
    let launcher = Command::new(LAUNCHER)
        .args(["run", "--scenario"])
        .arg(short_scenario(&dir))
        .arg("--realtime")
        .args(["--prefix", &prefix, "--timeout-s", "120", "--out"])
        .arg(&run)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let got = dir.join("got.csv");
    // Ask until the service has mapped something (it starts with an empty map).
    let printed = std::cell::Cell::new(0);
    wait_for(
        "a non-empty map from map-get",
        Duration::from_secs(60),
        || {
            let out = map_get(&prefix, &got, "10");
            let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
            assert!(
                out.status.success(),
                "map-get failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            let count: usize = stdout
                .split_whitespace()
                .next()
                .and_then(|n| n.parse().ok())
                .unwrap_or_else(|| panic!("map-get prints the landmark count: {stdout}"));
            printed.set(count);
            std::thread::sleep(Duration::from_millis(500));
            count > 0
        },
    );
    let mid_run = map_file::load(&got).expect("map-get writes a map that loads");
    assert_eq!(mid_run.len(), printed.get(), "the printed count");
    // Stop early (SIGTERM): the service finishes cleanly and the client writes its map.
    stop_service_and_wait(&prefix, launcher);
    let last = map_file::load(&run.join("map.csv")).expect("the client's final map");
    assert!(
        !mid_run.is_empty() && mid_run.len() <= last.len(),
        "{} landmarks mid-run, {} at the end",
        mid_run.len(),
        last.len()
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn map_get_without_a_service_fails_with_one_line() {
    let prefix = prefix("mapgetnone");
    let dir = folder(&prefix);
    let out = map_get(&prefix, &dir.join("got.csv"), "0.5");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().filter(|l| l.contains("rror")).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(
        lines[0].contains("no FastSLAM service answered"),
        "{stderr}"
    );
    assert!(!dir.join("got.csv").exists(), "no file without an answer");
    let root = fastslam_stack::stack_root(&prefix);
    assert!(!root.exists(), "the iceoryx2 root it created is removed");
    assert_no_leftovers_and_remove(&prefix, &dir);
}
