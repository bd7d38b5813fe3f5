//! A client SIGKILLed mid-run, through real processes over real iceoryx2: its `run.mcap`
//! is closed into a readable file, the sensors and the service carry on (a dead client
//! is not a dead service), a client started again records the rest of the run, and one
//! started again with `--resume` (as the launcher does) ends with everything: its
//! journal, and what the publishers kept for it.

mod common;

use common::stacks::{SimStack, launch};
use common::*;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use std::time::Duration;

/// Bytes of `run.mcap` past its magic and header: a chunk has been written.
const WRITTEN: u64 = 4096;

#[test]
fn a_sigkilled_client_leaves_a_readable_recording_and_stops_no_sensor() {
    let mut stack = SimStack::new("clientkill");
    stack.start_all();
    let mcap = stack.out().join("run.mcap");
    let size = || std::fs::metadata(&mcap).map_or(0, |m| m.len());
    wait_for(
        "the client to write a chunk",
        Duration::from_secs(60),
        || size() > WRITTEN,
    );
    stack.stack.kill("client");
    // The run goes on without a client for a while: nothing waits for it.
    std::thread::sleep(Duration::from_secs(1));
    stack.start("client");
    stack.wait_all(Duration::from_secs(90));
    let logs = &stack.stack.dir;
    for sensor in ["odometry-sim", "lidar-sim"] {
        let log = std::fs::read_to_string(logs.join(format!("{sensor}.0.log"))).unwrap();
        assert!(
            log.contains("does not resume died") && !log.contains("holding new messages"),
            "{sensor} took the dead client for a dead service: {log}"
        );
    }
    let m = metrics(&stack.out());
    assert_eq!(m["complete"], true, "{m}");
    assert!(num(&m, "/estimate/poses") > 10.0, "{m}");
    // The killed client's recording, closed by the next one, and the next one's.
    let killed = read_mcap(&stack.out().join("run.1.mcap"));
    assert!(
        killed["counts"]["/truth"].as_u64() > Some(0),
        "the killed client's chunks are kept: {killed}"
    );
    let next = read_mcap(&mcap);
    assert!(next["counts"]["/pose"].as_u64() > Some(10), "{next}");
    assert!(next["metrics"].is_object(), "{next}");
    let prefix = stack.stack.prefix.clone();
    drop(stack);
    assert_no_leftovers(&prefix);
}

/// When to kill the client, in seconds after the previous kill (the first: after its
/// first journal write): five gaps drawn from seed 34, each long enough for the client
/// started again to have resumed, all within the short drive's 12 s.
fn kill_gaps() -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(34);
    (0..5).map(|_| rng.random_range(1.0..2.0)).collect()
}

#[test]
fn a_client_sigkilled_at_five_points_and_restarted_by_the_launcher_loses_nothing() {
    // The uninterrupted run.
    let prefix_whole = prefix("clientwhole");
    let dir_whole = folder(&prefix_whole);
    let whole = launch(
        &prefix_whole,
        &dir_whole.join("run"),
        &short_scenario(&dir_whole),
    );
    let ended = whole.wait_with_output().unwrap();
    assert_success(&ended);
    let expected = reproducible(&dir_whole.join("run"));

    let prefix = prefix("clientkills");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let launcher = launch(&prefix, &out, &short_scenario(&dir));
    let journal = out.join("journal.bin");
    wait_for(
        "the client to write its journal",
        Duration::from_secs(60),
        || std::fs::metadata(&journal).is_ok_and(|m| m.len() > 0),
    );
    for gap in kill_gaps() {
        std::thread::sleep(Duration::from_secs_f64(gap));
        let client = (stack_processes(&prefix).into_iter())
            .find_map(|(pid, subcommand)| (subcommand == "client").then_some(pid))
            .expect("the client runs");
        kill(Pid::from_raw(client), Signal::SIGKILL).unwrap();
        // The launcher starts it again within its poll; the next kill finds the new one.
        wait_for(
            "the client to be started again",
            Duration::from_secs(10),
            || {
                (stack_processes(&prefix).into_iter())
                    .any(|(pid, subcommand)| subcommand == "client" && pid != client)
            },
        );
    }
    let ended = launcher.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&ended.stderr);
    assert_eq!(ended.status.code(), Some(0), "{stderr}");
    assert_eq!(
        stderr.matches("started again with --resume").count(),
        5,
        "{stderr}"
    );
    // Every pose, every truth sample, every input: the metrics are the uninterrupted run's.
    assert_eq!(reproducible(&out), expected);
    assert!(!journal.exists(), "a finished client removes its journal");
    // Each killed client's recording was closed by the next one and opens (its chunks
    // so far: the journal holds the rest); the last one holds every pose.
    for n in 1..=5 {
        read_mcap(&out.join(format!("run.{n}.mcap")));
    }
    let last = read_mcap(&out.join("run.mcap"));
    assert_eq!(
        last["counts"]["/pose"].as_f64(),
        Some(num(&expected, "/estimate/poses")),
        "{last}"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
    assert_no_leftovers_and_remove(&prefix_whole, &dir_whole);
}
