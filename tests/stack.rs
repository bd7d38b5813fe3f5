//! The whole stack through real processes: the launcher starts the simulated sensors, the
//! FastSLAM service and the client over iceoryx2; the tests judge the client's metrics.

mod common;

use common::*;

/// The scenario the test drives: one loop of the Bailey webmap with biased odometry.
const SCENARIO: &str = "bailey-loop-biased";

#[test]
fn fastslam_beats_dead_reckoning_through_the_real_processes() {
    let prefix = prefix("beats_dr");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let result = run_stack(&prefix, &out, &["--scenario", SCENARIO]);
    assert_success(&result);
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        stdout.contains("ATE RMSE") && stdout.contains(&out.display().to_string()),
        "{stdout}"
    );

    let m = metrics(&out);
    assert_eq!(m["complete"], true);
    let ate = num(&m, "/estimate/ate_rmse_m");
    let dead_reckoning = num(&m, "/dead_reckoning/ate_rmse_m");
    assert!(
        num(&m, "/estimate/poses") > 1000.0,
        "an estimate per observation: {m}"
    );
    assert!(
        ate < 0.75 * dead_reckoning,
        "FastSLAM ATE {ate} m vs dead reckoning {dead_reckoning} m"
    );
    // Known association: each landmark the sensor saw is in the map exactly once.
    let mapped = num(&m, "/map/estimated");
    assert!(
        (25.0..=35.0).contains(&mapped),
        "landmarks mapped once each: {m}"
    );
    assert!(num(&m, "/map/matched") >= 10.0, "{m}");
    // The client solved the reference over what crossed IPC, with the service's noise
    // model: a pose per scan with sightings, every landmark seen, and the
    // fit's χ² per degree of freedom is about 1 (the odometry's bias is far below the
    // noise of one control).
    assert!(num(&m, "/reference/poses") > 500.0, "{m}");
    assert_eq!(num(&m, "/reference/landmarks"), mapped, "{m}");
    let chi2 = num(&m, "/reference/chi2_per_dof");
    assert!((0.8..1.25).contains(&chi2), "{m}");
    assert!(stdout.contains("achievable ATE"), "{stdout}");
    assert_zero_copy(&out);
    for file in [
        "estimate.tum",
        "truth.tum",
        "dead_reckoning.tum",
        "map.csv",
        "true_map.csv",
    ] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn the_same_seed_gives_identical_metrics() {
    let prefix_a = prefix("same_seed_a");
    let prefix_b = prefix("same_seed_b");
    let dir = folder(&prefix_a);
    let run = |prefix: &str, name: &str| {
        let out = dir.join(name);
        assert_success(&run_stack(
            prefix,
            &out,
            &["--scenario", "bailey-short", "--seed", "7"],
        ));
        reproducible(&out)
    };
    let (a, b) = (run(&prefix_a, "a"), run(&prefix_b, "b"));
    assert_eq!(a, b, "two runs with seed 7 differ");
    let other = dir.join("c");
    assert_success(&run_stack(
        &prefix_a,
        &other,
        &["--scenario", "bailey-short", "--seed", "8"],
    ));
    assert_ne!(a, reproducible(&other), "the seed must matter");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_flags_and_scenarios_are_reported_with_their_reason() {
    let prefix = prefix("bad_flags");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let missing = run_stack(&prefix, &out, &["--scenario", "no-such-scenario"]);
    assert!(!missing.status.success());
    let err = String::from_utf8_lossy(&missing.stderr);
    assert!(
        err.contains("no-such-scenario") && err.contains("bailey-webmap"),
        "{err}"
    );

    let optimizer = run_stack(
        &prefix,
        &out,
        &["--scenario", "bailey-short", "--optimizer", "magic"],
    );
    assert!(!optimizer.status.success());
    let err = String::from_utf8_lossy(&optimizer.stderr);
    assert!(err.contains("magic") && err.contains("none"), "{err}");

    let unknown = std::process::Command::new(LAUNCHER)
        .args(["run", "--no-such-flag"])
        .output()
        .unwrap();
    assert!(!unknown.status.success());
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("--no-such-flag"));
    assert_no_leftovers_and_remove(&prefix, &dir);
}
