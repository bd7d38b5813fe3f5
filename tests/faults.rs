//! Fault injection through real processes: the launcher runs the whole stack under its
//! own prefix while the test joins it as one more process and does damage.

mod common;

use common::*;
use fastslam_protocol::ipc::{Ipc, StackConfig};
use fastslam_protocol::status::{RejectionKind, ServiceStatus};
use fastslam_protocol::{Header, Odometry, topics};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The stack's iceoryx2 location, as `fastslam-stack run` derives it from the prefix.
fn stack(prefix: &str) -> StackConfig {
    StackConfig {
        prefix: prefix.to_string(),
        root: Some(
            std::env::temp_dir()
                .join("fsl")
                .join(prefix)
                .display()
                .to_string(),
        ),
    }
}

/// Starts `fastslam-stack run` in the background.
fn launch(prefix: &str, out: &std::path::Path, scenario: &str) -> Child {
    Command::new(LAUNCHER)
        .args(["run", "--prefix", prefix, "--scenario", scenario, "--out"])
        .arg(out)
        .args(["--timeout-s", "120"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting the launcher")
}

/// Odometry no sane publisher sends: non-finite numbers, stamps going back, stamps far
/// in the future, implausible speeds. `k` picks the flavour.
fn garbage(k: u64) -> Odometry {
    let header = Header {
        stamp_ns: 0,
        seq: k % 50,
    };
    let mut m = Odometry {
        header,
        ..Default::default()
    };
    match k % 4 {
        0 => m.v = f64::NAN,
        1 => m.x = f64::NEG_INFINITY,
        2 => m.header.stamp_ns = u64::MAX / 2,
        _ => m.header.stamp_ns = 1,
    }
    m
}

#[test]
fn a_garbage_publisher_is_counted_and_the_run_still_finishes() {
    let prefix = prefix("garbage");
    let dir = folder(&prefix);
    let out = dir.join("run");
    let mut launcher = launch(&prefix, &out, "bailey-short");
    let ipc = Ipc::open(&stack(&prefix), "garbage", Duration::from_secs(60)).unwrap();
    // Publishers before subscribers (see `Ipc::subscriber`).
    let bad = ipc.publisher::<Odometry>(&topics::ODOMETRY).unwrap();
    let status = ipc.subscriber::<ServiceStatus>(&topics::STATUS).unwrap();
    let mut newest = ServiceStatus::default();
    // A stream's very first message is trusted (nothing to check it against): start
    // the damage once the service has processed real input.
    let first = std::cell::Cell::new(ServiceStatus::default());
    ipc.wait_until(
        || "a first status".into(),
        || {
            status.drain(|s| first.set(*s.payload())).unwrap();
            first.get().steps > 0
        },
    )
    .unwrap();
    let started = Instant::now();
    let mut k = 0;
    let exit = loop {
        if let Some(exit) = launcher.try_wait().unwrap() {
            break exit;
        }
        assert!(
            started.elapsed() < Duration::from_secs(150),
            "launcher hangs"
        );
        for _ in 0..4 {
            bad.send(garbage(k)).unwrap();
            k += 1;
        }
        status
            .drain(|s| newest = *s.payload())
            .expect("receiving status");
        std::thread::sleep(Duration::from_millis(5)); // the publisher's pace, not a wait
    };
    drop((bad, status, ipc));
    let output = launcher.wait_with_output().unwrap();
    assert!(
        exit.success(),
        "launcher failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let rejected = |kind: RejectionKind| newest.rejections[kind as usize];
    for kind in [
        RejectionKind::NonFinite,
        RejectionKind::StampBackwards,
        RejectionKind::StampJump,
    ] {
        assert!(rejected(kind) > 0, "no {kind:?} counted: {newest:?}");
    }
    let m = metrics(&out);
    assert_eq!(m["complete"], true);
    assert!(num(&m, "/estimate/poses") > 100.0, "{m}");
    assert!(
        num(&m, "/estimate/ate_rmse_m") < num(&m, "/dead_reckoning/ate_rmse_m").max(5.0),
        "garbage spoilt the estimate: {m}"
    );
    let log = std::fs::read_to_string(out.join("logs").join("service.log")).unwrap();
    let logged = log.matches("odometry skipped").count();
    assert!(
        logged <= 20 && (logged as u64) < k / 4,
        "{logged} rejection lines for {k} bad messages: the log is not rate-limited"
    );
    remove_stack_files(&prefix, &std::env::temp_dir().join("fsl").join(&prefix));
    assert_eq!(leftovers(&prefix), (vec![], vec![]));
    std::fs::remove_dir_all(&dir).ok();
}
