//! An in-process run (the simulators' messages, the service's glue and the client's
//! scoring in one process) and a run through the real processes over iceoryx2 give the
//! same metrics for the same seed — so the offline Monte Carlo comparison measures what the
//! stack computes. For landmark observations, raw scans and grid FastSLAM, and for
//! recorded data sets, one with inputs the service refuses or holds back.

mod common;

use common::*;
use fastslam_replay::dataset::Association;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::{EstimatorChoice, Overrides};
use fastslam_stack::{offline, settings};
use std::path::Path;

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

/// Runs `scenario` with `overrides` (as the launcher's flags, and in process), and the
/// service's `config` file if any, through the processes and in process, and asserts the
/// metrics the estimate determines are equal; `look` is shown the processes' run folder
/// before it is removed.
fn assert_in_process_equals_processes(
    name: &str,
    scenario: &str,
    (config, overrides): (Option<&Path>, &Overrides),
    look: impl FnOnce(&Path),
) -> offline::RunOutcome {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let out = dir.join("run");
    let flags = overrides.flags();
    let mut all = vec!["--scenario", scenario];
    all.extend(flags.iter().map(String::as_str));
    let file = config.map(|c| c.display().to_string());
    all.extend(file.iter().flat_map(|f| ["--config", f.as_str()]));
    assert_success(&run_stack(&prefix, &out, &all));
    let through_processes = std::fs::read_to_string(out.join("metrics.json")).unwrap();
    look(&out);

    let loaded = Scenario::load(scenario).unwrap();
    let config = settings::service_config(&loaded, config, overrides).unwrap();
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
    let outcome = assert_in_process_equals_processes(
        "offline_equal",
        "bailey-short",
        (None, &overrides),
        |_| {},
    );
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
    let outcome = assert_in_process_equals_processes(
        "offline_raw",
        "indoor-loop",
        (None, &overrides),
        |_| {},
    );
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
    let outcome = assert_in_process_equals_processes(
        "offline_grid",
        "indoor-loop",
        (None, &overrides),
        |_| {},
    );
    assert!(outcome.moves.is_some_and(|m| m.proposed > 0));
    assert!(outcome.metrics.estimate.ate_rmse_m < 0.5 * outcome.metrics.dead_reckoning.ate_rmse_m);
}

/// The first pose of a TUM trajectory file (`t x y …`): stamp, x, y.
fn first_pose(path: &Path) -> [f64; 3] {
    let text = std::fs::read_to_string(path).unwrap();
    let line = text.lines().find(|l| !l.starts_with('#')).expect("a pose");
    let mut fields = line.split_whitespace().map(|f| f.parse::<f64>().unwrap());
    std::array::from_fn(|_| fields.next().unwrap())
}

#[test]
fn grid_fastslam_with_loop_closing_gives_one_answer_and_ends_in_the_frame_it_started_in() {
    // Grid FastSLAM on the indoor loop with the loop-closing back-end solving every 10
    // keyframes: while it runs, each solve is moved into the map frame's gauge; the final
    // trajectory is in the first keyframe's frame, so it starts where the run's first
    // pose was published.
    let loaded = Scenario::load("indoor-loop").unwrap();
    let table = loaded.service.expect("indoor-loop has [service] settings");
    let dir = folder(&prefix("offline_loop_files"));
    let config = dir.join("service.toml");
    let loop_closing =
        "[loop_closure]\nenabled = true\nkeyframes_per_submap = 10\nsolve_every = 10\n";
    std::fs::write(&config, toml::to_string(&table).unwrap() + loop_closing).unwrap();
    let overrides = Overrides {
        particles: Some(10),
        seed: Some(4),
        choice: EstimatorChoice {
            map: Some("grid".into()),
            ..EstimatorChoice::default()
        },
    };
    let outcome = assert_in_process_equals_processes(
        "offline_loop",
        "indoor-loop",
        (Some(&config), &overrides),
        |run| {
            let published = first_pose(&run.join("estimate.tum"));
            let smoothed = first_pose(&run.join("smoothed.tum"));
            assert_eq!(published[0], smoothed[0], "both start at the first scan");
            let off = (published[1] - smoothed[1]).hypot(published[2] - smoothed[2]);
            assert!(
                off < 1e-3,
                "the final trajectory starts {off} m off the first pose"
            );
        },
    );
    let smoothed = outcome.metrics.smoothed.expect("the back-end's trajectory");
    assert!(smoothed.solves > 5, "{} solves", smoothed.solves);
    std::fs::remove_dir_all(&dir).ok();
}

/// Replays data set `set` from `data` (robot 1, with `association` where the data set
/// takes one) through the processes and in process, 20 particles, filter seed 2, and
/// asserts the metrics the estimate determines are equal, the refused inputs' counts
/// included.
fn assert_replay_in_process_equals_processes(
    name: &str,
    set: &str,
    data: &Path,
    association: Option<Association>,
) -> offline::RunOutcome {
    let prefix = prefix(name);
    let dir = folder(&prefix);
    let out = dir.join("run");
    let mut flags = vec!["--particles", "20", "--seed", "2", "--prefix", &prefix];
    if let Some(association) = association {
        flags.extend(["--association", association.service_mode()]);
    }
    let result = std::process::Command::new(LAUNCHER)
        .args(["replay", set, "--data"])
        .arg(data)
        .args(flags)
        .args(["--timeout-s", "600", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_success(&result);
    let through_processes = std::fs::read_to_string(out.join("metrics.json")).unwrap();
    let kind = fastslam_replay::registry::find(set).unwrap();
    let association = association.unwrap_or(Association::Unknown);
    let source = offline::Source::replay(kind, Some(data), 1, association, None).unwrap();
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
    std::fs::remove_dir_all(&dir).ok();
    outcome
}

/// The rows of `name` (plain or gzipped) in MRCLAM folder `dir`, comments left out.
fn mrclam_rows(dir: &Path, name: &str) -> Vec<Vec<String>> {
    let gz = std::fs::File::open(dir.join(format!("{name}.gz"))).unwrap();
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(gz), &mut text).unwrap();
    (text.lines())
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(str::to_string).collect())
        .collect()
}

/// The time of a row (s).
fn time(row: &[String]) -> f64 {
    row[0].parse().unwrap()
}

/// Robot 1 of `data/mrclam7` in `dir` with what real logs have and it lacks: repeated
/// odometry records (equal stamps), odometry records at camera frames' times (an
/// odometry message and a scan with the same stamp), 5 s without odometry, 90 s
/// without a landmark in view (more odometry messages between two scans than the
/// service's queue holds), and odometry whose speed or yaw rate the service refuses.
fn irregular_mrclam(dir: &Path) {
    let source = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/mrclam7");
    std::fs::create_dir_all(dir).unwrap();
    for file in [
        "Barcodes.dat",
        "Landmark_Groundtruth.dat",
        "Robot1_Groundtruth.dat.gz",
    ] {
        std::fs::copy(source.join(file), dir.join(file)).unwrap();
    }
    let mut frames = mrclam_rows(&source, "Robot1_Measurement.dat");
    let mut odometry = mrclam_rows(&source, "Robot1_Odometry.dat");
    let start = time(&odometry[0]);
    let blind = start + 200.0..start + 290.0;
    frames.retain(|row| !blind.contains(&time(row)));
    let stopped = start + 400.0..start + 405.0;
    odometry.retain(|row| !stopped.contains(&time(row)));
    for k in (1000..odometry.len() - 1000).step_by(3000) {
        odometry[k][2] = "12.0".into();
        odometry[k + 1000][1] = "40.0".into();
    }
    let mut at_frames: Vec<Vec<String>> = (frames.iter().step_by(10))
        .map(|frame| {
            let before = odometry.partition_point(|row| time(row) <= time(frame));
            let mut row = odometry[before.saturating_sub(1)].clone();
            row[0].clone_from(&frame[0]);
            row
        })
        .collect();
    let repeated = (odometry.iter().step_by(500)).cloned();
    at_frames.extend(repeated);
    odometry.extend(at_frames);
    odometry.sort_by(|a, b| time(a).total_cmp(&time(b)));
    for (name, rows) in [
        ("Robot1_Odometry.dat", odometry),
        ("Robot1_Measurement.dat", frames),
    ] {
        let lines: Vec<String> = rows.iter().map(|row| row.join(" ") + "\n").collect();
        std::fs::write(dir.join(name), lines.concat()).unwrap();
    }
}

#[test]
fn in_process_replay_gives_the_metrics_of_the_replay_through_the_processes() {
    // Victoria Park: unknown association, aligned and scored at the GPS fixes.
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/victoria_park");
    let outcome =
        assert_replay_in_process_equals_processes("offline_replay", "victoria-park", &data, None);
    assert!(outcome.metrics.estimate.poses > 1000);
    // MRCLAM with irregular stamps, a long gap and odometry the service refuses, under
    // both associations.
    let dir = folder(&prefix("offline_irregular")).join("mrclam");
    irregular_mrclam(&dir);
    for association in [Association::Unknown, Association::Known] {
        let name = format!("offline_mrclam_{}", association.service_mode());
        let outcome =
            assert_replay_in_process_equals_processes(&name, "mrclam", &dir, Some(association));
        let refused = &outcome.metrics.inputs.rejected;
        assert!(refused["teleport"] >= 2, "{refused:?}");
        assert!(outcome.metrics.estimate.poses > 1000);
    }
    std::fs::remove_dir_all(dir.parent().unwrap()).ok();
}
