//! Runs that cannot mean anything fail, with one line saying why: a run with no pose
//! estimate, a timeout of nothing.

mod common;

use common::*;

/// A scenario in `dir` whose vehicle never moves: the first waypoint is already within
/// reach, and the route ends before the first scan.
fn standstill(dir: &std::path::Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(short_scenario(dir)).unwrap();
    let scenario = dir.join("standstill.toml");
    std::fs::write(
        &scenario,
        text.replace("switch_distance_m = 1.0", "switch_distance_m = 1000.0"),
    )
    .unwrap();
    scenario
}

#[test]
fn a_run_without_a_pose_is_a_failure_with_one_line() {
    let prefix = prefix("noposes");
    let dir = folder(&prefix);
    let scenario = standstill(&dir);
    let out = dir.join("run");
    let run = run_stack(
        &prefix,
        &out,
        &["--scenario", &scenario.display().to_string()],
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "one error line: {stderr}");
    assert!(
        errors[0].contains("without a pose estimate"),
        "says why: {stderr}"
    );
    assert_eq!(metrics(&out)["complete"], true, "every stream ended");
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_standalone_client_fails_a_run_without_a_pose_with_one_line() {
    let prefix = prefix("clientnopose");
    let dir = folder(&prefix);
    let scenario = standstill(&dir).display().to_string();
    let out = dir.join("run");
    let mut stack = HandStack::new(&prefix, dir.join("logs"));
    let sim = |subscribers| ["--scenario", &scenario, "--wait-subscribers", subscribers];
    stack.start("client", &["--out", &out.display().to_string()]);
    stack.start("service", &["--wait-subscribers", "1"]);
    stack.start("odometry-sim", &sim("2"));
    stack.start("lidar-sim", &sim("2"));
    stack.start("truth-sim", &sim("3"));
    let statuses = stack.wait_all(std::time::Duration::from_secs(120));
    let client = statuses
        .iter()
        .find(|(name, _)| *name == "client")
        .unwrap()
        .1;
    assert_eq!(client.code(), Some(1), "logs in {}", dir.display());
    let log = std::fs::read_to_string(dir.join("logs").join("client.0.log")).unwrap();
    let errors: Vec<&str> = log.lines().filter(|l| l.contains("error:")).collect();
    assert_eq!(errors.len(), 1, "one error line: {log}");
    assert!(errors[0].contains("without a pose estimate"), "{log}");
    assert_eq!(metrics(&out)["complete"], true, "every stream ended");
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_timeout_of_zero_seconds_is_refused_before_anything_starts() {
    let dir = folder(&prefix("timeout0"));
    let out = dir.join("run");
    for timeout in ["0", "-1", "nan"] {
        let refused = std::process::Command::new(LAUNCHER)
            .args(["run", "--scenario", "bailey-short"])
            .arg(format!("--timeout-s={timeout}"))
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success(), "--timeout-s {timeout}: {stderr}");
        assert!(stderr.contains("positive number of seconds"), "{stderr}");
        assert!(!out.exists(), "the launcher made its run folder");
    }
    std::fs::remove_dir_all(dir).ok();
}
