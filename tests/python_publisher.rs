//! A publisher written in Python plugs into the stack: `examples/python/publisher.py`
//! (iceoryx2 wheel from PyPI, the generated ctypes module) publishes odometry,
//! observations and ground truth; the real service and client run on it. The test
//! bootstraps its own Python environment (see [`common::python_with_iceoryx2`]).

mod common;

use common::*;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Service settings that suit the script's robot (its noise, known association).
const SERVICE_TOML: &str = r#"
[filter]
particles = 50
[filter.motion]
model = "unicycle"
sigma_v = 0.05
sigma_omega = 0.02
[filter.sensor]
sigma_range = 0.1
sigma_bearing = 0.01
max_range = 15.0
[filter.association]
mode = "known"
"#;

/// Stops the stack's processes (SIGTERM) and removes its files, also when the test fails.
struct Stack {
    children: Vec<Child>,
    prefix: String,
    root: std::path::PathBuf,
}

impl Drop for Stack {
    fn drop(&mut self) {
        for c in &mut self.children {
            if c.try_wait().ok().flatten().is_none() {
                let _ = nix::sys::signal::kill(
                    nix::unistd::Pid::from_raw(c.id() as i32),
                    nix::sys::signal::Signal::SIGTERM,
                );
                let _ = c.wait();
            }
        }
        remove_stack_files(&self.prefix, Some(&self.root));
    }
}

/// Waits for `child` up to `limit`; its exit status, or `None` when it is still running.
fn wait_for(child: &mut Child, limit: Duration) -> Option<std::process::ExitStatus> {
    let start = Instant::now();
    while start.elapsed() < limit {
        if let Some(status) = child.try_wait().expect("polling a child") {
            return Some(status);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    None
}

#[test]
fn the_service_runs_on_what_the_python_publisher_sends() {
    let python = python_with_iceoryx2();
    let prefix = prefix("python");
    let dir = folder(&prefix);
    let root = fastslam_stack::stack_root(&prefix);
    let config = dir.join("service.toml");
    std::fs::write(&config, SERVICE_TOML).unwrap();
    let out = dir.join("run");
    let stack_flags = |role: &str| {
        let mut c = Command::new(LAUNCHER);
        c.arg(role)
            .args(["--prefix", &prefix, "--iox-root"])
            .arg(&root)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join(format!("{role}.log"))).unwrap());
        c
    };
    let mut stack = Stack {
        children: Vec::new(),
        prefix: prefix.clone(),
        root: root.clone(),
    };
    let service = stack_flags("service")
        .arg("--config")
        .arg(&config)
        .args(["--wait-subscribers", "1"])
        .spawn()
        .expect("starting the service");
    stack.children.push(service);
    let client = stack_flags("client")
        .arg("--out")
        .arg(&out)
        .spawn()
        .expect("starting the client");
    stack.children.push(client);

    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/python/publisher.py");
    let published = Command::new(&python)
        .arg(&script)
        .args(["--prefix", &prefix, "--iox-root"])
        .arg(&root)
        .args(["--wait-subscribers", "2"]) // service and client
        .output()
        .expect("starting the Python publisher");
    assert!(
        published.status.success(),
        "publisher.py failed:\n{}",
        String::from_utf8_lossy(&published.stderr)
    );
    let client_status = wait_for(&mut stack.children[1], Duration::from_secs(120));
    let log =
        |role: &str| std::fs::read_to_string(dir.join(format!("{role}.log"))).unwrap_or_default();
    assert!(
        client_status.is_some_and(|s| s.success()),
        "the client did not finish ({client_status:?}):\n{}\nservice:\n{}",
        log("client"),
        log("service")
    );
    assert!(
        !log("service").contains(" WARN "),
        "the service rejected inputs:\n{}",
        log("service")
    );

    let m = metrics(&out);
    assert_eq!(m["complete"], true, "{m}");
    // 63 s at 5 Hz: one estimate per scan, all read correctly.
    assert_eq!(num(&m, "/estimate/poses"), 315.0, "{m}");
    let (ate, dead_reckoning) = (
        num(&m, "/estimate/ate_rmse_m"),
        num(&m, "/dead_reckoning/ate_rmse_m"),
    );
    assert!(
        ate < 0.5 * dead_reckoning,
        "ATE {ate} m vs dead reckoning {dead_reckoning} m"
    );
    assert_eq!(
        num(&m, "/map/matched"),
        12.0,
        "every landmark mapped where it is: {m}"
    );
    assert!(num(&m, "/map/rmse_m") < 0.5, "{m}");
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}
