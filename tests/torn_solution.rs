//! A torn smoothing solution is withheld: the real service, with a gate every solution
//! fails, publishes no smoothed trajectory and counts the torn solves in its status; the
//! client's metrics.json and the summary say so in a warning, which `--expect` judges.
//! The same route with the default gate publishes its solution without a word.

mod common;

use common::{assert_no_leftovers_and_remove, assert_success, folder, prefix, run_stack};

/// The bailey-short scenario with `extra` lines in its `[service.smoother]` table, written
/// to `dir` under `name`.
fn scenario(dir: &std::path::Path, name: &str, extra: &str) -> String {
    let text = include_str!("../sensors-sim/scenarios/bailey-short.toml")
        .replace("name = \"bailey-short\"", &format!("name = \"{name}\""))
        .replace(
            "[service.smoother]\nenabled = true",
            &format!("[service.smoother]\nenabled = true\n{extra}"),
        );
    assert!(
        text.contains(extra),
        "the scenario's [service.smoother] table moved"
    );
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn a_torn_solution_is_withheld_counted_and_warned_about() {
    let prefix = prefix("torn");
    let dir = folder(&prefix);

    let good = dir.join("good");
    let path = scenario(&dir, "short-default-gate", "");
    let out = run_stack(&prefix, &good, &["--scenario", &path]);
    assert_success(&out);
    let m = common::metrics(&good);
    assert!(m.pointer("/smoothed").is_some(), "{m}");
    assert_eq!(common::num(&m, "/filter/smoother_torn_solves"), 0.0);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!stdout.contains("withheld"), "{stdout}");

    let torn = dir.join("torn");
    let path = scenario(&dir, "short-tearing-gate", "torn_chi2_per_dof = 1e-12");
    let out = run_stack(
        &prefix,
        &torn,
        &["--scenario", &path, "--expect", "warnings.count == 0"],
    );
    assert!(!out.status.success(), "the expectation must fail");
    let m = common::metrics(&torn);
    assert!(m.pointer("/smoothed").is_none(), "nothing published: {m}");
    let solves = common::num(&m, "/filter/smoother_torn_solves");
    assert!(solves >= 1.0, "{m}");
    let lines = m.pointer("/warnings/lines").unwrap().to_string();
    assert!(lines.contains("withheld"), "{lines}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("warning: the smoothing back-end withheld"),
        "{stdout}"
    );
    let service_log = std::fs::read_to_string(torn.join("logs/service.log")).unwrap();
    assert!(service_log.contains("solution torn"), "{service_log}");
    // The filter does not depend on its back-end's publishing: the same estimate.
    let good = common::metrics(&good);
    assert_eq!(
        common::num(&good, "/estimate/ate_rmse_m"),
        common::num(&m, "/estimate/ate_rmse_m")
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}
