//! `fastslam-stack bench` runs its parts through the real processes and prints their
//! figures. The figures are timings, which these shared machines make noisy, so they are
//! not judged here (BENCHMARKS.md records them): the test checks that the parts run and
//! report what they promise, and that the multi-process runs estimate what the
//! in-process runs do.

mod common;

use common::*;
use std::process::Command;

/// The two numbers of "same metrics as in process: ATE 8.924 m (in process 8.924 m)".
fn ates(line: &str) -> (f64, f64) {
    let numbers: Vec<f64> = line
        .split_whitespace()
        .filter_map(|word| word.parse().ok())
        .collect();
    match numbers[..] {
        [stack, in_process] => (stack, in_process),
        _ => panic!("two ATEs expected: {line}"),
    }
}

#[test]
fn bench_prints_the_step_grid_and_every_throughput_round() {
    let dir = folder(&prefix("bench"));
    let out = Command::new(LAUNCHER)
        .args(["bench", "--quick", "--parts", "step,throughput"])
        .args(["--particles", "10", "--landmarks", "10,100", "--steps", "3"])
        .args(["--throughput-rounds", "2", "--out"])
        .arg(dir.join("runs"))
        .output()
        .expect("starting the launcher");
    assert_success(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("machine: "), "{stdout}");
    assert!(
        stdout.lines().any(|l| l.trim_start().starts_with("N=10 ")),
        "a row of the step grid: {stdout}"
    );
    let rounds: Vec<&str> = stdout
        .lines()
        .filter(|l| l.trim_start().starts_with("round "))
        .collect();
    assert_eq!(rounds.len(), 2, "one line per round: {stdout}");
    for round in rounds {
        assert_eq!(
            round.matches('x').count(),
            3,
            "each round's streamed, CPU and live-view ratios: {round}"
        );
    }
    assert!(
        stdout.contains("IPC overhead (median [min, max]): streamed "),
        "{stdout}"
    );
    assert!(
        stdout.contains("live view (--live, the viewer subscribed"),
        "{stdout}"
    );
    let same = stdout
        .lines()
        .find(|l| l.contains("same metrics as in process"))
        .unwrap_or_else(|| panic!("the ATE comparison: {stdout}"));
    let (stack, in_process) = ates(same);
    assert_eq!(stack, in_process, "{same}");
    std::fs::remove_dir_all(&dir).ok();
}
