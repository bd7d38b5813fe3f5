//! An in-process run (the simulators' messages, the service's glue and the client's
//! scoring in one process) and a run through the real processes over iceoryx2 give the
//! same metrics for the same seed — so the offline Monte Carlo comparison measures what the
//! stack computes. Both for landmark observations and for raw scans.

mod common;

use common::*;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::{EstimatorChoice, Overrides};
use fastslam_stack::{offline, settings};

/// The metrics the estimate determines. Sections that are not the estimate's are left out:
/// `/filter` summarises the service's status topic, which an in-process run does not
/// publish, `/cost` and `/reference/solve_s` are wall-clock time and /proc readings, and
/// `/grid` scores the occupancy grid the service publishes. The rest of `/reference` stays:
/// both solve the same data.
fn estimate_only(json: &str) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_str(json).unwrap();
    drop_timings(&mut v);
    let m = v.as_object_mut().unwrap();
    assert!(m.remove("filter").is_some());
    m.remove("grid");
    v
}

/// Runs `scenario` with `flags` (and their `overrides`) through the processes and in
/// process, and asserts the metrics the estimate determines are equal.
fn assert_in_process_equals_processes(
    name: &str,
    scenario: &str,
    flags: &[&str],
    overrides: &Overrides,
) -> offline::RunOutcome {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let out = dir.join("run");
    let mut all = vec!["--scenario", scenario];
    all.extend(flags);
    assert_success(&run_stack(&prefix, &out, &all));
    let through_processes = std::fs::read_to_string(out.join("metrics.json")).unwrap();

    let loaded = Scenario::load(scenario).unwrap();
    let config = settings::service_config(&loaded, None, overrides).unwrap();
    let source = offline::Source::Simulation(Box::new(loaded));
    let outcome = offline::run_in_process(&source, overrides.seed.unwrap(), &config).unwrap();
    let in_process = serde_json::to_string_pretty(&outcome.metrics).unwrap();
    assert_eq!(
        estimate_only(&in_process),
        estimate_only(&through_processes)
    );
    std::fs::remove_dir_all(&dir).ok();
    outcome
}

#[test]
fn in_process_run_gives_the_metrics_of_the_run_through_the_processes() {
    // bailey-short with an optimiser, its correction and FastSLAM 2.0, so every piece of
    // the service's wiring is exercised; 30 particles keep it quick.
    let flags = [
        "--seed",
        "3",
        "--particles",
        "30",
        "--optimizer",
        "icoa",
        "--proposal",
        "fastslam2",
        "--move-correction",
        "proposal",
    ];
    let overrides = Overrides {
        particles: Some(30),
        seed: Some(3),
        choice: EstimatorChoice {
            optimizer: Some("icoa".into()),
            proposal: Some("fastslam2".into()),
            move_correction: Some("proposal".into()),
            map: None,
        },
    };
    let outcome =
        assert_in_process_equals_processes("offline_equal", "bailey-short", &flags, &overrides);
    assert!(outcome.moves.is_some_and(|m| m.proposed > 0));
    assert!(outcome.metrics.estimate.poses > 200);
}

#[test]
fn in_process_raw_scans_give_the_metrics_of_the_run_through_the_processes() {
    let overrides = Overrides {
        particles: Some(30),
        seed: Some(2),
        ..Overrides::default()
    };
    let flags = ["--seed", "2", "--particles", "30"];
    let outcome =
        assert_in_process_equals_processes("offline_raw", "indoor-loop", &flags, &overrides);
    assert!(outcome.metrics.estimate.poses > 100);
}

#[test]
fn in_process_grid_fastslam_gives_the_metrics_of_the_run_through_the_processes() {
    let overrides = Overrides {
        particles: Some(10),
        seed: Some(4),
        choice: EstimatorChoice {
            optimizer: Some("hill".into()),
            map: Some("grid".into()),
            ..EstimatorChoice::default()
        },
    };
    let flags = overrides.flags();
    let flags: Vec<&str> = flags.iter().map(String::as_str).collect();
    let outcome =
        assert_in_process_equals_processes("offline_grid", "indoor-loop", &flags, &overrides);
    assert!(outcome.moves.is_some_and(|m| m.proposed > 0));
    assert!(outcome.metrics.estimate.ate_rmse_m < 0.5 * outcome.metrics.dead_reckoning.ate_rmse_m);
}

#[test]
fn in_process_replay_gives_the_metrics_of_the_replay_through_the_processes() {
    // Victoria Park: unknown association, aligned and scored at the GPS fixes.
    let prefix = prefix("offline_replay");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/victoria_park");
    let result = std::process::Command::new(LAUNCHER)
        .args(["replay", "victoria-park", "--data"])
        .arg(&data)
        .args(["--particles", "20", "--seed", "2", "--prefix", &prefix])
        .args(["--timeout-s", "600", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_success(&result);
    let through_processes = std::fs::read_to_string(out.join("metrics.json")).unwrap();
    let source = offline::Source::replay(
        fastslam_replay::registry::find("victoria-park").unwrap(),
        Some(&data),
        1,
        fastslam_replay::dataset::Association::Unknown,
        None,
    )
    .unwrap();
    let overrides = Overrides {
        particles: Some(20),
        seed: Some(2),
        ..Overrides::default()
    };
    let config = source.service_config(None, &overrides).unwrap();
    let outcome = offline::run_in_process(&source, 2, &config).unwrap();
    let in_process = serde_json::to_string_pretty(&outcome.metrics).unwrap();
    assert_eq!(
        estimate_only(&in_process),
        estimate_only(&through_processes)
    );
    assert!(outcome.metrics.estimate.poses > 1000);
    std::fs::remove_dir_all(&dir).ok();
}
