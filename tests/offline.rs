//! An in-process run (the simulators' messages, the service's glue and the client's
//! scoring in one process) and a run through the real processes over iceoryx2 give the
//! same metrics for the same seed — so the offline Monte Carlo comparison measures what the
//! stack computes.

mod common;

use common::*;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::{EstimatorChoice, Overrides};
use fastslam_stack::{offline, settings};

#[test]
fn in_process_run_gives_the_metrics_of_the_run_through_the_processes() {
    // bailey-short with an optimiser, its correction and FastSLAM 2.0, so every piece of
    // the service's wiring is exercised; 30 particles keep it quick.
    let flags = [
        "--scenario",
        "bailey-short",
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
    let prefix = prefix("offline_equal");
    let dir = folder(&prefix);
    let out = dir.join("run");
    assert_success(&run_stack(&prefix, &out, &flags));
    let through_processes = std::fs::read_to_string(out.join("metrics.json")).unwrap();

    let scenario = Scenario::load("bailey-short").unwrap();
    let overrides = Overrides {
        particles: Some(30),
        seed: Some(3),
        choice: EstimatorChoice {
            optimizer: Some("icoa".into()),
            proposal: Some("fastslam2".into()),
            move_correction: Some("proposal".into()),
        },
    };
    let config = settings::service_config(&scenario, None, &overrides).unwrap();
    let outcome = offline::run_in_process(&scenario, 3, &config).unwrap();
    let in_process = serde_json::to_string_pretty(&outcome.metrics).unwrap();
    // Everything the estimate determines must be equal. Two sections are not the
    // estimate's: `/filter` summarises the service's status topic, which an in-process run
    // does not publish, and `/cost` is wall-clock time and /proc readings.
    let estimate_only = |json: &str| {
        let mut v: serde_json::Value = serde_json::from_str(json).unwrap();
        let m = v.as_object_mut().unwrap();
        assert!(m.remove("filter").is_some() && m.remove("cost").is_some());
        v
    };
    assert_eq!(
        estimate_only(&in_process),
        estimate_only(&through_processes)
    );
    assert!(outcome.moves.is_some_and(|m| m.proposed > 0));
    assert!(outcome.metrics.estimate.poses > 200, "{in_process}");
    std::fs::remove_dir_all(&dir).ok();
}
