//! The smoothing back-end's graph written as g2o (`[smoother] graph_out`) by the real
//! service, and solved again by `fastslam-stack solve`: the file any other solver can
//! check a run with.

mod common;

use common::{LAUNCHER, assert_no_leftovers_and_remove, assert_success, folder, prefix, run_stack};
use std::process::Command;

/// The value after `key` in a line of `key value` pairs.
fn field(line: &str, key: &str) -> f64 {
    let mut words = line.split_whitespace();
    while let Some(word) = words.next() {
        if word == key {
            return words.next().and_then(|v| v.parse().ok()).expect(key);
        }
    }
    panic!("{key} not in {line}")
}

#[test]
fn the_back_end_writes_the_graph_it_solved_and_solve_reads_it() {
    let prefix = prefix("graph_out");
    let dir = folder(&prefix);
    let graph = dir.join("smoothed.g2o");
    let scenario = include_str!("../sensors-sim/scenarios/bailey-webmap.toml")
        .replace("name = \"bailey-webmap\"", "name = \"webmap-graph-out\"")
        .replace(
            "[service.smoother]\nenabled = true",
            &format!(
                "[service.smoother]\nenabled = true\ngraph_out = {:?}",
                graph.display().to_string()
            ),
        );
    assert!(
        scenario.contains("graph_out"),
        "the scenario's [service.smoother] table moved"
    );
    let path = dir.join("webmap-graph-out.toml");
    std::fs::write(&path, scenario).unwrap();
    let out = dir.join("run");
    assert_success(&run_stack(
        &prefix,
        &out,
        &["--scenario", path.to_str().unwrap()],
    ));
    let metrics = common::metrics(&out);
    let smoothed_poses = common::num(&metrics, "/smoothed/poses");

    let solved = Command::new(LAUNCHER)
        .arg("solve")
        .arg(&graph)
        .output()
        .unwrap();
    assert!(
        solved.status.success(),
        "{}",
        String::from_utf8_lossy(&solved.stderr)
    );
    let line = String::from_utf8(solved.stdout).unwrap();
    // The 30 landmarks the route sees, and the smoothed trajectory's poses.
    assert_eq!(field(&line, "landmarks"), 30.0, "{line}");
    assert_eq!(field(&line, "poses"), smoothed_poses, "{line}");
    // Written at the back-end's solution, which is the g2o problem's minimum to first
    // order: solving it again moves χ² by little, and never up.
    let (before, after) = (field(&line, "chi2_initial"), field(&line, "chi2_final"));
    assert!(after <= before * (1.0 + 1e-12), "{line}");
    assert!(after > 0.9 * before, "{line}");
    assert_no_leftovers_and_remove(&prefix, &dir);
}
