//! Processes of one's own beside a stack cannot break it: a service created first with
//! settings the stack cannot use is refused with one line naming the setting; a
//! subscriber that never reads neither keeps the stack's processes from leaving at the
//! end of the run nor counts among them in `metrics.json`.

mod common;

use common::*;
use fastslam_protocol::ipc::{Ipc, Service, StackConfig, Wire, remove_stack_files};
use fastslam_protocol::topics::{self, Topic};
use fastslam_protocol::{LandmarkMapHeader, MapLandmark, Observation, ObservationsHeader};
use fastslam_protocol::{Odometry, PoseEstimate};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use std::fmt::Debug;
use std::time::Duration;

/// A process of one's own on the stack `prefix` (a thread of the test: its node is named
/// `outsider`, not one of the stack's).
fn outsider(prefix: &str) -> Ipc {
    let stack = StackConfig {
        prefix: prefix.to_string(),
        root: Some(fastslam_stack::stack_root(prefix).display().to_string()),
    };
    Ipc::open(&stack, "outsider", Duration::from_secs(60)).unwrap()
}

/// The publish–subscribe service of `topic` with `buffer` and the stack's other settings.
fn service<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static>(
    ipc: &Ipc,
    prefix: &str,
    topic: &Topic,
    buffer: usize,
) -> iceoryx2::service::port_factory::publish_subscribe::PortFactory<Service, P, H> {
    let name = ServiceName::new(&topics::service_name(prefix, topic.name)).unwrap();
    let builder = ipc
        .node()
        .service_builder(&name)
        .publish_subscribe::<P>()
        .user_header::<H>()
        .enable_safe_overflow(false)
        .subscriber_max_buffer_size(buffer)
        .history_size(topic.history)
        .max_publishers(topics::MAX_PUBLISHERS)
        .max_subscribers(topics::MAX_SUBSCRIBERS);
    P::open_service(builder).unwrap()
}

/// A subscriber of `topic` that never receives anything.
fn never_reads<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static>(
    ipc: &Ipc,
    prefix: &str,
    topic: &Topic,
) -> Subscriber<Service, P, H> {
    let service = service::<P, H>(ipc, prefix, topic, topic.buffer);
    service.subscriber_builder().create().unwrap()
}

#[test]
fn a_service_created_first_with_a_smaller_buffer_is_refused_with_one_line() {
    let prefix = prefix("smallbuf");
    let dir = folder(&prefix);
    let ipc = outsider(&prefix);
    let _pose = service::<PoseEstimate, ()>(&ipc, &prefix, &topics::POSE, 16);
    let out = dir.join("run");
    let run = run_stack(
        &prefix,
        &out,
        &["--scenario", &short_scenario(&dir).display().to_string()],
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    let wanted = format!(
        "service {prefix}/pose exists with subscriber buffer 16; the stack needs at least 256: \
         stop the process that created it"
    );
    assert!(
        stderr.lines().any(|l| l.contains(&wanted)),
        "one line names the setting: {stderr}"
    );
    drop(ipc);
    remove_stack_files(&prefix, Some(&fastslam_stack::stack_root(&prefix)));
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_subscriber_that_never_reads_neither_holds_the_stack_nor_counts_as_its_own() {
    let prefix = prefix("neverreads");
    let dir = folder(&prefix);
    let ipc = outsider(&prefix);
    // Every topic whose publisher stays at its end until its subscribers have left.
    let _truth_map =
        never_reads::<[MapLandmark], LandmarkMapHeader>(&ipc, &prefix, &topics::TRUE_LANDMARKS);
    let _map = never_reads::<[MapLandmark], LandmarkMapHeader>(&ipc, &prefix, &topics::MAP);
    let _odometry = never_reads::<Odometry, ()>(&ipc, &prefix, &topics::ODOMETRY);
    let _observations =
        never_reads::<[Observation], ObservationsHeader>(&ipc, &prefix, &topics::OBSERVATIONS);
    let out = dir.join("run");
    // Shorter than the processes' own wait timeout (60 s): a process that waits on the
    // subscriber that never reads outlives the launcher's timeout and fails the run.
    let run = std::process::Command::new(LAUNCHER)
        .args(["run", "--prefix", &prefix, "--out"])
        .arg(&out)
        .args(["--timeout-s", "50", "--scenario"])
        .arg(short_scenario(&dir))
        .output()
        .unwrap();
    assert_success(&run);
    // Each of them saw the subscriber, and left it behind.
    for process in ["truth-sim", "service", "odometry-sim", "lidar-sim"] {
        let log = std::fs::read_to_string(out.join("logs").join(format!("{process}.log")));
        assert!(
            log.as_ref()
                .is_ok_and(|l| l.contains("that are not the stack's own behind")),
            "{process}: {log:?}"
        );
    }
    let m = metrics(&out);
    let processes = m["cost"]["processes"].as_array().unwrap();
    let mut names: Vec<&str> = processes
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "client",
            "fastslam-service",
            "lidar-sim",
            "odometry-sim",
            "truth-sim"
        ],
        "the stack's own processes, and only those"
    );
    let own: f64 = processes.iter().map(|p| p["cpu_s"].as_f64().unwrap()).sum();
    // The same figures summed in another order: equal up to rounding (an outsider's CPU
    // would add milliseconds).
    let stack_cpu = num(&m, "/cost/stack_cpu_s");
    assert!(
        (stack_cpu - own).abs() <= 1e-9 * own.max(1.0),
        "{stack_cpu} vs {own}"
    );
    drop(ipc);
    remove_stack_files(&prefix, Some(&fastslam_stack::stack_root(&prefix)));
    assert_no_leftovers_and_remove(&prefix, &dir);
}
