//! Odometry from the laser alone on a synthetic world: a laser mounted ahead of the base
//! driven once round a ring corridor, its poses against the truth.

mod common;

use common::{BEAMS, Segment, beam_angle, corridor_world, scan};
use fastslam_estimation::Pose2;
use fastslam_estimation::laser_odometry::{LaserOdometry, LaserOdometryConfig};
use fastslam_estimation::scan::RangeScan;
use fastslam_estimation::wrap_angle;

/// Scans per second.
const RATE: f64 = 10.0;

/// The base's pose at each scan once round the ring: `speed` (m/s) along the sides,
/// turning on the spot at `turn_rate` (rad/s) at the corners.
fn lap(speed: f64, turn_rate: f64) -> Vec<Pose2> {
    let mut path = Vec::new();
    let mut pose = Pose2::default();
    for _ in 0..4 {
        let steps = (10.0 / (speed / RATE)).round() as usize;
        for _ in 0..steps {
            path.push(pose);
            pose = pose.compose(&Pose2::new(speed / RATE, 0.0, 0.0));
        }
        let turns = (std::f64::consts::FRAC_PI_2 / (turn_rate / RATE)).round() as usize;
        let step = std::f64::consts::FRAC_PI_2 / turns as f64;
        for _ in 0..turns {
            path.push(pose);
            pose = pose.compose(&Pose2::new(0.0, 0.0, step));
        }
    }
    path.push(pose);
    path
}

/// Each scan's pose by the laser odometry, for the base driven along `path` round the
/// ring corridor, scan `k` at `k / RATE` seconds, and how many scans matched.
fn track(path: &[Pose2], mount: &Pose2) -> (Vec<Pose2>, usize) {
    let scans: Vec<(usize, Pose2)> = path.iter().copied().enumerate().collect();
    track_in(&corridor_world(), &scans, mount)
}

/// [`track`] of the scans `(k, pose)` in `world`, each with 1 cm of range noise.
fn track_in(world: &[Segment], scans: &[(usize, Pose2)], mount: &Pose2) -> (Vec<Pose2>, usize) {
    let mut odometry = LaserOdometry::new(LaserOdometryConfig::default(), *mount);
    let poses = (scans.iter())
        .map(|&(k, ref pose)| {
            let ranges: Vec<f32> = scan(world, &pose.compose(mount), 0.01, k as u64)
                .into_iter()
                .map(|r| r as f32)
                .collect();
            let scan = RangeScan {
                angle_min: beam_angle(0),
                angle_increment: std::f64::consts::TAU / BEAMS as f64,
                range_min: 0.1,
                range_max: 30.0,
                ranges: &ranges,
            };
            odometry.track(k as f64 / RATE, &scan)
        })
        .collect();
    (poses, odometry.counts().matched)
}

/// The largest error of the motion between consecutive scans: translation (m) and
/// rotation (rad).
fn worst_step(path: &[Pose2], poses: &[Pose2]) -> (f64, f64) {
    (1..path.len()).fold((0.0, 0.0), |(t, r), k| {
        let truth = path[k - 1].inverse().compose(&path[k]);
        let got = poses[k - 1].inverse().compose(&poses[k]);
        let e = truth.inverse().compose(&got);
        (t.max(e.x.hypot(e.y)), r.max(wrap_angle(e.theta).abs()))
    })
}

/// Every step's motion within 3 cm and 1° of the truth's.
fn assert_steps_close(path: &[Pose2], poses: &[Pose2]) {
    let (step, turn) = worst_step(path, poses);
    assert!(step < 0.03, "a step off by {step:.4} m");
    let degrees = turn.to_degrees();
    assert!(degrees < 1.0, "a turn off by {degrees:.3}°");
}

/// `got` within 20 cm and 1° of `truth`.
fn assert_ends_close(truth: &Pose2, got: &Pose2) {
    let end = truth.inverse().compose(got);
    assert!(end.x.hypot(end.y) < 0.2, "ends {end:?} off");
    let degrees = wrap_angle(end.theta).abs().to_degrees();
    assert!(degrees < 1.0, "ends {end:?} off");
}

#[test]
fn a_lap_of_the_ring_drifts_by_centimetres() {
    let mount = Pose2::new(0.25, 0.0, 0.0);
    let path = lap(0.5, 1.0);
    let (poses, matched) = track(&path, &mount);
    assert_eq!(
        matched,
        path.len() - 1,
        "every scan after the first matches"
    );
    assert_steps_close(&path, &poses);
    // 40 m and four corners: the end within 0.5 % of the distance of the truth.
    assert_ends_close(path.last().unwrap(), poses.last().unwrap());
}

#[test]
fn fast_turns_on_the_spot_are_followed() {
    // 3 rad/s at 10 Hz: 17° between scans, with the speed changing at every corner.
    let mount = Pose2::new(0.25, 0.0, 0.0);
    let path = lap(1.0, 3.0);
    let (poses, matched) = track(&path, &mount);
    assert_eq!(matched, path.len() - 1);
    assert_steps_close(&path, &poses);
}

#[test]
fn a_gap_in_the_scans_during_a_turn_is_bridged() {
    // No scan for 1.4 s from the start of the first corner: the base turns 1.4 rad unseen.
    let mount = Pose2::new(0.25, 0.0, 0.0);
    let path = lap(0.5, 1.0);
    let corner = (10.0 / 0.05) as usize;
    let scans: Vec<(usize, Pose2)> = (path.iter().copied().enumerate())
        .filter(|(k, _)| !(corner + 1..corner + 15).contains(k))
        .collect();
    let (poses, matched) = track_in(&corridor_world(), &scans, &mount);
    assert_eq!(matched, scans.len() - 1);
    assert_ends_close(&scans.last().unwrap().1, poses.last().unwrap());
}

#[test]
fn a_corridor_is_tracked_by_the_wall_at_its_end() {
    // Two parallel walls 2 m apart and a wall across behind the start: along the corridor
    // only that end wall, up to 9.5 m away, tells how far the base went; the side walls,
    // seen at grazing angles, must not hold the pose where their beams ended before.
    let world: Vec<Segment> = vec![
        [-40.0, -1.0, 40.0, -1.0],
        [-40.0, 1.0, 40.0, 1.0],
        [-2.0, -1.0, -2.0, 1.0],
    ];
    let scans: Vec<(usize, Pose2)> = (0..150)
        .map(|k| (k, Pose2::new(k as f64 * 0.05, 0.0, 0.0)))
        .collect();
    let (poses, _) = track_in(&world, &scans, &Pose2::default());
    let (last, truth) = (poses.last().unwrap(), scans.last().unwrap().1);
    assert!((last.x - truth.x).abs() < 0.1, "{last:?} against {truth:?}");
    assert!(last.y.abs() < 0.05 && last.theta.abs() < 0.01, "{last:?}");
}
