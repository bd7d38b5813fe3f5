//! The stack with a real lidar, through the real processes: the simulated lidar sends raw
//! scans, the service extracts the poles and builds the occupancy grid, the client scores
//! the run and saves the grid. The grid is compared with the world's walls.

mod common;

use common::*;
use fastslam_sensors_sim::Scenario;

#[test]
fn the_structured_world_runs_end_to_end_with_raw_scans() {
    let prefix = prefix("structured");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let result = run_stack(&prefix, &out, &["--scenario", "structured-100m"]);
    assert_success(&result);
    let m = metrics(&out);
    println!("{}", String::from_utf8_lossy(&result.stdout));
    assert_eq!(m["complete"], true);
    let ate = num(&m, "/estimate/ate_rmse_m");
    let dead_reckoning = num(&m, "/dead_reckoning/ate_rmse_m");
    assert!(num(&m, "/estimate/poses") > 1500.0, "a pose per scan: {m}");
    assert!(ate < 0.6, "ATE {ate} m: {m}");
    assert!(
        ate < 0.5 * dead_reckoning,
        "ATE {ate} m vs dead reckoning {dead_reckoning} m"
    );
    let rmse = num(&m, "/map/rmse_m");
    assert!(rmse < 0.5, "landmark RMSE {rmse} m: {m}");
    assert!(
        num(&m, "/map/matched") >= 40.0,
        "poles found along the route: {m}"
    );
    assert!(num(&m, "/map/spurious") <= 15.0, "{m}");
    assert_zero_copy(&out);
    let scenario = Scenario::load("structured-100m").unwrap();
    // The route leaves some corridors unvisited: only precision is judged here.
    let (precision, recall) = precision_recall(&out, &scenario, 0.4);
    println!("structured-100m grid: precision {precision:.3}, recall {recall:.3}");
    assert!(precision > 0.9, "grid precision {precision:.3}");
    assert!(out.join("map.png").is_file());
    let mcap = read_mcap(&out.join("run.mcap"));
    assert_eq!(
        mcap["counts"]["/scan"].as_u64(),
        Some(scans_published(&out.join("logs").join("lidar-sim.log"))),
        "run.mcap holds every scan: {mcap}"
    );
    assert_eq!(mcap["schemas"]["/scan"], "foxglove.LaserScan/protobuf");
    assert!(mcap["counts"]["/grid"].as_u64() >= Some(1), "{mcap}");
    assert_eq!(mcap["schemas"]["/grid"], "foxglove.Grid/protobuf");
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn the_grid_of_the_indoor_loop_matches_its_walls() {
    let prefix = prefix("indoor_grid");
    let dir = folder(&prefix);
    let out = dir.join("run");
    assert_success(&run_stack(&prefix, &out, &["--scenario", "indoor-loop"]));
    let m = metrics(&out);
    assert!(num(&m, "/estimate/ate_rmse_m") < 0.5, "{m}");
    let scenario = Scenario::load("indoor-loop").unwrap();
    let (precision, recall) = precision_recall(&out, &scenario, 0.3);
    println!("indoor-loop grid: precision {precision:.3}, recall {recall:.3}");
    assert!(precision > 0.9, "grid precision {precision:.3}");
    assert!(recall > 0.9, "grid recall {recall:.3}");
    let png = std::fs::read(out.join("map.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn raw_scan_runs_are_the_same_in_real_time_as_fast_as_possible_busy_polling_and_spinning() {
    let prefix_a = prefix("pacing_fast");
    let prefix_b = prefix("pacing_real");
    let prefix_c = prefix("pacing_poll");
    let prefix_d = prefix("pacing_spin");
    let dir = folder(&prefix_a);
    // The indoor loop cut to its first 6 m (about 6 s of simulated time).
    let scenario = dir.join("short.toml");
    std::fs::write(
        &scenario,
        rerouted("indoor-loop", "indoor-short", "[[6.0, 0.0]]"),
    )
    .unwrap();
    let scenario = scenario.display().to_string();
    let run = |prefix: &str, name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut flags = vec!["--scenario", scenario.as_str()];
        flags.extend(extra);
        assert_success(&run_stack(prefix, &out, &flags));
        (
            reproducible(&out),
            std::fs::read(out.join("map.pgm")).unwrap(),
        )
    };
    let fast = run(&prefix_a, "fast", &[]);
    let real = run(&prefix_b, "real", &["--realtime"]);
    let polled = run(&prefix_c, "polled", &["--realtime", "--busy-poll"]);
    let spun = run(&prefix_d, "spun", &["--realtime", "--spin-us", "1000"]);
    assert_eq!(fast.0["complete"], true, "{}", fast.0);
    assert_eq!(fast, real, "pacing changed the results");
    assert_eq!(real, polled, "busy polling changed the results");
    assert_eq!(real, spun, "spinning after wake-ups changed the results");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn grid_fastslam_maps_an_office_without_poles_where_the_landmark_filter_dead_reckons() {
    let prefix_grid = prefix("office_grid");
    let prefix_landmarks = prefix("office_landmarks");
    let dir = folder(&prefix_grid);
    // The office floor's first two corridors (52 m, about 55 s simulated).
    let scenario = dir.join("office.toml");
    let route = "[[36.0, 0.0], [36.0, 16.0]]";
    std::fs::write(
        &scenario,
        rerouted("office-corridors", "office-half", route),
    )
    .unwrap();
    let scenario_flag = scenario.display().to_string();
    let grid = dir.join("grid");
    let result = run_stack(&prefix_grid, &grid, &["--scenario", &scenario_flag]);
    assert_success(&result);
    println!("{}", String::from_utf8_lossy(&result.stdout));
    let m = metrics(&grid);
    assert_eq!(m["complete"], true);
    let ate = num(&m, "/estimate/ate_rmse_m");
    let dead_reckoning = num(&m, "/dead_reckoning/ate_rmse_m");
    assert!(
        ate < 0.25 * dead_reckoning,
        "grid FastSLAM ATE {ate} m vs dead reckoning {dead_reckoning} m"
    );
    let office = Scenario::load(&scenario_flag).unwrap();
    let (precision, recall) = precision_recall(&grid, &office, 0.3);
    println!("office grid: precision {precision:.3}, recall {recall:.3}");
    assert!(precision > 0.9, "grid precision {precision:.3}");
    // No poles: the landmark filter has nothing to correct its odometry with.
    let landmarks = dir.join("landmarks");
    let flags = ["--scenario", &scenario_flag, "--map", "landmarks"];
    assert_success(&run_stack(&prefix_landmarks, &landmarks, &flags));
    let l = metrics(&landmarks);
    assert_eq!(num(&l, "/map/estimated"), 0.0, "{l}");
    let landmark_ate = num(&l, "/estimate/ate_rmse_m");
    assert!(
        landmark_ate > 0.8 * dead_reckoning,
        "landmark filter ATE {landmark_ate} m vs dead reckoning {dead_reckoning} m"
    );
    assert_no_leftovers(&prefix_landmarks);
    assert_no_leftovers_and_remove(&prefix_grid, &dir);
}
