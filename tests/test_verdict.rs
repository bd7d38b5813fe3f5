//! `fastslam-stack test` passes no run that lost inputs, and stops what it started. A
//! publisher that sends its odometry well ahead of its scans (`tests/python/odometry_ahead.py`),
//! as fast as possible (`test`'s default): well within the service's input queue (4096)
//! nothing is dropped and the run passes; beyond a small one (the publisher waits on a
//! full odometry buffer with no scan sent, so the service takes the odometry as passed)
//! the early scans are refused as late, and the run fails naming them unless the user's
//! own expectation on `inputs.rejected_total` replaces the default. A publisher that ignores SIGTERM is gone
//! once `test` returns, a grace period after its timeout.

mod common;

use common::*;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// A small input queue, which the odometry sent ahead (and its subscriber buffer of 256)
/// exceeds within seconds of data.
const SMALL_QUEUE: usize = 32;

/// Runs `test` on `odometry_ahead.py --ahead <ahead>` with `extra` flags, the run in
/// `dir/out`: the Python example's service settings, with `max_queue` when given.
fn test_ahead(dir: &Path, ahead: usize, max_queue: Option<usize>, extra: &[&str]) -> Output {
    let python = python_with_iceoryx2();
    let settings = dir.join("settings.toml");
    let mut toml = include_str!("../examples/python/service.toml").to_string();
    if let Some(n) = max_queue {
        toml += &format!("[input]\nmax_queue = {n}\n");
    }
    std::fs::write(&settings, toml).unwrap();
    Command::new(LAUNCHER)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["test", "--config"])
        .arg(&settings)
        .arg("--publisher")
        .arg(format!(
            "'{}' tests/python/odometry_ahead.py --ahead {ahead}",
            python.display()
        ))
        .args(["--timeout-s", "300", "--out"])
        .arg(dir.join("out"))
        .args(extra)
        .output()
        .expect("starting the launcher")
}

/// What a launcher said, for a failed assertion.
fn said(out: &Output) -> String {
    format!(
        "status {}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

#[test]
fn odometry_well_within_the_input_queue_loses_nothing_and_passes() {
    let dir = folder(&prefix("ahead_within"));
    let map = dir.join("map.csv");
    let save_map = format!("--service-flag=--save-map={}", map.display());
    let result = test_ahead(&dir, 20, None, &[&save_map]);
    assert_eq!(result.status.code(), Some(0), "{}", said(&result));
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        stdout.contains("✓ inputs.rejected_total == 0"),
        "{}",
        said(&result)
    );
    let m = metrics(&dir.join("out/run"));
    assert_eq!(m["inputs"]["rejected_total"], 0, "{m}");
    // 60 s at 5 Hz: every scan gave a pose.
    assert_eq!(m["estimate"]["poses"], 300, "{m}");
    // The service flag went through: the service saved its map.
    assert!(map.is_file(), "no {}: {}", map.display(), said(&result));
    assert_no_leftovers_and_remove(&announced_prefix(&result), &dir);
}

#[test]
fn odometry_ahead_beyond_a_small_input_queue_fails_naming_the_late_scans() {
    let dir = folder(&prefix("ahead_beyond"));
    let result = test_ahead(&dir, 600, Some(SMALL_QUEUE), &[]);
    assert_eq!(result.status.code(), Some(1), "{}", said(&result));
    let m = metrics(&dir.join("out/run"));
    // At least the scans older than the odometry the service had to take before the
    // publisher could send a scan: (600 - 256 - 32) odometry periods, 4 per scan.
    let late = m["inputs"]["rejected"]["late"].as_u64().unwrap();
    assert!(late >= 78, "{m}");
    assert_eq!(m["inputs"]["rejected_total"], late, "{m}");
    let stderr = String::from_utf8_lossy(&result.stderr);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("error")).collect();
    assert_eq!(
        errors,
        [format!(
            "error: failed expectations: inputs.rejected_total == 0 (measured {late})"
        )],
        "{}",
        said(&result)
    );
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        stdout.contains(&format!("rejected {late} inputs (late {late})")),
        "{}",
        said(&result)
    );
    assert_no_leftovers(&announced_prefix(&result));

    // The user's own expectation on the figure replaces the default.
    let again = folder(&prefix("ahead_expected"));
    let expected = test_ahead(
        &again,
        600,
        Some(SMALL_QUEUE),
        &["--expect", "inputs.rejected_total > 0"],
    );
    assert_eq!(expected.status.code(), Some(0), "{}", said(&expected));
    let stdout = String::from_utf8_lossy(&expected.stdout);
    assert!(
        stdout.contains("✓ inputs.rejected_total > 0")
            && !stdout.contains("inputs.rejected_total == 0"),
        "{}",
        said(&expected)
    );
    assert_no_leftovers_and_remove(&announced_prefix(&expected), &again);
    std::fs::remove_dir_all(&dir).ok();
}

/// True while process `pid` exists and is not a zombie.
fn alive(pid: i32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
        stat.rsplit(')')
            .next()
            .is_some_and(|s| !s.trim_start().starts_with('Z'))
    })
}

#[test]
fn a_publisher_that_ignores_sigterm_is_gone_a_grace_period_after_the_timeout() {
    let dir = folder(&prefix("hung_publisher"));
    let pids = dir.join("pids");
    // The shell and the sleep it started both ignore SIGTERM.
    let publisher = format!(
        "trap '' TERM; echo $$ > '{0}'; sleep 600 & echo $! >> '{0}'; wait",
        pids.display()
    );
    let started = Instant::now();
    let result = Command::new(LAUNCHER)
        .args([
            "test",
            "--publisher",
            &publisher,
            "--timeout-s",
            "4",
            "--out",
        ])
        .arg(dir.join("out"))
        .output()
        .expect("starting the launcher");
    let took = started.elapsed();
    assert_eq!(result.status.code(), Some(1), "{}", said(&result));
    assert!(
        String::from_utf8_lossy(&result.stderr).contains("still running after 4s"),
        "{}",
        said(&result)
    );
    let pids: Vec<i32> = std::fs::read_to_string(&pids)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect();
    assert_eq!(pids.len(), 2, "{pids:?}");
    for pid in pids {
        assert!(
            !alive(pid),
            "process {pid} of the publisher outlived `test`"
        );
    }
    // The timeout, the grace period (5 s), and ample time to start and stop the stack.
    assert!(took < Duration::from_secs(4 + 5 + 60), "{took:?}");
    assert_no_leftovers_and_remove(&announced_prefix(&result), &dir);
}
