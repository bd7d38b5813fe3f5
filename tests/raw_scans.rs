//! The stack with a real lidar, through the real processes: the simulated lidar sends raw
//! scans, the service extracts the poles and builds the occupancy grid, the client scores
//! the run and saves the grid. The grid is compared with the world's walls.

mod common;

use common::*;
use fastslam_sensors_sim::Scenario;
use std::collections::HashSet;
use std::path::Path;

/// The occupied cells of a run folder's map (`map.yaml` + `map.pgm`, map_server format),
/// as cell-centre coordinates (m), and the resolution.
fn occupied_cells(out: &Path) -> (Vec<[f64; 2]>, f64) {
    let yaml = std::fs::read_to_string(out.join("map.yaml")).expect("map.yaml");
    let value = |key: &str| -> String {
        let line = yaml.lines().find(|l| l.starts_with(key)).unwrap();
        line[key.len()..].trim().to_string()
    };
    let resolution: f64 = value("resolution:").parse().unwrap();
    let origin: Vec<f64> = value("origin:")
        .trim_matches(['[', ']'])
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    let pgm = std::fs::read(out.join("map.pgm")).expect("map.pgm");
    let text = String::from_utf8_lossy(&pgm[..20]).to_string();
    let mut fields = text.split_whitespace();
    assert_eq!(fields.next(), Some("P5"));
    let width: usize = fields.next().unwrap().parse().unwrap();
    let height: usize = fields.next().unwrap().parse().unwrap();
    let pixels = &pgm[pgm.len() - width * height..];
    let cells = pixels
        .iter()
        .enumerate()
        .filter(|(_, p)| **p == 0)
        .map(|(k, _)| {
            let (column, row) = (k % width, k / width);
            let j = height - 1 - row; // image row 0 is the top of the map
            [
                origin[0] + (column as f64 + 0.5) * resolution,
                origin[1] + (j as f64 + 0.5) * resolution,
            ]
        })
        .collect();
    (cells, resolution)
}

/// Distance from `p` to the segment `w` = [x1, y1, x2, y2].
fn to_segment(p: [f64; 2], w: &[f64; 4]) -> f64 {
    let (dx, dy) = (w[2] - w[0], w[3] - w[1]);
    let t = (((p[0] - w[0]) * dx + (p[1] - w[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    (p[0] - w[0] - t * dx).hypot(p[1] - w[1] - t * dy)
}

/// Precision (occupied cells within `tolerance` of a wall or a pole's surface) and recall
/// (points every 0.1 m along the walls with an occupied cell within `tolerance`).
fn precision_recall(out: &Path, scenario: &Scenario, tolerance: f64) -> (f64, f64) {
    let (cells, resolution) = occupied_cells(out);
    assert!(
        cells.len() > 100,
        "an almost empty grid: {} cells",
        cells.len()
    );
    let world = &scenario.world;
    let near_structure = |p: [f64; 2]| {
        world.walls.iter().any(|w| to_segment(p, w) <= tolerance)
            || world
                .poles
                .iter()
                .any(|c| ((p[0] - c[0]).hypot(p[1] - c[1]) - c[2]).abs() <= tolerance)
    };
    let precision =
        cells.iter().filter(|&&p| near_structure(p)).count() as f64 / cells.len() as f64;
    let key = |p: [f64; 2]| {
        (
            (p[0] / resolution).floor() as i64,
            (p[1] / resolution).floor() as i64,
        )
    };
    let occupied: HashSet<(i64, i64)> = cells.iter().map(|&p| key(p)).collect();
    let reach = (tolerance / resolution).ceil() as i64;
    let found = |p: [f64; 2]| {
        let (i, j) = key(p);
        (-reach..=reach).any(|di| (-reach..=reach).any(|dj| occupied.contains(&(i + di, j + dj))))
    };
    let samples: Vec<[f64; 2]> = world
        .walls
        .iter()
        .flat_map(|w| {
            let n = ((w[2] - w[0]).hypot(w[3] - w[1]) / 0.1).ceil() as usize;
            (0..=n).map(move |k| {
                let t = k as f64 / n as f64;
                [w[0] + t * (w[2] - w[0]), w[1] + t * (w[3] - w[1])]
            })
        })
        .collect();
    let recall = samples.iter().filter(|&&p| found(p)).count() as f64 / samples.len() as f64;
    (precision, recall)
}

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
    let text = fastslam_sensors_sim::scenario::BUILT_IN
        .iter()
        .find(|(n, _)| *n == "indoor-loop")
        .unwrap()
        .1;
    let start = text.find("waypoints = [").unwrap();
    let end = start + text[start..].find("\n]").unwrap() + 2;
    // Renamed: a scenario file may not take the name of a built-in it differs from.
    let short = format!("{}waypoints = [[6.0, 0.0]]{}", &text[..start], &text[end..])
        .replace("name = \"indoor-loop\"", "name = \"indoor-short\"");
    let scenario = dir.join("short.toml");
    std::fs::write(&scenario, short).unwrap();
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
