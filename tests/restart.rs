//! Restarts and saved maps through the real processes: the service stopped by SIGTERM
//! leaves a checkpoint and a map that load; a service SIGKILLed again and again and
//! resumed each time gives the metrics of the run it interrupted, with landmarks and with
//! grid FastSLAM and its loop-closing back-end; a saved map drives a
//! localisation-only run that leaves it unchanged; bad checkpoint files and unknown flags
//! fail in one line.

mod common;

use common::*;
use fastslam_protocol::ipc::{Ipc, StackConfig};
use fastslam_protocol::{ServiceStatus, StreamId, topics};
use fastslam_service::checkpoint::{Checkpoint, EstimatorState};
use fastslam_service::map_file;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Short drive (300 observation steps) so each test stays well under 30 s.
const SCENARIO: &str = "bailey-short";

#[test]
fn sigterm_stops_the_service_cleanly_with_its_checkpoint_and_map() {
    let prefix = prefix("sigterm");
    let dir = folder(&prefix);
    let (ckpt, map) = (dir.join("run.ckpt"), dir.join("map.csv"));
    // In real time, so the stop lands mid-run however fast the stack is (as fast as
    // possible it can finish before the test sees the first checkpoint). The short drive
    // keeps the test short: the sensors finish their route after the service stopped.
    let launcher = Command::new(LAUNCHER)
        .args(["run", "--scenario"])
        .arg(short_scenario(&dir))
        .args(["--prefix", &prefix, "--realtime"])
        .args(["--timeout-s", "120", "--out"])
        .arg(dir.join("run"))
        .arg(format!("--service-flag=--checkpoint={}", ckpt.display()))
        .arg("--service-flag=--checkpoint-every=20")
        .arg(format!("--service-flag=--save-map={}", map.display()))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The first periodic checkpoint says the run is under way.
    wait_for("the first checkpoint", Duration::from_secs(30), || {
        ckpt.is_file()
    });
    stop_service_and_wait(&prefix, launcher);
    let log = std::fs::read_to_string(dir.join("run/logs/service.log")).unwrap();
    assert!(log.contains("stopped by signal"), "{log}");
    let checkpoint = Checkpoint::read(&ckpt).expect("the checkpoint loads");
    // The service's final status (before its end-of-stream) reached the client.
    let client_log = std::fs::read_to_string(dir.join("run/logs/client.log")).unwrap();
    let final_status = client_log
        .lines()
        .find(|l| l.contains("final status of the service"))
        .unwrap_or_else(|| panic!("no final status in the client's log: {client_log}"));
    assert!(
        final_status.contains(&format!("steps={}", checkpoint.steps)),
        "{final_status}"
    );
    let scans = scans_published(&dir.join("run/logs/lidar-sim.log"));
    assert!(
        (20..scans).contains(&checkpoint.steps),
        "stopped mid-run: {} steps of {scans} scans",
        checkpoint.steps
    );
    let lidar_ns = (checkpoint.processed_ns.iter())
        .find(|&&(stream, _)| stream != StreamId::Odometry as u32)
        .map_or(0, |&(_, stamp)| stamp);
    assert!(lidar_ns > 0, "{:?}", checkpoint.processed_ns);
    let saved = map_file::load(&map).expect("the map loads");
    let filter = checkpoint
        .filter
        .landmarks()
        .expect("a landmark filter's checkpoint");
    let best = &filter.maps[filter.particles[0].map as usize];
    assert!(!saved.is_empty() && saved.len() <= best.landmarks.len() + 30);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn localisation_only_on_a_saved_map_keeps_the_map_and_tracks_the_pose() {
    let prefix = prefix("localise");
    let dir = folder(&prefix);
    let (mapped, kept) = (dir.join("mapped.csv"), dir.join("kept.csv"));
    let mapping = dir.join("mapping");
    assert_success(&run_stack(
        &prefix,
        &mapping,
        &[
            "--scenario",
            SCENARIO,
            &format!("--service-flag=--save-map={}", mapped.display()),
        ],
    ));
    let localising = dir.join("localising");
    assert_success(&run_stack(
        &prefix,
        &localising,
        &[
            "--scenario",
            SCENARIO,
            &format!("--service-flag=--load-map={}", mapped.display()),
            "--service-flag=--localise-only",
            &format!("--service-flag=--save-map={}", kept.display()),
        ],
    ));
    let before = map_file::load(&mapped).unwrap();
    let after = map_file::load(&kept).unwrap();
    assert!(
        before.len() >= 10,
        "the mapping run mapped: {}",
        before.len()
    );
    assert_eq!(after, before, "localisation only leaves the map as it was");
    let ate = |out: &Path| num(&metrics(out), "/estimate/ate_rmse_m");
    let (ate_mapping, ate_localising) = (ate(&mapping), ate(&localising));
    eprintln!("ATE mapping {ate_mapping:.3} m, localising {ate_localising:.3} m");
    assert!(
        ate_localising < 2.0 * ate_mapping + 0.5,
        "localising ATE {ate_localising} m vs mapping {ate_mapping} m"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

/// Runs the service alone with `flags`; it must fail before joining any stack.
fn service_fails(prefix: &str, flags: &[&str]) -> String {
    let out = Command::new(LAUNCHER)
        .args(["service", "--prefix", prefix])
        .args(flags)
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .unwrap();
    assert!(!out.status.success(), "{flags:?} must fail");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let reason: Vec<&str> = stderr.lines().filter(|l| l.contains("rror")).collect();
    assert_eq!(reason.len(), 1, "one line says why: {stderr}");
    reason[0].to_string()
}

#[test]
fn bad_checkpoints_and_unknown_flags_fail_with_one_line() {
    let prefix = prefix("badfiles");
    let dir = folder(&prefix);
    let garbage = dir.join("garbage.ckpt");
    std::fs::write(&garbage, b"id,x,y\n").unwrap();
    let line = service_fails(&prefix, &["--resume", &garbage.display().to_string()]);
    assert!(line.contains("not a FastSLAM checkpoint"), "{line}");
    let missing = dir.join("missing.ckpt").display().to_string();
    let line = service_fails(&prefix, &["--resume", &missing]);
    assert!(line.contains("missing.ckpt"), "{line}");
    let line = service_fails(&prefix, &["--localise-only"]);
    assert!(line.contains("--load-map"), "{line}");
    let line = service_fails(&prefix, &["--no-such-flag"]);
    assert!(line.contains("--no-such-flag"), "{line}");
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_particle_count_whose_memory_exceeds_any_machine_is_refused_with_one_line() {
    let prefix = prefix("toomany");
    let dir = folder(&prefix);
    // A million particles, each with the first scan's grid out to 1 km: petabytes.
    let config = dir.join("huge.toml");
    std::fs::write(
        &config,
        "[map]\nkind = \"grid\"\n[grid]\nmax_range = 1000.0\n",
    )
    .unwrap();
    let config = config.display().to_string();
    let line = service_fails(&prefix, &["--particles", "1000000", "--config", &config]);
    assert!(
        line.contains("1000000 particles of a grid map need an estimated")
            && line.contains("PiB")
            && line.contains("available (MemAvailable)"),
        "{line}"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_sigkilled_service_resumes_from_its_checkpoint_without_a_long_gap() {
    let prefix = prefix("kill9");
    let dir = folder(&prefix);
    let run = dir.join("run");
    let ckpt = dir.join("run.ckpt").display().to_string();
    let every: u64 = 20;
    let every_s = every as f64 * 0.2; // the short drive observes every 0.2 s, as bailey-short
    let service = [
        "--seed",
        "1",
        "--wait-subscribers",
        "1",
        "--checkpoint",
        &ckpt,
        "--checkpoint-every",
        "20",
    ];
    // The short drive (about 60 scans) keeps the test short.
    let scenario = short_scenario(&dir).display().to_string();
    let sim = |subscribers: &'static str| {
        [
            "--scenario",
            &scenario,
            "--seed",
            "1",
            "--wait-subscribers",
            subscribers,
        ]
    };
    let mut stack = HandStack::new(&prefix, dir.join("logs"));
    stack.start("client", &["--out", &run.display().to_string()]);
    stack.start("service", &service);
    stack.start("odometry-sim", &sim("2"));
    stack.start("lidar-sim", &sim("2"));
    // Real time: the sensors do not run ahead, so what the dead service held is short.
    let mut truth = sim("3").to_vec();
    truth.push("--realtime");
    stack.start("truth-sim", &truth);

    wait_for("the first checkpoint", Duration::from_secs(30), || {
        Path::new(&ckpt).is_file()
    });
    stack.kill("service");
    assert!(stack.child("truth-sim").try_wait().unwrap().is_none());
    let mut resumed = service.to_vec();
    resumed.extend(["--resume", &ckpt]);
    stack.start("service", &resumed);
    let statuses = stack.wait_all(Duration::from_secs(150));
    for (name, status) in &statuses {
        assert!(
            status.success(),
            "{name} failed ({status}); logs in {}",
            dir.join("logs").display()
        );
    }

    let tum = std::fs::read_to_string(run.join("estimate.tum")).unwrap();
    let stamps: Vec<f64> = tum
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect();
    let scans = scans_published(&dir.join("logs").join("lidar-sim.0.log"));
    assert!(
        stamps.len() as u64 + every >= scans,
        "{} poses of {scans} scans",
        stamps.len()
    );
    let gap = stamps.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    assert!(
        gap <= every_s,
        "longest gap {gap:.2} s, checkpoint interval {every_s} s"
    );
    let ate = num(&metrics(&run), "/estimate/ate_rmse_m");
    eprintln!("resumed run: longest gap {gap:.2} s, ATE {ate:.3} m");
    assert!(ate < 3.0, "ATE {ate} m");
    drop(stack);
    assert_no_leftovers_and_remove(&prefix, &dir);
}

/// `n` distinct observation steps in `lo..hi`, drawn from `seed`, in increasing order.
fn seeded_steps(n: usize, seed: u64, lo: u64, hi: u64) -> Vec<u64> {
    let mut state = seed;
    let mut steps = std::collections::BTreeSet::new();
    while steps.len() < n {
        // xorshift64*
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        steps.insert(lo + state.wrapping_mul(0x2545_f491_4f6c_dd1d) % (hi - lo));
    }
    steps.into_iter().collect()
}

/// What a killed run drives: the sensors' scenario, and the service's flags besides its
/// seed, pace and checkpoints.
struct Drive {
    scenario: String,
    service: Vec<String>,
}

impl Drive {
    /// [`SCENARIO`] with the service's default settings.
    fn bailey() -> Self {
        Self {
            scenario: SCENARIO.into(),
            service: Vec::new(),
        }
    }
}

/// Runs `drive` through processes started one by one into the run folder
/// `<dir>/<name>`, SIGKILLing the service as soon as its status reports each of `kill_at`
/// steps and resuming it from its checkpoint; the run's reproducible metrics and how many
/// services ran. The service runs as fast as possible (its result does not depend on
/// timing); ground truth is paced at ten times real time, so that the route is still
/// being driven when the test's kill lands, even on a loaded machine.
fn killed_at(
    prefix: &str,
    dir: &Path,
    name: &str,
    drive: &Drive,
    kill_at: &[u64],
) -> (serde_json::Value, u64) {
    let m = killed_with_history(prefix, dir, name, drive, kill_at, None);
    assert_eq!(num(&m, "/inputs/rejected_total"), 0.0, "{m}");
    (reproducible(&dir.join(name)), kill_at.len() as u64 + 1)
}

/// [`killed_at`] with the sensors keeping at most `history_kib` KiB for a resumed
/// service (default: theirs); the run's metrics.
fn killed_with_history(
    prefix: &str,
    dir: &Path,
    name: &str,
    drive: &Drive,
    kill_at: &[u64],
    history_kib: Option<&str>,
) -> serde_json::Value {
    let run = dir.join(name);
    let ckpt = dir.join(format!("{name}.ckpt")).display().to_string();
    let mut service: Vec<&str> = vec![
        "--seed",
        "1",
        "--wait-subscribers",
        "1",
        "--as-fast-as-possible",
        "--checkpoint",
        &ckpt,
        "--checkpoint-every",
        "10",
    ];
    service.extend(drive.service.iter().map(String::as_str));
    let sim = |subscribers: &'static str| {
        [
            "--scenario",
            &drive.scenario,
            "--seed",
            "1",
            "--wait-subscribers",
            subscribers,
        ]
    };
    let mut stack = HandStack::new(prefix, dir.join(format!("{name}-logs")));
    // The test watches the service's steps on its status topic.
    let watcher = Ipc::open(
        &StackConfig {
            prefix: prefix.to_string(),
            root: Some(stack.root.display().to_string()),
        },
        "test-watcher",
        Duration::from_secs(60),
    )
    .unwrap();
    let status = watcher
        .optional_subscriber::<ServiceStatus>(&topics::STATUS)
        .unwrap();
    stack.start("client", &["--out", &run.display().to_string()]);
    stack.start("service", &service);
    let mut sensor = sim("2").to_vec();
    if let Some(kib) = history_kib {
        sensor.extend(["--history-kib", kib]);
    }
    stack.start("odometry-sim", &sensor);
    stack.start("lidar-sim", &sensor);
    let mut truth = sim("3").to_vec();
    truth.extend(["--realtime", "--rate", "10"]);
    stack.start("truth-sim", &truth);
    let mut resumed = service.clone();
    resumed.extend(["--resume", &ckpt]);
    for &step in kill_at {
        let mut steps = 0;
        wait_for(&format!("step {step}"), Duration::from_secs(60), || {
            status.drain(|s| steps = steps.max(s.steps)).unwrap();
            steps >= step
        });
        stack.kill("service");
        status.drain(|_| {}).unwrap();
        stack.start("service", &resumed);
    }
    for (process, status) in stack.wait_all(Duration::from_secs(120)) {
        assert!(
            status.success(),
            "{process} failed ({status}); logs in {}",
            stack.dir.display()
        );
    }
    drop(status);
    drop(watcher);
    metrics(&run)
}

#[test]
fn a_service_sigkilled_at_ten_random_steps_and_resumed_gives_the_uninterrupted_metrics() {
    let prefix = prefix("resume10");
    let dir = folder(&prefix);
    let (whole, _) = killed_at(&prefix, &dir, "whole", &Drive::bailey(), &[]);
    let kill_at = seeded_steps(10, 2024, 15, 280);
    let (resumed, services) = killed_at(&prefix, &dir, "killed", &Drive::bailey(), &kill_at);
    eprintln!(
        "killed at steps {kill_at:?}: {services} services, ATE {} m",
        num(&resumed, "/estimate/ate_rmse_m")
    );
    assert_eq!(
        resumed, whole,
        "the resumed run's metrics differ from the uninterrupted run's"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn a_grid_service_with_loop_closing_sigkilled_twice_and_resumed_gives_the_same_metrics() {
    let prefix = prefix("gridresume");
    let dir = folder(&prefix);
    // The office floor's first corridor (30 m, about 300 scans and 60 keyframes).
    let scenario = dir.join("office.toml");
    let text = rerouted("office-corridors", "office-corridor", "[[30.0, 0.0]]");
    std::fs::write(&scenario, text).unwrap();
    let office = fastslam_sensors_sim::Scenario::load(&scenario.display().to_string()).unwrap();
    // The scenario's service settings (grid FastSLAM, the hill climber), with the
    // loop-closing back-end solving every 10 keyframes, so that its solves and
    // correction are part of what is resumed.
    let table = office
        .service
        .expect("the office floor has [service] settings");
    let config = dir.join("service.toml");
    let loop_closing =
        "[loop_closure]\nenabled = true\nkeyframes_per_submap = 10\nsolve_every = 10\n";
    std::fs::write(&config, toml::to_string(&table).unwrap() + loop_closing).unwrap();
    let drive = Drive {
        scenario: scenario.display().to_string(),
        service: vec!["--config".into(), config.display().to_string()],
    };
    let (whole, _) = killed_at(&prefix, &dir, "whole", &drive, &[]);
    let (resumed, services) = killed_at(&prefix, &dir, "killed", &drive, &[95, 210]);
    let ckpt = Checkpoint::read(&dir.join("killed.ckpt")).expect("the checkpoint loads");
    let grid = match &ckpt.filter {
        EstimatorState::Grid(grid) => grid,
        EstimatorState::Landmarks(_) => panic!("a landmark checkpoint of a grid run"),
    };
    let back_end = grid.back_end.as_ref().expect("the back-end's keyframes");
    let indexed: usize = (grid.filter.particles.iter())
        .map(|p| p.grid.tiles.iter().filter(|&&t| t > 0).count())
        .sum();
    eprintln!(
        "{services} services, ATE {} m; last checkpoint: {} keyframes, {} distinct tiles \
         of {indexed} indexed",
        num(&resumed, "/estimate/ate_rmse_m"),
        back_end.keyframes.len(),
        grid.filter.tiles.len()
    );
    assert!(
        back_end.keyframes.len() > 40,
        "{}",
        back_end.keyframes.len()
    );
    // The last service resumed mid-run: it applied part of the scans, not all of them.
    let logs = dir.join("killed-logs");
    let published = scans_published(&logs.join("lidar-sim.0.log"));
    let (applied, _) = scans_from_shared_memory(&logs.join("service.2.log"));
    assert!(
        applied > 0 && applied + 95 <= published,
        "the last service applied {applied} of {published} scans"
    );
    assert!(
        grid.filter.tiles.len() * 3 < indexed,
        "shared tiles are written once: {} of {indexed}",
        grid.filter.tiles.len()
    );
    assert_eq!(
        resumed, whole,
        "the resumed grid run's metrics differ from the uninterrupted run's"
    );
    assert_no_leftovers_and_remove(&prefix, &dir);
}

#[test]
fn what_sensors_no_longer_keep_for_a_resumed_service_is_counted_as_lost() {
    let prefix = prefix("lost");
    let dir = folder(&prefix);
    // 1 KiB holds some 18 odometry messages; ten steps between checkpoints send about 80.
    let m = killed_with_history(
        &prefix,
        &dir,
        "small",
        &Drive::bailey(),
        &[105, 207],
        Some("1"),
    );
    let logged: u64 = ["odometry-sim", "lidar-sim"]
        .iter()
        .map(|sensor| {
            let log = std::fs::read_to_string(dir.join(format!("small-logs/{sensor}.0.log")));
            (log.unwrap().split("lost=").skip(1))
                .map(|rest| {
                    rest.split_whitespace()
                        .next()
                        .unwrap()
                        .parse::<u64>()
                        .unwrap()
                })
                .sum::<u64>()
        })
        .sum();
    let lost = num(&m, "/inputs/rejected/lost");
    eprintln!("lost {lost} inputs; the sensors logged {logged}");
    assert!(lost > 0.0, "nothing lost: {m}");
    assert_eq!(
        lost, logged as f64,
        "the service counts what the sensors lost"
    );
    assert_eq!(num(&m, "/inputs/rejected_total"), lost, "{m}");
    assert!(num(&m, "/estimate/poses") > 0.0);
    assert_no_leftovers_and_remove(&prefix, &dir);
}
