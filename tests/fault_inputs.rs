//! Faults of the stack's inputs, injected through real processes: a publisher of garbage,
//! an odometry flood, scans sent far ahead of their odometry, observations with unusable
//! ids. The launcher or the test runs the stack under its own prefix while the test joins
//! it as one more process and does damage.

mod common;

use common::stacks::{SimStack, launch, stack};
use common::*;
use fastslam_protocol::ipc::Ipc;
use fastslam_protocol::status::{RejectionKind, ServiceStatus};
use fastslam_protocol::{
    EndOfStream, Header, Observation, ObservationsHeader, Odometry, PoseEstimate, StreamId, topics,
};
use std::time::{Duration, Instant};

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
    // In real time, so the garbage meets a service in mid-run however fast the stack is.
    let mut launcher = launch(&prefix, &out, &short_scenario(&dir));
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
    assert!(num(&m, "/estimate/poses") > 40.0, "{m}");
    // Never silent: metrics.json counts the rejections by reason, the summary warns.
    assert!(num(&m, "/inputs/rejected/non_finite") > 0.0, "{m}");
    assert_eq!(
        num(&m, "/inputs/rejected_total") as u64,
        newest.rejections.iter().sum::<u64>(),
        "the service's final count"
    );
    let summary = String::from_utf8_lossy(&output.stdout);
    let warnings: Vec<&str> = (summary.lines())
        .filter(|l| l.contains("warning:") && l.contains("rejected"))
        .collect();
    assert_eq!(warnings.len(), 1, "one line for the rejections: {summary}");
    assert!(warnings[0].contains("non_finite"), "{summary}");
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
    remove_stack_files(&prefix, Some(&fastslam_stack::stack_root(&prefix)));
    assert_no_leftovers_and_remove(&prefix, &dir);
}

/// Resident memory of process `pid` (kB), from `/proc/<pid>/status`.
fn vm_rss_kb(pid: u32) -> Option<u64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = text.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[test]
fn an_odometry_flood_stays_bounded_and_poses_keep_coming() {
    let mut stack = SimStack::new("flood");
    let config = stack.dir.join("service.toml");
    std::fs::write(&config, "[input]\nmax_queue = 256\n").unwrap();
    stack.service_flags = vec!["--config".into(), config.display().to_string()];
    stack.truth_subscribers = 2; // lidar and client: the test is the odometry
    let ipc = stack.ipc();
    // Publishers before subscribers (see `Ipc::subscriber`).
    let odometry = ipc.publisher::<Odometry>(&topics::ODOMETRY).unwrap();
    let eos = ipc
        .publisher::<EndOfStream>(&topics::END_OF_STREAM)
        .unwrap();
    for name in ["client", "service", "lidar-sim", "truth-sim"] {
        stack.start(name);
    }
    let status = ipc.subscriber::<ServiceStatus>(&topics::STATUS).unwrap();
    let service = stack.pid("service");
    odometry.wait_for_subscribers(&ipc, 2).unwrap();
    // Nominal odometry: 40 Hz, 25 ms apart in stamps. The flood sends 400 Hz whose
    // stamps also run 10x ahead of the lidar, so the odometry queue overflows.
    let (period_ns, v) = (25_000_000u64, 3.0);
    let mut newest = ServiceStatus::default();
    let mut peak_kb = 0;
    let mut last = Header::default();
    for k in 0..1600u64 {
        last = Header {
            stamp_ns: k * period_ns,
            seq: k,
        };
        odometry
            .send(Odometry {
                header: last,
                v,
                x: v * (k * period_ns) as f64 * 1e-9,
                ..Default::default()
            })
            .unwrap();
        if k % 40 == 0 {
            status.drain(|s| newest = *s.payload()).unwrap();
            peak_kb = peak_kb.max(vm_rss_kb(service).unwrap_or(0));
        }
        std::thread::sleep(Duration::from_micros(2500)); // the flood's pace
    }
    eos.send(EndOfStream::new(StreamId::Odometry, Some(last)))
        .unwrap();
    let started = Instant::now();
    while stack
        .stack
        .children
        .iter_mut()
        .any(|(_, c)| c.try_wait().unwrap().is_none())
    {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the stack hangs"
        );
        status.drain(|s| newest = *s.payload()).unwrap();
        peak_kb = peak_kb.max(vm_rss_kb(service).unwrap_or(0));
        std::thread::sleep(Duration::from_millis(20));
    }
    stack.wait_all(Duration::from_secs(1));
    drop((odometry, eos, status, ipc));
    let overflow = newest.rejections[RejectionKind::Overflow as usize];
    assert!(overflow > 0, "no overflow counted: {newest:?}");
    assert!(newest.steps > 20, "poses stopped: {newest:?}");
    assert!(
        peak_kb > 0 && peak_kb < 200 * 1024,
        "service resident memory peaked at {peak_kb} kB"
    );
    println!(
        "flood: {overflow} overflows, {} steps, peak RSS {peak_kb} kB",
        newest.steps
    );
    let prefix = stack.stack.prefix.clone();
    drop(stack);
    assert_no_leftovers(&prefix);
}

/// One publisher that sends both streams from one thread, and more scans ahead of their
/// odometry than the service's lidar buffer holds: the service holds the first scan in
/// shared memory waiting for odometry, the buffer fills and the publisher's next send
/// waits, with the odometry still unsent. The service must give up holding (a copy) so
/// the publisher goes on; the run then ends with a pose for every scan.
#[test]
fn scans_sent_far_ahead_of_their_odometry_by_one_thread_do_not_stall_the_service() {
    let mut sim = SimStack::new("ahead");
    // A deadline (and so a hold limit) with room to spare on a loaded machine: the
    // odometry must never be given up for quiet here.
    let config = sim.dir.join("service.toml");
    std::fs::write(&config, "[input]\ndeadline_s = 4.0\n").unwrap();
    sim.service_flags = ["--lidar", "observations", "--config"]
        .map(String::from)
        .into_iter()
        .chain([config.display().to_string()])
        .collect();
    let scans = 4 * topics::OBSERVATIONS.buffer as u64;
    let (period_ns, v) = (25_000_000u64, 1.0);
    let header = move |k: u64| Header {
        stamp_ns: k * period_ns,
        seq: k,
    };
    let odometry_at = move |k: u64| Odometry {
        header: header(k),
        v,
        x: v * (k * period_ns) as f64 * 1e-9,
        ..Default::default()
    };
    let pole = Observation {
        range: 5.0,
        id: 0,
        ..Default::default()
    };
    // The publisher: a thread of its own (iceoryx2's ports stay on the thread that made
    // them), so that the test can watch for a stall while its sends wait.
    let config = stack(&sim.stack.prefix);
    let publisher = std::thread::spawn(move || {
        let ipc = Ipc::open(&config, "ahead", Duration::from_secs(30)).unwrap();
        let odometry = ipc.publisher::<Odometry>(&topics::ODOMETRY).unwrap();
        let lidar = ipc
            .slice_publisher::<ObservationsHeader, Observation>(&topics::OBSERVATIONS)
            .unwrap();
        let eos = ipc
            .publisher::<EndOfStream>(&topics::END_OF_STREAM)
            .unwrap();
        lidar.wait_for_subscribers(&ipc, 1).unwrap();
        odometry.send(odometry_at(0)).unwrap();
        for k in 1..=scans {
            let h = ObservationsHeader {
                header: header(k),
                count: 1,
                max_range: 30.0,
                min_bearing: -1.5,
                max_bearing: 1.5,
                ..Default::default()
            };
            lidar.send(h, &[pole]).unwrap();
        }
        for k in 1..=scans {
            odometry.send(odometry_at(k)).unwrap();
        }
        eos.send(EndOfStream::new(StreamId::Odometry, Some(header(scans))))
            .unwrap();
        eos.send(EndOfStream::new(
            StreamId::Observations,
            Some(header(scans)),
        ))
        .unwrap();
        // The lidar's samples live in its own segment: stay until the service has them.
        lidar.wait_until_unsubscribed(&ipc).unwrap();
    });
    let poses = poses_until_the_service_ends(&mut sim, publisher, scans);
    assert_eq!(poses, scans, "a pose per scan");
    let log_path = sim.stack.dir.join("service.0.log");
    let log = std::fs::read_to_string(&log_path).unwrap();
    let rejections = log
        .rsplit("rejections=[")
        .next()
        .and_then(|r| r.split(']').next());
    assert!(
        !log.contains("degraded") && rejections.is_some_and(|r| r.split(", ").all(|n| n == "0")),
        "the odometry was given up for quiet or refused: {log}"
    );
    let (applied, direct) = scans_from_shared_memory(&log_path);
    assert_eq!(applied, scans);
    assert!(
        direct < scans,
        "every scan from shared memory: the service never gave up holding ({direct})"
    );
    let prefix = sim.stack.prefix.clone();
    drop(sim);
    assert_no_leftovers(&prefix);
}

/// Under known association an observation's id must name a landmark: a message with a
/// negative id or one beyond the map's limit is refused as out of range and counted,
/// and the good messages around it each still give a pose.
#[test]
fn observations_with_unusable_ids_under_known_association_are_refused_and_counted() {
    let mut sim = SimStack::new("badids");
    let config = sim.dir.join("service.toml");
    std::fs::write(&config, "[filter.association]\nmode = \"known\"\n").unwrap();
    sim.service_flags = [
        "--lidar",
        "observations",
        "--as-fast-as-possible",
        "--config",
    ]
    .map(String::from)
    .into_iter()
    .chain([config.display().to_string()])
    .collect();
    let bad_ids = [-7, 1 << 62, -7, 1 << 62];
    let scans = 3 * bad_ids.len() as u64;
    let (period_ns, v) = (25_000_000u64, 1.0);
    let header = move |k: u64| Header {
        stamp_ns: k * period_ns,
        seq: k,
    };
    let config = stack(&sim.stack.prefix);
    let publisher = std::thread::spawn(move || {
        let ipc = Ipc::open(&config, "badids", Duration::from_secs(30)).unwrap();
        let odometry = ipc.publisher::<Odometry>(&topics::ODOMETRY).unwrap();
        let lidar = ipc
            .slice_publisher::<ObservationsHeader, Observation>(&topics::OBSERVATIONS)
            .unwrap();
        let eos = ipc
            .publisher::<EndOfStream>(&topics::END_OF_STREAM)
            .unwrap();
        lidar.wait_for_subscribers(&ipc, 1).unwrap();
        for k in 0..=scans {
            odometry
                .send(Odometry {
                    header: header(k),
                    v,
                    x: v * (k * period_ns) as f64 * 1e-9,
                    ..Default::default()
                })
                .unwrap();
            if k == 0 {
                continue;
            }
            // Every third scan carries an unusable id next to a good one.
            let id = match k % 3 {
                0 => bad_ids[(k / 3 - 1) as usize],
                _ => 1,
            };
            let seen = [0, id].map(|id| Observation {
                range: 5.0,
                id,
                ..Default::default()
            });
            let h = ObservationsHeader {
                header: header(k),
                count: 2,
                max_range: 30.0,
                min_bearing: -1.5,
                max_bearing: 1.5,
                ..Default::default()
            };
            lidar.send(h, &seen).unwrap();
        }
        for stream in [StreamId::Odometry, StreamId::Observations] {
            eos.send(EndOfStream::new(stream, Some(header(scans))))
                .unwrap();
        }
        lidar.wait_until_unsubscribed(&ipc).unwrap();
    });
    let poses = poses_until_the_service_ends(&mut sim, publisher, scans);
    let bad = bad_ids.len() as u64;
    assert_eq!(poses, scans - bad, "a pose per good scan");
    let log = std::fs::read_to_string(sim.stack.dir.join("service.0.log")).unwrap();
    let counts: Vec<u64> = log
        .rsplit("rejections=[")
        .next()
        .and_then(|r| r.split(']').next())
        .map(|r| r.split(", ").filter_map(|n| n.parse().ok()).collect())
        .unwrap_or_default();
    assert_eq!(
        counts.get(RejectionKind::OutOfRange as usize),
        Some(&bad),
        "every unusable id counted as out of range: {log}"
    );
    assert_eq!(
        counts.iter().sum::<u64>(),
        bad,
        "nothing else refused: {log}"
    );
    let prefix = sim.stack.prefix.clone();
    drop(sim);
    assert_no_leftovers(&prefix);
}

/// Starts the service of `sim` (its publisher thread `publisher` already sending up to
/// `scans` scans), counts the poses it publishes until it exits (failing after 60 s),
/// then joins the publisher and waits for the rest of the stack.
fn poses_until_the_service_ends(
    sim: &mut SimStack,
    publisher: std::thread::JoinHandle<()>,
    scans: u64,
) -> u64 {
    sim.start("service");
    // The test stands in for the stack's client, whose pose subscription the service
    // waits for: it joins under the client's node name.
    let ipc = Ipc::open(&stack(&sim.stack.prefix), "client", Duration::from_secs(30)).unwrap();
    let pose = ipc.subscriber::<PoseEstimate>(&topics::POSE).unwrap();
    let started = Instant::now();
    let mut poses = 0;
    while sim.stack.child("service").try_wait().unwrap().is_none() {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the service stalls: {poses} poses of {scans}"
        );
        poses += pose.drain(|_| {}).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    poses += pose.drain(|_| {}).unwrap();
    publisher.join().expect("the publisher failed");
    sim.wait_all(Duration::from_secs(1));
    drop((pose, ipc));
    poses as u64
}
