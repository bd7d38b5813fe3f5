//! A stack belongs to its launcher: it dies with it, whatever kills the launcher; the
//! next run on the prefix cleans what it left; and while it runs, nobody else's stack
//! can start on its prefix.

mod common;

use common::*;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Starts `fastslam-stack run` on the short route in real time under `prefix` (a run long
/// enough to be killed in mid-run), and waits until its service runs.
fn start_realtime(prefix: &str, out: &Path, scenario: &Path) -> Child {
    let launcher = Command::new(LAUNCHER)
        .args([
            "run",
            "--prefix",
            prefix,
            "--realtime",
            "--timeout-s",
            "120",
        ])
        .arg("--scenario")
        .arg(scenario)
        .arg("--out")
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starting the launcher");
    let service_log = out.join("logs").join("service.log");
    wait_for("the service to run", Duration::from_secs(30), || {
        std::fs::read_to_string(&service_log).is_ok_and(|log| log.contains("running"))
    });
    launcher
}

/// True while process `pid` exists and is not a zombie (a dead child nobody reaped).
fn alive(pid: i32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|stat| Some(stat.rsplit_once(") ")?.1.starts_with('Z')))
        .is_some_and(|zombie| !zombie)
}

#[test]
fn a_stack_dies_with_its_sigkilled_launcher_and_the_next_run_leaves_nothing() {
    let prefix = prefix("orphans");
    let dir = folder(&prefix);
    let scenario = short_scenario(&dir);
    let mut launcher = start_realtime(&prefix, &dir.join("killed"), &scenario);
    let launcher_pid = launcher.id() as i32;
    let children: Vec<i32> = stack_processes(&prefix)
        .into_iter()
        .map(|(pid, _)| pid)
        .filter(|&pid| pid != launcher_pid)
        .collect();
    assert_eq!(children.len(), 5, "the stack's five processes run");
    kill(Pid::from_raw(launcher_pid), Signal::SIGKILL).unwrap();
    launcher.wait().unwrap();
    wait_for(
        "every process of the stack to end with its launcher",
        Duration::from_secs(2),
        || children.iter().all(|&pid| !alive(pid)),
    );
    // The next run on the prefix starts (the dead launcher's hold is gone), finishes and
    // removes what both stacks left.
    let out = dir.join("next");
    let next = run_stack(
        &prefix,
        &out,
        &["--scenario", &scenario.display().to_string()],
    );
    assert_success(&next);
    assert_eq!(metrics(&out)["complete"], true);
    let summary = String::from_utf8_lossy(&next.stdout);
    assert!(
        !summary.contains("dropped or rejected"),
        "nothing was rejected: {summary}"
    );
    assert!(!fastslam_stack::stack_root(&prefix).exists(), "root left");
    assert!(!fastslam_stack::stack_lock(&prefix).exists(), "lock left");
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_second_stack_on_a_prefix_in_use_is_refused_before_it_starts_anything() {
    let prefix = prefix("owned");
    let dir = folder(&prefix);
    let scenario = short_scenario(&dir);
    let first = start_realtime(&prefix, &dir.join("first"), &scenario);
    let second_out = dir.join("second");
    let second = run_stack(
        &prefix,
        &second_out,
        &["--scenario", &scenario.display().to_string()],
    );
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "the second stack ran: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr.contains(&format!("stack prefix {prefix} is in use")),
        "{stderr}"
    );
    assert!(
        !second_out.exists(),
        "the second launcher made its run folder"
    );
    assert_eq!(
        stack_processes(&prefix).len(),
        6,
        "the first launcher and its five processes, and nothing else"
    );
    kill(Pid::from_raw(first.id() as i32), Signal::SIGINT).unwrap();
    let first = first.wait_with_output().unwrap();
    assert_eq!(
        first.status.code(),
        Some(130),
        "the first stack, interrupted"
    );
    assert!(!fastslam_stack::stack_lock(&prefix).exists(), "lock left");
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_bad_prefix_is_refused_before_anything_starts() {
    let dir = folder(&prefix("badprefix"));
    let out = dir.join("run");
    let bad = "no/such prefix";
    let refused = run_stack(bad, &out, &["--scenario", "bailey-short"]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains(bad), "names the prefix: {stderr}");
    assert!(!out.exists(), "the launcher made its run folder");
    std::fs::remove_dir_all(dir).ok();
}
