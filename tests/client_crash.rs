//! A client SIGKILLed mid-run, through real processes over real iceoryx2: its `run.mcap`
//! is closed into a readable file, the sensors and the service carry on (a dead client
//! is not a dead service), and a client started again records the rest of the run.

mod common;

use common::stacks::SimStack;
use common::*;
use std::time::Duration;

/// Bytes of `run.mcap` past its magic and header: a chunk has been written.
const WRITTEN: u64 = 4096;

#[test]
fn a_sigkilled_client_leaves_a_readable_recording_and_stops_no_sensor() {
    let mut stack = SimStack::new("clientkill");
    for name in [
        "client",
        "service",
        "odometry-sim",
        "lidar-sim",
        "truth-sim",
    ] {
        stack.start(name);
    }
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
