//! A client SIGKILLed mid-run, through real processes over real iceoryx2: its `run.mcap`
//! is closed into a readable file, the sensors and the service carry on (a dead client
//! is not a dead service), and a client started again records the rest of the run.

mod common;

use common::stacks::{SimStack, launch};
use common::*;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
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

#[test]
fn a_launchers_run_whose_client_is_sigkilled_ends_with_a_readable_recording() {
    let prefix = prefix("launchclientkill");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let launcher = launch(&prefix, &out, &short_scenario(&dir));
    let mcap = out.join("run.mcap");
    wait_for(
        "the client to write a chunk",
        Duration::from_secs(60),
        || std::fs::metadata(&mcap).is_ok_and(|m| m.len() > WRITTEN),
    );
    let client = (stack_processes(&prefix).into_iter())
        .find_map(|(pid, subcommand)| (subcommand == "client").then_some(pid))
        .expect("the client runs");
    kill(Pid::from_raw(client), Signal::SIGKILL).unwrap();
    let ended = launcher.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&ended.stderr);
    assert_eq!(ended.status.code(), Some(1), "{stderr}");
    assert_eq!(
        stderr
            .matches("left unfinished by a client that died: closed")
            .count(),
        1,
        "{stderr}"
    );
    let read = read_mcap(&mcap);
    assert!(read["counts"]["/truth"].as_u64() > Some(0), "{read}");
    assert_no_leftovers_and_remove(&prefix, &dir);
}
