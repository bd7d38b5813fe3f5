//! Expectations on the metrics (`--expect`), the JUnit report (`--junit`) and
//! `fastslam-stack test` on a publisher of one's own, through the real processes: a run
//! that meets its expectations exits 0, one that misses them exits 1 naming what failed,
//! and a bad expression is refused before anything starts.

mod common;

use common::*;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The test cases of a JUnit report, parsed with an independent XML parser: each one's
/// name and its failure message, if it failed.
fn junit_cases(path: &Path) -> Vec<(String, Option<String>)> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{e}:\n{text}"));
    doc.descendants()
        .filter(|n| n.has_tag_name("testcase"))
        .map(|case| {
            let failure = case
                .children()
                .find(|c| c.has_tag_name("failure"))
                .map(|f| f.attribute("message").unwrap_or_default().to_string());
            (
                case.attribute("name").unwrap_or_default().to_string(),
                failure,
            )
        })
        .collect()
}

/// The launcher's stdout and stderr, for a failure message.
fn output(out: &Output) -> String {
    format!(
        "status {}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The number after `measured ` in `text`.
fn measured(text: &str) -> f64 {
    text.split("measured ")
        .nth(1)
        .and_then(|rest| rest.split([')', ',', ' ', ';']).next()?.parse().ok())
        .unwrap_or_else(|| panic!("no measured value in {text}"))
}

#[test]
fn a_run_meets_its_expectations_or_exits_1_naming_the_failed_one() {
    let prefix = prefix("expect_run");
    let dir = folder(&prefix);
    let scenario = short_scenario(&dir);
    let scenario = scenario.to_str().unwrap();
    let quick = ["--scenario", scenario, "--particles", "20"];

    let (out, junit) = (dir.join("pass"), dir.join("pass.xml"));
    let pass = run_stack(
        &prefix,
        &out,
        &[
            &quick[..],
            &[
                "--expect",
                "estimate.ate_rmse_m < 100",
                "--expect",
                "estimate.poses >= 10",
            ],
            &["--junit", junit.to_str().unwrap()],
        ]
        .concat(),
    );
    assert_success(&pass);
    let stdout = String::from_utf8_lossy(&pass.stdout);
    let ate = num(&metrics(&out), "/estimate/ate_rmse_m");
    assert!(stdout.contains("✓ every stream ended"), "{}", output(&pass));
    let line = (stdout.lines())
        .find(|l| l.contains("✓ estimate.ate_rmse_m < 100"))
        .unwrap_or_else(|| panic!("no line for the expectation: {}", output(&pass)));
    assert!(
        (measured(line) - ate).abs() <= 1e-5 * ate,
        "{line} vs {ate}"
    );
    let cases = junit_cases(&junit);
    let names: Vec<&str> = cases.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "every stream ended",
            "estimate.ate_rmse_m < 100",
            "estimate.poses >= 10"
        ]
    );
    assert!(cases.iter().all(|(_, f)| f.is_none()), "{cases:?}");

    let (out, junit) = (dir.join("fail"), dir.join("fail.xml"));
    let fail = run_stack(
        &prefix,
        &out,
        &[
            &quick[..],
            &[
                "--expect",
                "estimate.ate_rmse_m < 0.001",
                "--expect",
                "estimate.poses >= 10",
            ],
            &["--junit", junit.to_str().unwrap()],
        ]
        .concat(),
    );
    assert_eq!(fail.status.code(), Some(1), "{}", output(&fail));
    let stderr = String::from_utf8_lossy(&fail.stderr);
    let error: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(error.len(), 1, "{}", output(&fail));
    assert!(
        error[0].starts_with("error: failed expectations: estimate.ate_rmse_m < 0.001 (measured "),
        "{}",
        error[0]
    );
    assert!(
        !error[0].contains("poses"),
        "only the failed one: {}",
        error[0]
    );
    let ate = num(&metrics(&out), "/estimate/ate_rmse_m");
    assert!(
        (measured(error[0]) - ate).abs() <= 1e-5 * ate,
        "{} vs {ate}",
        error[0]
    );
    let stdout = String::from_utf8_lossy(&fail.stdout);
    assert!(
        stdout.contains("✗ estimate.ate_rmse_m < 0.001") && stdout.contains("ATE RMSE"),
        "{}",
        output(&fail)
    );
    let cases = junit_cases(&junit);
    assert_eq!(cases.len(), 3, "{cases:?}");
    assert_eq!(cases[0], ("every stream ended".into(), None));
    assert_eq!(cases[2], ("estimate.poses >= 10".into(), None));
    let failure = cases[1].1.as_deref().expect("the ATE case failed");
    assert_eq!(cases[1].0, "estimate.ate_rmse_m < 0.001");
    assert!(
        (measured(failure) - ate).abs() <= 1e-5 * ate,
        "{failure} vs {ate}"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_bad_expectation_is_refused_before_anything_starts() {
    let prefix = prefix("expect_bad");
    let dir = folder(&prefix);
    let bad = [
        "--expect",
        "nonsense.path < 1",
        "--expect",
        "estimate.ate_rmse_m <",
    ];
    let out = dir.join("run");
    let started = Instant::now();
    let commands: [Vec<&str>; 4] = [
        vec!["run", "--prefix", &prefix, "--out", out.to_str().unwrap()],
        vec![
            "replay",
            "mrclam",
            "--prefix",
            &prefix,
            "--out",
            out.to_str().unwrap(),
        ],
        vec![
            "test",
            "--publisher",
            "sleep 100",
            "--out",
            out.to_str().unwrap(),
        ],
        // The client alone would otherwise wait a minute for the stack's publishers.
        vec![
            "client",
            "--prefix",
            &prefix,
            "--out",
            out.to_str().unwrap(),
        ],
    ];
    for command in commands {
        let result = Command::new(LAUNCHER)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&command)
            .args(bad)
            .output()
            .unwrap();
        assert_eq!(
            result.status.code(),
            Some(1),
            "{command:?}: {}",
            output(&result)
        );
        let stderr = String::from_utf8_lossy(&result.stderr);
        let error: Vec<&str> = stderr.lines().filter(|l| l.contains("error:")).collect();
        assert_eq!(error.len(), 1, "{command:?}: {}", output(&result));
        assert!(
            error[0].contains("metrics.json has no field nonsense.path")
                && error[0].contains("\"estimate.ate_rmse_m <\": \"\" is not a finite number"),
            "{command:?}: {}",
            error[0]
        );
        assert!(!out.exists(), "{command:?} made its run folder");
        assert_no_leftovers(&prefix);
    }
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "refused at start-up, not after waiting: {:?}",
        started.elapsed()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `fastslam-stack test` on the Python example publisher with `expectations`, its run
/// and logs in `dir`; returns the launcher's output and the JUnit report's path.
fn test_python_publisher(dir: &Path, expectations: &[&str]) -> (Output, std::path::PathBuf) {
    test_python_publisher_with(dir, "", expectations)
}

/// [`test_python_publisher`] with extra flags for the publisher.
fn test_python_publisher_with(
    dir: &Path,
    publisher_flags: &str,
    expectations: &[&str],
) -> (Output, std::path::PathBuf) {
    let python = python_with_iceoryx2();
    let junit = dir.join("report.xml");
    let mut command = Command::new(LAUNCHER);
    command
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "test",
            "--config",
            "examples/python/service.toml",
            "--publisher",
        ])
        .arg(format!(
            "'{}' examples/python/publisher.py {publisher_flags}",
            python.display()
        ))
        .args(["--timeout-s", "300", "--out"])
        .arg(dir)
        .arg("--junit")
        .arg(&junit);
    for e in expectations {
        command.args(["--expect", e]);
    }
    (command.output().expect("starting the launcher"), junit)
}

#[test]
fn the_test_command_passes_the_python_publisher_on_sensible_expectations() {
    let dir = folder(&prefix("test_pass"));
    let sensible = [
        "estimate.ate_rmse_m < 0.5",
        "estimate.poses == 315",
        "map.matched >= 12",
        "reference.ate_rmse_m < 0.2",
    ];
    let (result, junit) = test_python_publisher(&dir, &sensible);
    assert_success(&result);
    let stdout = String::from_utf8_lossy(&result.stdout);
    for e in sensible {
        assert!(
            stdout.contains(&format!("✓ {e}")),
            "{e}: {}",
            output(&result)
        );
    }
    let cases = junit_cases(&junit);
    // Every stream ended, nothing dropped (`test`'s default), then the expectations.
    assert_eq!(cases.len(), 2 + sensible.len(), "{cases:?}");
    assert_eq!(cases[1].0, "inputs.rejected_total == 0", "{cases:?}");
    assert!(cases.iter().all(|(_, f)| f.is_none()), "{cases:?}");
    let m = metrics(&dir.join("run"));
    assert!(num(&m, "/estimate/ate_rmse_m") < 0.5);
    assert_no_leftovers_and_remove(&announced_prefix(&result), &dir);
}

#[test]
fn the_test_command_fails_the_python_publisher_on_an_impossible_expectation() {
    let dir = folder(&prefix("test_fail"));
    let (result, junit) = test_python_publisher(
        &dir,
        &["estimate.ate_rmse_m < 0.5", "estimate.ate_rmse_m < 1e-6"],
    );
    assert_eq!(result.status.code(), Some(1), "{}", output(&result));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("error: failed expectations: estimate.ate_rmse_m < 0.000001 (measured "),
        "{}",
        output(&result)
    );
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        stdout.contains("✓ estimate.ate_rmse_m < 0.5")
            && stdout.contains("✗ estimate.ate_rmse_m < 0.000001"),
        "{}",
        output(&result)
    );
    let failed: Vec<String> = (junit_cases(&junit).into_iter())
        .filter_map(|(name, failure)| failure.map(|_| name))
        .collect();
    assert_eq!(failed, ["estimate.ate_rmse_m < 0.000001"]);
    assert_no_leftovers_and_remove(&announced_prefix(&result), &dir);
}

#[test]
fn a_publisher_without_ground_truth_passes_on_what_needs_no_truth() {
    let dir = folder(&prefix("test_no_truth"));
    let (result, _) = test_python_publisher_with(&dir, "--no-truth", &["estimate.poses == 315"]);
    assert_success(&result);
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(stdout.contains("no ground truth"), "{}", output(&result));
    let m = metrics(&dir.join("run"));
    assert_eq!(m["ground_truth"], false, "{m}");
    assert!(m["estimate"].get("ate_rmse_m").is_none(), "{m}");
    // An expectation on a truth-based figure is not measured: the run fails.
    let again = folder(&prefix("test_no_truth_ate"));
    let (result, _) =
        test_python_publisher_with(&again, "--no-truth", &["estimate.ate_rmse_m < 0.5"]);
    assert_eq!(result.status.code(), Some(1), "{}", output(&result));
    assert!(
        output(&result).contains("not measured"),
        "{}",
        output(&result)
    );
    assert_no_leftovers_and_remove(&announced_prefix(&result), &again);
    std::fs::remove_dir_all(&dir).ok();
}
