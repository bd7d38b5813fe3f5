//! `fastslam-stack compare` through the real stack: every configuration runs the whole
//! multi-process stack; the table has one row per method × particle count, its numbers
//! are those of individual runs with the same seeds, and a name the service rejects is
//! reported with the service's reason while the other runs still happen.

mod common;

use common::*;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The optimisers compared: the first three the service knows (`none`, `coa`, `icoa`), the
/// issue's "3 optimisers × 2 seeds" check.
fn optimizers() -> Vec<String> {
    fastslam_estimation::optimise::OptimiserKind::ALL
        .iter()
        .take(3)
        .map(ToString::to_string)
        .collect()
}

const PARTICLES: [usize; 2] = [10, 30];
const SEEDS: [u64; 2] = [1, 2];

/// Rows of a CSV file as header-keyed maps.
fn csv(path: &std::path::Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

/// An individual `run` on `bailey-short` with `flags`, into `<dir>/single`: what a line
/// of compare's table must equal.
fn single_run(prefix: &str, dir: &Path, flags: &[&str]) -> PathBuf {
    let out = dir.join("single");
    let mut all = vec!["--scenario", "bailey-short"];
    all.extend(flags);
    assert_success(&run_stack(prefix, &out, &all));
    out
}

#[test]
fn compare_tables_every_configuration_with_the_numbers_of_individual_runs() {
    let prefix = prefix("compare");
    let dir = folder(&prefix);
    let out = dir.join("cmp");
    let good = optimizers();
    let mut names = good.clone();
    names.push("magic".into()); // not an optimiser: rejected by the service
    let join = |v: Vec<String>| v.join(",");
    let result = Command::new(LAUNCHER)
        .args(["compare", "--scenario", "bailey-short", "--jobs", "2"])
        .args(["--optimizers", &names.join(",")])
        .args([
            "--particles",
            &join(PARTICLES.map(|n| n.to_string()).to_vec()),
        ])
        .args(["--seeds", &join(SEEDS.map(|n| n.to_string()).to_vec())])
        .args(["--timeout-s", "300", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&result.stdout);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(
        result.status.code(),
        Some(1),
        "a rejected run fails compare:\n{stdout}\n{stderr}"
    );

    // One summary row per optimiser × particle count, in the order asked for.
    let summary = csv(&out.join("summary.csv"));
    let keys: Vec<(String, String)> = summary
        .iter()
        .map(|r| (r["optimizer"].clone(), r["particles"].clone()))
        .collect();
    let expected: Vec<(String, String)> = names
        .iter()
        .flat_map(|o| PARTICLES.map(|n| (o.to_string(), n.to_string())))
        .collect();
    assert_eq!(keys, expected);
    for r in &summary {
        let (runs, failed) = if r["optimizer"] == "magic" {
            ("0", "2")
        } else {
            ("2", "0")
        };
        assert_eq!(
            (r["runs"].as_str(), r["failed"].as_str()),
            (runs, failed),
            "{r:?}"
        );
    }
    // The Markdown table says the same, and names the rejection with its reason.
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("| none | 10 | 2 |"), "{md}");
    assert!(
        md.contains("magic") && md.contains("possible values: none, coa"),
        "{md}"
    );
    assert!(stdout.contains("| method | particles |"), "{stdout}");
    for ext in ["svg", "png"] {
        let plot = out.join(format!("rmse_vs_cpu.{ext}"));
        assert!(
            std::fs::metadata(&plot)
                .map(|m| m.len() > 1000)
                .unwrap_or(false),
            "{plot:?}"
        );
    }

    // Every run is in runs.csv; each good one equals an individual run with its seed.
    let runs = csv(&out.join("runs.csv"));
    assert_eq!(runs.len(), names.len() * PARTICLES.len() * SEEDS.len());
    let ok: BTreeSet<(String, String, String)> = runs
        .iter()
        .filter(|r| r["status"] == "ok")
        .map(|r| {
            (
                r["optimizer"].clone(),
                r["particles"].clone(),
                r["seed"].clone(),
            )
        })
        .collect();
    assert_eq!(
        ok.len(),
        good.len() * PARTICLES.len() * SEEDS.len(),
        "{runs:?}"
    );
    let (optimizer, particles, seed) = (good[good.len() - 1].as_str(), PARTICLES[1], SEEDS[1]);
    let single = single_run(
        &prefix,
        &dir,
        &[
            "--optimizer",
            optimizer,
            "--particles",
            &particles.to_string(),
            "--seed",
            &seed.to_string(),
        ],
    );
    let in_compare = out
        .join("runs")
        .join(format!("{optimizer}_n{particles}_seed{seed}"));
    assert_eq!(
        reproducible(&single),
        reproducible(&in_compare),
        "compare's run differs from the individual run"
    );
    let row = runs
        .iter()
        .find(|r| {
            r["optimizer"] == optimizer
                && r["particles"] == particles.to_string()
                && r["seed"] == seed.to_string()
        })
        .unwrap();
    let table_ate: f64 = row["ate_rmse_m"].parse().unwrap();
    assert_eq!(table_ate, num(&metrics(&single), "/estimate/ate_rmse_m"));
    let nees: f64 = row["nees_mean"].parse().unwrap();
    assert_eq!(nees, num(&metrics(&single), "/consistency/nees_mean"));
    for r in runs.iter().filter(|r| r["optimizer"] == "magic") {
        assert!(r["status"].contains("magic"), "{r:?}");
    }
    // No run left a process behind.
    assert_eq!(
        leftovers(&dir.display().to_string()).0,
        Vec::<String>::new()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--proposals` runs every optimiser with each proposal: a table line per method, and
/// the FastSLAM 2.0 run equals an individual `run --proposal fastslam2`.
#[test]
fn compare_runs_each_optimiser_with_each_proposal() {
    let prefix = prefix("compare_proposals");
    let dir = folder(&prefix);
    let out = dir.join("cmp");
    let result = Command::new(LAUNCHER)
        .args([
            "compare",
            "--scenario",
            "bailey-short",
            "--optimizers",
            "none",
        ])
        .args(["--proposals", "motion,fastslam2", "--particles", "10"])
        .args(["--seeds", "1", "--timeout-s", "300", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        result.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let summary = csv(&out.join("summary.csv"));
    let keys: Vec<(&str, &str, &str)> = summary
        .iter()
        .map(|r| (&*r["optimizer"], &*r["proposal"], &*r["runs"]))
        .collect();
    assert_eq!(keys, [("none", "motion", "1"), ("none", "fastslam2", "1")]);
    assert!(stdout.contains("| none+fastslam2 | 10 | 1 |"), "{stdout}");
    let single = single_run(
        &prefix,
        &dir,
        &[
            "--proposal",
            "fastslam2",
            "--particles",
            "10",
            "--seed",
            "1",
        ],
    );
    let in_compare = out.join("runs").join("none+fastslam2_n10_seed1");
    assert_eq!(reproducible(&single), reproducible(&in_compare));
    let motion = out.join("runs").join("none_n10_seed1");
    assert_ne!(
        reproducible(&motion),
        reproducible(&in_compare),
        "the proposal made no difference"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--move-corrections` runs every optimiser but `none` in each mode: a table line per
/// method, and the corrected run equals an individual `run --move-correction proposal`.
#[test]
fn compare_runs_each_optimiser_in_each_correction_mode() {
    let prefix = prefix("compare_corrections");
    let dir = folder(&prefix);
    let out = dir.join("cmp");
    let result = Command::new(LAUNCHER)
        .args(["compare", "--scenario", "bailey-short"])
        .args([
            "--optimizers",
            "none,coa",
            "--move-corrections",
            "none,proposal",
        ])
        .args([
            "--particles",
            "10",
            "--seeds",
            "1",
            "--timeout-s",
            "300",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        result.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let summary = csv(&out.join("summary.csv"));
    let keys: Vec<(&str, &str)> = summary
        .iter()
        .map(|r| (&*r["optimizer"], &*r["correction"]))
        .collect();
    assert_eq!(keys, [("none", ""), ("coa", "none"), ("coa", "proposal")]);
    assert!(stdout.contains("| coa+proposal | 10 | 1 |"), "{stdout}");
    let single = single_run(
        &prefix,
        &dir,
        &[
            "--optimizer",
            "coa",
            "--move-correction",
            "proposal",
            "--particles",
            "10",
            "--seed",
            "1",
        ],
    );
    let in_compare = out.join("runs").join("coa+proposal_n10_seed1");
    assert_eq!(reproducible(&single), reproducible(&in_compare));
    let papers = out.join("runs").join("coa_n10_seed1");
    assert_ne!(reproducible(&papers), reproducible(&in_compare));
    std::fs::remove_dir_all(&dir).ok();
}

/// `compare` with `flags` into `out`; its output.
fn compare(out: &Path, flags: &[&str]) -> std::process::Output {
    Command::new(LAUNCHER)
        .arg("compare")
        .args(flags)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// `compare --merge` of `slices` into `out`; its output.
fn merge(out: &Path, slices: &[&PathBuf]) -> std::process::Output {
    Command::new(LAUNCHER)
        .args(["compare", "--merge"])
        .args(slices)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// The error output of a command that must fail.
fn refusal(output: &std::process::Output) -> String {
    assert!(!output.status.success(), "{output:?}");
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A CSV file without the columns that measure time on the machine.
fn without_timings(
    path: &Path,
    timings: &[&str],
) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut rows = csv(path);
    for row in &mut rows {
        for column in timings {
            assert!(
                row.remove(*column).is_some(),
                "{column} in {}",
                path.display()
            );
        }
    }
    rows
}

/// `--shard 1/2` + `--shard 2/2` + `--merge` gives the unsliced sweep's tables: equal
/// but for the columns that measure time (CPU and wall times, latencies) and where the run
/// folders are; merging the unsliced folder itself gives its tables byte for byte. Slices
/// of another sweep, or cut differently, and a missing or repeated slice are refused.
#[test]
fn sharded_compare_merges_into_the_unsliced_tables() {
    let prefix = prefix("compare_shards");
    let dir = folder(&prefix);
    let scenario = short_scenario(&dir);
    let scenario = scenario.to_str().unwrap();
    let sweep = [
        "--scenario",
        scenario,
        "--particles",
        "10",
        "--seeds",
        "1,2",
        "--timeout-s",
        "300",
    ];
    let with = |more: &[&'static str]| [&sweep[..], more].concat();
    let whole = dir.join("whole");
    let (one, two) = (dir.join("one"), dir.join("two"));
    assert_success(&compare(&whole, &sweep));
    assert_success(&compare(&one, &with(&["--shard", "1/2"])));
    assert_success(&compare(&two, &with(&["--shard", "2/2"])));
    for (slice, seed) in [(&one, 1), (&two, 2)] {
        let runs = csv(&slice.join("runs.csv"));
        assert_eq!(runs.len(), 1, "{}", slice.display());
        assert_eq!(runs[0]["seed"], seed.to_string());
    }

    let merged = dir.join("merged");
    assert_success(&merge(&merged, &[&two, &one]));
    let summary_timings = ["service_cpu_s_mean", "service_cpu_s_std", "wall_s_mean"];
    assert_eq!(
        without_timings(&merged.join("summary.csv"), &summary_timings),
        without_timings(&whole.join("summary.csv"), &summary_timings)
    );
    let run_timings = [
        "wall_s",
        "service_cpu_s",
        "stack_cpu_s",
        "latency_median_ms",
        "latency_p99_ms",
        "run_folder",
    ];
    assert_eq!(
        without_timings(&merged.join("runs.csv"), &run_timings),
        without_timings(&whole.join("runs.csv"), &run_timings)
    );
    for run in csv(&merged.join("runs.csv")) {
        assert!(
            Path::new(&run["run_folder"]).join("metrics.json").is_file(),
            "{run:?}"
        );
    }
    assert!(merged.join("rmse_vs_cpu.png").is_file());

    // The merge is the tables of the unsliced sweep: byte for byte on the same runs.
    let again = dir.join("again");
    assert_success(&merge(&again, &[&whole]));
    for file in ["runs.csv", "summary.csv", "summary.md"] {
        assert_eq!(
            std::fs::read_to_string(again.join(file)).unwrap(),
            std::fs::read_to_string(whole.join(file)).unwrap(),
            "{file}"
        );
    }

    // Refusals, each in one line. Slices with no runs are cheap: a 2-run sweep in 3.
    let other = dir.join("other");
    let other_flags = [&sweep[..6], &["--timeout-s", "200", "--shard", "3/3"]].concat();
    assert_success(&compare(&other, &other_flags));
    let third = dir.join("third");
    assert_success(&compare(&third, &with(&["--shard", "3/3"])));
    let no = dir.join("refused");
    let cases: [(&[&PathBuf], &str); 4] = [
        (&[&one], "missing slice(s) 2/2"),
        (&[&one, &two, &one], "slice 1/2 is given twice"),
        (&[&one, &other], "slices of different sweeps"),
        (&[&one, &third], "cut into 2 and into 3 slices"),
    ];
    for (slices, reason) in cases {
        let stderr = refusal(&merge(&no, slices));
        assert!(stderr.contains(reason), "{reason}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
    assert!(
        refusal(&compare(&no, &with(&["--shard", "3/2"]))).contains("1 ≤ I ≤ N"),
        "a slice past the last is refused"
    );
    assert!(!no.exists(), "a refused merge wrote nothing");
    std::fs::remove_dir_all(&dir).ok();
}
