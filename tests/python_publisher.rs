//! A publisher written in Python plugs into the stack: `examples/python/publisher.py`
//! (iceoryx2 wheel from PyPI, the generated ctypes module) publishes odometry,
//! observations and ground truth; the real service and client run on it, started by the
//! harness a user's own test would use. The test bootstraps its own Python environment
//! (see [`common::python_with_iceoryx2`]).

mod common;

use common::*;
use fastslam_stack::harness::Stack;
use std::path::Path;
use std::process::Command;
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
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/python/publisher.py");
    let config = stack.config().clone();
    let mut publisher = Command::new(&python);
    publisher
        .arg(&script)
        .args(["--prefix", &config.prefix, "--iox-root"])
        .arg(config.root.as_deref().unwrap_or_default());
    stack.run_publisher(publisher).expect("publisher.py runs");
    let service_log = stack.log("service");
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
}
