//! Ctrl-C on the launcher stops every process of the stack and removes its shared memory;
//! so does its timeout, which names the processes still running.

mod common;

use common::*;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn ctrl_c_leaves_no_process_and_no_shared_memory() {
    let prefix = prefix("ctrl_c");
    let dir = folder(&prefix);
    // Real-time pacing: the run would take minutes, so it is surely still going.
    let mut launcher = Command::new(LAUNCHER)
        .args([
            "run",
            "--realtime",
            "--scenario",
            "bailey-webmap",
            "--prefix",
            &prefix,
            "--out",
        ])
        .arg(dir.join("run"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // Wait until the stack is up: every process has created its node (shared memory).
    while leftovers(&prefix).0.len() < 6 || leftovers(&prefix).1.is_empty() {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "stack did not start: {:?}",
            leftovers(&prefix)
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_millis(500));
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(launcher.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .unwrap();
    let status = launcher.wait().unwrap();
    assert_eq!(status.code(), Some(130), "interrupted runs exit 130");
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "stopping took {:?}",
        start.elapsed()
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_timeout_names_the_processes_still_running_and_their_last_log_lines() {
    let prefix = prefix("timeout");
    let dir = folder(&prefix);
    // Real time: the short route takes 14 s, far past the 2 s allowed.
    let out = Command::new(LAUNCHER)
        .args(["run", "--realtime", "--scenario"])
        .arg(short_scenario(&dir))
        .args(["--prefix", &prefix, "--timeout-s", "2", "--out"])
        .arg(dir.join("run"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = (stderr.lines())
        .find(|l| l.starts_with("timed out with "))
        .unwrap_or_else(|| panic!("{stderr}"));
    for name in ["truth-sim", "service", "client"] {
        assert!(line.contains(name), "{stderr}");
        let said = format!("the {name}'s log ends with:");
        assert!(stderr.contains(&said), "{stderr}");
    }
    assert_no_leftovers_and_remove(&prefix, &dir);
}
