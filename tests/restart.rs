//! Restarts and saved maps through the real processes: the service stopped by SIGTERM
//! leaves a checkpoint and a map that load; a saved map drives a localisation-only run
//! that leaves it unchanged; bad checkpoint files and unknown flags fail in one line.

mod common;

use common::*;
use fastslam_service::checkpoint::Checkpoint;
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
    let launcher = Command::new(LAUNCHER)
        .args(["run", "--scenario", SCENARIO, "--prefix", &prefix])
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
    let pid = service_pid(&prefix).expect("the service is running");
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(pid),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let out = launcher.wait_with_output().unwrap();
    // The launcher fails (1) as soon as a process exits non-zero; the others finish
    // their streams once the service has said end-of-stream.
    assert_eq!(
        out.status.code(),
        Some(0),
        "the service exited 0 and the stack finished: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = std::fs::read_to_string(dir.join("run/logs/service.log")).unwrap();
    assert!(log.contains("stopped by signal"), "{log}");
    let checkpoint = Checkpoint::read(&ckpt).expect("the checkpoint loads");
    assert!(
        (20..300).contains(&checkpoint.steps),
        "stopped mid-run: {} steps",
        checkpoint.steps
    );
    assert!(checkpoint.processed_ns[1] > 0);
    let saved = map_file::load(&map).expect("the map loads");
    let best = &checkpoint.filter.maps[checkpoint.filter.particles[0].map as usize];
    assert!(!saved.is_empty() && saved.len() <= best.landmarks.len() + 30);
    assert_eq!(
        leftovers(&prefix),
        (vec![], vec![]),
        "processes or shared memory left behind"
    );
    std::fs::remove_dir_all(&dir).ok();
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
    assert_eq!(leftovers(&prefix), (vec![], vec![]));
    std::fs::remove_dir_all(&dir).ok();
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
    assert_eq!(leftovers(&prefix), (vec![], vec![]));
    std::fs::remove_dir_all(&dir).ok();
}
