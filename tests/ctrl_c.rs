//! Ctrl-C on the launcher stops every process of the stack and removes its shared memory.

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
