//! Two hosts on one machine: each its own iceoryx2 root and stack prefix, one bridge each,
//! Zenoh over loopback TCP. The sensors and the client run on one "host", the FastSLAM
//! service on the other; the run gives the metrics of the same run on one host, also when
//! the sensor host's bridge is killed mid-run in real time and started again. A peer that
//! sends another contract version or another type is refused with the reason, and a
//! well-formed message from it arrives as it was sent.

mod common;

use common::*;
use fastslam_protocol::{CONTRACT_VERSION, Header, Odometry, ServiceStatus, topics};
use std::path::Path;
use std::time::Duration;
use zenoh::Wait;

/// A TCP port on loopback nobody listens on right now.
fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().port()
}

/// The flags of a simulated sensor (or the truth) on the short scenario, seed 1.
fn sim(scenario: &Path, subscribers: &str) -> Vec<String> {
    ["--scenario", &scenario.display().to_string(), "--seed", "1"]
        .into_iter()
        .chain(["--wait-subscribers", subscribers])
        .map(String::from)
        .collect()
}

/// Starts the sensors, the truth (with `truth_flags`) and the client on `stack`, the
/// client writing `out`.
fn start_sensors_and_client(
    stack: &mut HandStack,
    scenario: &Path,
    out: &Path,
    truth_flags: &[&str],
) {
    stack.start("client", &["--out", &out.display().to_string()]);
    stack.start("odometry-sim", &sim(scenario, "2"));
    stack.start("lidar-sim", &sim(scenario, "2"));
    let mut truth = sim(scenario, "3");
    truth.extend(truth_flags.iter().map(|f| f.to_string()));
    stack.start("truth-sim", &truth);
}

/// The run on one host, as fast as possible: the reference's run folder.
fn one_host_run(test: &str, dir: &Path, scenario: &Path) -> std::path::PathBuf {
    let out = dir.join("one-host");
    let mut one = HandStack::new(&prefix(test), dir.join("logs-one"));
    one.start("service", &SERVICE);
    start_sensors_and_client(&mut one, scenario, &out, &[]);
    all_succeed(&mut one, "one host");
    let prefix = one.prefix.clone();
    drop(one);
    assert_no_leftovers(&prefix);
    out
}

/// The two hosts of a bridged run: the sensor host (sensors, truth, client, a bridge
/// listening) and the service host (service, a bridge connecting).
struct TwoHosts {
    sensors: HandStack,
    service: HandStack,
    /// The sensor host's bridge's flags (to start it again).
    bridge: Vec<String>,
}

impl TwoHosts {
    /// Starts both bridges and the service; the sensor host's other processes are the
    /// test's to start.
    fn start(test: &str, dir: &Path) -> Self {
        let (prefix_a, prefix_b) = (prefix(&format!("{test}s")), prefix(&format!("{test}v")));
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let key = format!("fastslam/{prefix_a}");
        let mut sensors = HandStack::new(&prefix_a, dir.join("logs-sensors"));
        let mut service = HandStack::new(&prefix_b, dir.join("logs-service"));
        let bridge: Vec<String> = ["--side", "sensors", "--listen", &endpoint, "--key", &key]
            .map(String::from)
            .to_vec();
        sensors.start("bridge", &bridge);
        service.start(
            "bridge",
            &["--side", "service", "--connect", &endpoint, "--key", &key],
        );
        service.start("service", &SERVICE);
        Self {
            sensors,
            service,
            bridge,
        }
    }

    /// Waits until the service has taken `steps` filter steps, following its status as a
    /// process of the test's own (which leaves before the run ends).
    fn wait_for_steps(&self, steps: u64) {
        let ipc = self.service.join("test-watch");
        let status = ipc.subscriber::<ServiceStatus>(&topics::STATUS).unwrap();
        let mut taken = 0;
        wait_for(
            &format!("{steps} filter steps"),
            Duration::from_secs(60),
            || {
                status.drain(|s| taken = taken.max(s.steps)).unwrap();
                taken >= steps
            },
        );
    }

    /// Waits for every process of both hosts; each must succeed.
    fn all_succeed(&mut self) {
        all_succeed(&mut self.sensors, "sensor host");
        all_succeed(&mut self.service, "service host");
    }

    /// Drops both hosts (stopping what still runs) and checks nothing is left.
    fn finish(self) {
        let prefixes = [self.sensors.prefix.clone(), self.service.prefix.clone()];
        drop(self);
        for prefix in &prefixes {
            assert_no_leftovers(prefix);
        }
    }
}

/// The service's flags: seed 1, as fast as possible, waiting for one pose subscriber.
const SERVICE: [&str; 5] = [
    "--seed",
    "1",
    "--wait-subscribers",
    "1",
    "--as-fast-as-possible",
];

/// Waits for every process of `stack` and fails the test unless each exited 0.
fn all_succeed(stack: &mut HandStack, what: &str) {
    for (name, status) in stack.wait_all(Duration::from_secs(180)) {
        assert!(
            status.success(),
            "{what}: {name} failed ({status}); logs in {}",
            stack.dir.display()
        );
    }
}

#[test]
fn two_hosts_over_zenoh_give_the_metrics_of_one_host() {
    let dir = folder(&prefix("bridgetwo"));
    let scenario = short_scenario(&dir);
    let one_host = one_host_run("bridgeone", &dir, &scenario);

    let two_hosts = dir.join("two-hosts");
    let mut hosts = TwoHosts::start("bridgetwo", &dir);
    start_sensors_and_client(&mut hosts.sensors, &scenario, &two_hosts, &[]);
    hosts.all_succeed();
    assert_eq!(
        reproducible(&two_hosts),
        reproducible(&one_host),
        "the two-host run's metrics differ from the one-host run's"
    );
    assert!(num(&metrics(&two_hosts), "/estimate/poses") > 10.0);
    let log = std::fs::read_to_string(hosts.sensors.dir.join("bridge.0.log")).unwrap();
    assert!(log.contains("received topic=\"pose\""), "{log}");
    hosts.finish();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn run_split_across_two_hosts_gives_the_default_runs_metrics() {
    let prefix_one = prefix("splitone");
    let dir = folder(&prefix_one);
    let one_host = dir.join("one-host");
    assert_success(&run_stack(&prefix_one, &one_host, &[]));

    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let key = format!("fastslam/{prefix_one}");
    let (sensors, service) = (prefix("splitsensors"), prefix("splitservice"));
    let split = |prefix: &str, host: &str, peer: &str, out: &Path| {
        std::process::Command::new(LAUNCHER)
            .args(["run", "--prefix", prefix, "--timeout-s", "300"])
            .args(["--host", host, peer, &endpoint, "--key", &key, "--out"])
            .arg(out)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let service_host = split(&service, "service", "--listen", &dir.join("service-host"));
    let sensor_host = split(&sensors, "sensors", "--connect", &dir.join("sensor-host"));
    let (sensor_out, service_out) = (
        sensor_host.wait_with_output().unwrap(),
        service_host.wait_with_output().unwrap(),
    );
    assert_success(&sensor_out);
    assert_success(&service_out);
    assert!(
        String::from_utf8_lossy(&service_out.stdout).contains("the service finished"),
        "{service_out:?}"
    );
    assert_eq!(
        reproducible(&dir.join("sensor-host")),
        reproducible(&one_host),
        "the split run's metrics differ from the one-host run's"
    );
    for prefix in [&prefix_one, &sensors, &service] {
        assert_no_leftovers(prefix);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_sensor_hosts_bridge_killed_and_restarted_mid_run_loses_nothing() {
    let dir = folder(&prefix("bridgekill"));
    let scenario = short_scenario(&dir);
    let one_host = one_host_run("bridgekillone", &dir, &scenario);

    // The truth in real time, so the kill lands mid-run; the service takes its inputs as
    // they come, without deadlines, so the result does not depend on their timing.
    let two_hosts = dir.join("two-hosts");
    let mut hosts = TwoHosts::start("bridgekill", &dir);
    start_sensors_and_client(&mut hosts.sensors, &scenario, &two_hosts, &["--realtime"]);
    // A quarter of the drive's 60-odd scans through the bridges, however slow the start.
    hosts.wait_for_steps(15);
    hosts.sensors.kill("bridge");
    std::thread::sleep(Duration::from_millis(500));
    let bridge = hosts.bridge.clone();
    hosts.sensors.start("bridge", &bridge);
    hosts.all_succeed();

    assert_eq!(
        reproducible(&two_hosts),
        reproducible(&one_host),
        "the run with a bridge restarted mid-run differs from the one-host run"
    );
    let restarted = std::fs::read_to_string(hosts.sensors.dir.join("bridge.1.log")).unwrap();
    assert!(
        restarted.contains("asking the sensors for everything after it"),
        "{restarted}"
    );
    let peer = std::fs::read_to_string(hosts.service.dir.join("bridge.0.log")).unwrap();
    assert!(peer.contains("a peer came back"), "{peer}");
    hosts.finish();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_peer_of_another_contract_or_type_is_refused_and_a_good_message_arrives_whole() {
    let prefix = prefix("bridgepeer");
    let dir = folder(&prefix);
    let port = free_port();
    let key = format!("fastslam/{prefix}");
    let mut stack = HandStack::new(&prefix, dir.join("logs"));
    stack.start(
        "bridge",
        &[
            "--side",
            "service",
            "--listen",
            &format!("tcp/127.0.0.1:{port}"),
            "--key",
            &key,
        ],
    );
    // The test is the peer: it says it publishes odometry, and subscribes to what the
    // bridge then publishes on this host.
    let mut config = zenoh::Config::default();
    config
        .insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{port}\"]"))
        .unwrap();
    config
        .insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    let session = zenoh::open(config).wait().unwrap();
    let _token = session
        .liveliness()
        .declare_token(format!("{key}/publishers/odometry"))
        .wait()
        .unwrap();
    let publisher = session
        .declare_publisher(format!("{key}/data/odometry"))
        .wait()
        .unwrap();
    let ipc = stack.join("test-peer");
    let odometry = ipc.subscriber::<Odometry>(&topics::ODOMETRY).unwrap();
    wait_for(
        "the bridge to take odometry",
        Duration::from_secs(30),
        || publisher.matching_status().wait().unwrap().matching(),
    );

    let sent = Odometry {
        header: Header {
            stamp_ns: 1_000_000_000,
            seq: 0,
        },
        v: 1.5,
        omega: -0.25,
        ..Odometry::default()
    };
    let frame = |contract: u32, name: &str, body: &[u8]| {
        let mut frame = b"FSZB".to_vec();
        frame.extend_from_slice(&contract.to_le_bytes());
        frame.extend_from_slice(&(body.len() as u32).to_le_bytes());
        frame.extend_from_slice(&0u32.to_le_bytes());
        frame.extend_from_slice(&(name.len() as u16).to_le_bytes());
        frame.extend_from_slice(name.as_bytes());
        frame.extend_from_slice(body);
        frame
    };
    let body = bytemuck::bytes_of(&sent);
    publisher
        .put(frame(CONTRACT_VERSION + 1, "fastslam::Odometry", body))
        .wait()
        .unwrap();
    publisher
        .put(frame(CONTRACT_VERSION, "fastslam::Imu", body))
        .wait()
        .unwrap();
    publisher
        .put(frame(CONTRACT_VERSION, "fastslam::Odometry", body))
        .wait()
        .unwrap();

    let mut received = Vec::new();
    wait_for("the good message", Duration::from_secs(30), || {
        odometry.drain(|s| received.push(*s.payload())).unwrap();
        !received.is_empty()
    });
    assert_eq!(received, vec![sent], "only the good message arrives, whole");
    let log_path = stack.dir.join("bridge.0.log");
    let log = std::fs::read_to_string(&log_path).unwrap();
    assert!(
        log.contains(&format!(
            "contract version {} and this bridge {CONTRACT_VERSION}",
            CONTRACT_VERSION + 1
        )) && log.contains("run the same release"),
        "the refusal names both versions: {log}"
    );
    // Later refusals on the topic are counted, not logged again.
    assert_eq!(log.matches("refused what a peer sends").count(), 1, "{log}");
    drop((odometry, ipc, publisher, session));
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_bridge_whose_peer_never_comes_says_what_to_check() {
    let prefix = prefix("bridgealone");
    let dir = folder(&prefix);
    let mut stack = HandStack::new(&prefix, dir.join("logs"));
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    stack.start("bridge", &["--side", "sensors", "--listen", &endpoint]);
    let ipc = stack.join("test-sensor");
    let odometry = ipc.publisher::<Odometry>(&topics::ODOMETRY).unwrap();
    let log = stack.dir.join("bridge.0.log");
    wait_for("the bridge's warning", Duration::from_secs(40), || {
        std::fs::read_to_string(&log).is_ok_and(|l| l.contains("no peer has taken these"))
    });
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.contains("odometry") && text.contains("--side"),
        "{text}"
    );
    assert_eq!(text.matches("no peer has taken these").count(), 1, "{text}");
    drop((odometry, ipc));
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_bridge_without_peers_or_with_bad_flags_fails_in_one_line() {
    let prefix = prefix("bridgeflags");
    let dir = folder(&prefix);
    let out = dir.join("run").display().to_string();
    for (flags, says) in [
        (vec!["bridge", "--side", "sensors"], "--listen"),
        (
            vec![
                "bridge",
                "--export",
                "odometri",
                "--listen",
                "tcp/127.0.0.1:1",
            ],
            "cannot carry \"odometri\"",
        ),
        (
            vec!["bridge", "--side", "sensors", "--connect", "nonsense"],
            "--connect \"nonsense\"",
        ),
        (
            vec!["bridge", "--side", "sensors", "--listen", "tcp/nonsense"],
            "invalid socket address",
        ),
        (vec!["run", "--host", "sensors", "--out", &out], "--connect"),
        (
            vec![
                "run",
                "--host",
                "service",
                "--listen",
                "tcp/127.0.0.1:1",
                "--live",
            ],
            "sensor host",
        ),
    ] {
        let out = std::process::Command::new(LAUNCHER)
            .args(&flags[..1])
            .args(["--prefix", &prefix])
            .args(&flags[1..])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{flags:?} must fail");
        let stderr = String::from_utf8_lossy(&out.stderr);
        let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("error")).collect();
        assert_eq!(errors.len(), 1, "{stderr}");
        assert!(errors[0].contains(says), "{stderr}");
        assert!(
            !stderr.contains(".cargo/registry") && !stderr.contains("/rustc/"),
            "no build machine's paths: {stderr}"
        );
    }
    assert!(!dir.join("run").exists(), "nothing starts on bad flags");
    assert_no_leftovers_and_remove(&prefix, &dir);
}

/// An address nobody answers at (TEST-NET-1): dropped, refused or unroutable, as the
/// network has it.
const UNREACHABLE: &str = "tcp/192.0.2.1:7447";

#[test]
fn a_bridge_whose_peer_cannot_be_reached_gives_up_at_its_timeout_in_one_line() {
    let prefix = prefix("bridgeunreach");
    let dir = folder(&prefix);
    let mut stack = HandStack::new(&prefix, dir.join("logs"));
    let flags = ["--side", "service", "--connect", UNREACHABLE];
    stack.start("bridge", &[&flags[..], &["--wait-timeout-s", "3"]].concat());
    let statuses = stack.wait_all(Duration::from_secs(60));
    assert!(!statuses[0].1.success(), "{statuses:?}");
    let log = std::fs::read_to_string(stack.dir.join("bridge.0.log")).unwrap();
    let errors: Vec<&str> = (log.lines())
        .filter(|l| l.starts_with("error") || l.contains(" ERROR "))
        .collect();
    assert_eq!(errors.len(), 1, "{log}");
    assert!(
        errors[0].contains(&format!("no peer answered at {UNREACHABLE} within 3 s")),
        "{log}"
    );
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_bridge_stops_on_sigterm_while_it_connects() {
    let prefix = prefix("bridgeterm");
    let dir = folder(&prefix);
    let mut stack = HandStack::new(&prefix, dir.join("logs"));
    let flags = ["--side", "service", "--connect", UNREACHABLE];
    stack.start(
        "bridge",
        &[&flags[..], &["--wait-timeout-s", "600"]].concat(),
    );
    let log = stack.dir.join("bridge.0.log");
    // The bridge's own line as it starts connecting.
    wait_for("the bridge to connect", Duration::from_secs(30), || {
        std::fs::read_to_string(&log).is_ok_and(|l| l.contains("opening the Zenoh session"))
    });
    let pid = nix::unistd::Pid::from_raw(stack.child("bridge").id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM).unwrap();
    let statuses = stack.wait_all(Duration::from_secs(60));
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(statuses[0].1.success(), "{statuses:?}: {text}");
    assert!(text.contains("stopped by signal"), "{text}");
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}
