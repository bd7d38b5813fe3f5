//! A publisher written in Python plugs into the stack: `examples/python/publisher.py`
//! (iceoryx2 wheel from PyPI, the generated ctypes module) publishes odometry,
//! observations and ground truth; the real service and client run on it, started by the
//! harness a user's own test would use; and `examples/python/subscriber.py` joins the
//! running stack from outside and reads every pose. The test bootstraps its own Python
//! environment (see [`common::python_with_iceoryx2`]).

mod common;

use common::*;
use fastslam_stack::harness::Stack;
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Service settings that suit the script's robot (its noise, known association).
const SERVICE_TOML: &str = include_str!("../examples/python/service.toml");

#[test]
fn the_service_runs_on_what_the_python_publisher_sends() {
    let python = python_with_iceoryx2();
    let mut stack = Stack::builder(LAUNCHER)
        .service_config(SERVICE_TOML)
        .start()
        .expect("the stack starts");
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/python");
    // An outside subscriber joins with the environment the stack hands out, after the
    // stack's client (the service waits for one pose subscriber); the publisher waits
    // for both on `pose`, so neither misses a pose (the topic keeps no history).
    let mut subscriber = Command::new(&python)
        .arg(examples.join("subscriber.py"))
        .args(["--after-subscribers", "1"])
        .envs(stack.env())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("subscriber.py starts");
    let mut stderr = subscriber.stderr.take().unwrap();
    let script = examples.join("publisher.py");
    let config = stack.config().clone();
    let mut publisher = Command::new(&python);
    publisher
        .arg(&script)
        .args(["--prefix", &config.prefix, "--iox-root"])
        .arg(config.root.as_deref().unwrap_or_default())
        .args(["--wait-pose-subscribers", "2"]);
    stack.run_publisher(publisher).expect("publisher.py runs");
    let service_log = stack.log("service");
    let stack_folder = stack.run_folder().to_path_buf();
    let m = stack
        .finish(Duration::from_secs(120))
        .expect("the run ends");
    let log = std::fs::read_to_string(&service_log).unwrap_or_default();
    assert!(
        !log.contains(" WARN "),
        "the service rejected inputs:\n{log}"
    );
    assert!(m.complete);
    // 63 s at 5 Hz: one estimate per scan, all read correctly.
    assert_eq!(m.estimate.poses, 315);
    let (ate, dead_reckoning) = (m.estimate.ate_rmse_m, m.dead_reckoning.ate_rmse_m);
    assert!(
        ate < 0.5 * dead_reckoning,
        "ATE {ate} m vs dead reckoning {dead_reckoning} m"
    );
    assert_eq!(m.map.matched, 12, "every landmark mapped where it is");
    assert!(m.map.rmse_m < 0.5, "{:?}", m.map);
    // The subscriber saw every pose the client scored, bit for bit the same stream.
    let seen = subscriber.wait_with_output().expect("subscriber.py ends");
    let mut said = String::new();
    stderr.read_to_string(&mut said).unwrap();
    assert!(seen.status.success(), "{said}");
    assert_eq!(said, "ready\nreceived 315 poses\n");
    let lines: Vec<String> = String::from_utf8(seen.stdout)
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect();
    assert_eq!(lines.len(), 315);
    let estimate = std::fs::read_to_string(stack_folder.join("estimate.tum")).unwrap();
    let last_stamp_s: f64 = estimate
        .lines()
        .last()
        .and_then(|l| l.split_whitespace().next())
        .and_then(|t| t.parse().ok())
        .unwrap();
    let subscriber_last_ns: f64 = lines[314].split(',').next().unwrap().parse().unwrap();
    assert!((subscriber_last_ns * 1e-9 - last_stamp_s).abs() < 1e-6);
}
