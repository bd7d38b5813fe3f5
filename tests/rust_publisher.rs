//! The Rust publisher example (`examples/rust/publisher.rs`) drives the real service and
//! client — tested only through the harness a user's own test would use
//! (`fastslam_stack::harness`).

use fastslam_stack::harness::Stack;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// The launcher, whose `service` and `client` subcommands the harness starts.
const LAUNCHER: &str = env!("CARGO_BIN_EXE_fastslam-stack");

/// Settings for the example's robot: known association, a unicycle with small noise (its
/// odometry is exact).
const SERVICE_TOML: &str = r#"
[filter]
particles = 20
[filter.motion]
model = "unicycle"
sigma_v = 0.01
sigma_omega = 0.01
[filter.association]
mode = "known"
"#;

#[test]
fn the_rust_publisher_example_drives_the_service_and_the_client() {
    let mut stack = Stack::builder(LAUNCHER)
        .service_config(SERVICE_TOML)
        .start()
        .expect("the stack starts");
    // Cargo builds the examples beside the test binaries' `deps` folder.
    let examples = Path::new(LAUNCHER).parent().unwrap().join("examples");
    stack
        .run_publisher(Command::new(examples.join("publisher")))
        .expect("the example publishes");
    let metrics = stack
        .finish(Duration::from_secs(120))
        .expect("the run ends");
    assert!(metrics.complete);
    // 60 s at 5 Hz: one pose per scan, the four landmarks mapped where they are.
    assert_eq!(metrics.estimate.poses, 300);
    assert!(metrics.estimate.ate_rmse_m < 0.2, "{:?}", metrics.estimate);
    assert_eq!((metrics.map.estimated, metrics.map.matched), (4, 4));
}
