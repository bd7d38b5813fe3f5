//! The pole extraction on real data: `fastslam-stack extraction-report` runs it on the
//! Victoria Park raw scans shipped in `data/victoria_park` and compares it with the tree
//! detections released with the data set.

mod common;

use common::LAUNCHER;

/// The number after `label` in the report, and the percentage in brackets if any.
fn figures(report: &str, label: &str) -> (f64, Option<f64>) {
    let line = report
        .lines()
        .find(|l| l.trim_start().starts_with(label))
        .unwrap_or_else(|| panic!("no `{label}` in:\n{report}"));
    let rest = &line[line.find(label).unwrap() + label.len()..];
    let mut words = rest.split_whitespace();
    let value = words.next().unwrap().parse().unwrap();
    let percent = rest
        .split_once('(')
        .and_then(|(_, p)| p.split_whitespace().next()?.parse().ok());
    (value, percent)
}

#[test]
fn extraction_finds_the_released_victoria_park_trees() {
    let out = std::process::Command::new(LAUNCHER)
        .arg("extraction-report")
        .output()
        .expect("starting the launcher");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{report}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{report}");
    assert!(report.contains("7230 raw scans"), "{report}");
    let (theirs, _) = figures(&report, "released tree detections");
    assert!(theirs > 50_000.0, "{report}");
    let (_, found) = figures(&report, "theirs we find");
    let (_, confirmed) = figures(&report, "ours they have");
    let (error, _) = figures(&report, "median centre error");
    assert!(
        found.unwrap() > 95.0,
        "recall against the release: {report}"
    );
    assert!(
        confirmed.unwrap() > 50.0,
        "precision against the release: {report}"
    );
    assert!(error < 0.05, "median centre error: {report}");
}

#[test]
fn extraction_report_names_a_missing_data_folder() {
    let out = std::process::Command::new(LAUNCHER)
        .args(["extraction-report", "--data", "/nonexistent/victoria"])
        .output()
        .expect("starting the launcher");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nonexistent/victoria"), "{err}");
}
