//! Grid FastSLAM on a synthetic room without a single landmark: the scan matcher keeps the
//! estimate on the true path while biased odometry drifts, and the numbers do not depend
//! on the number of threads.

mod common;

use common::cast;
use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::FastSlamConfig;
use fastslam_estimation::grid::GridConfig;
use fastslam_estimation::gridslam::{GridFastSlam, ScanMatchConfig};
use fastslam_estimation::motion::{Control, MotionModel, Unicycle};
use fastslam_estimation::moves::MoveConfig;
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::rng::seeded;
use fastslam_estimation::scan::RangeScan;
use rand::RngExt;
use rand_distr::StandardNormal;

/// A 14 m × 9 m room with a partition, a notch and a doorway: walls [x1, y1, x2, y2].
const WALLS: [[f64; 4]; 9] = [
    [-2.0, -2.0, 12.0, -2.0],
    [12.0, -2.0, 12.0, 7.0],
    [12.0, 7.0, 4.0, 7.0],
    [4.0, 7.0, 4.0, 5.5],
    [4.0, 5.5, -2.0, 5.5],
    [-2.0, 5.5, -2.0, -2.0],
    [5.0, 1.5, 5.0, 3.5],
    [8.0, 2.5, 10.0, 2.5],
    [1.0, 2.0, 2.5, 2.0],
];
const BEAMS: usize = 360;
const MAX_RANGE: f64 = 10.0;
const DT: f64 = 0.1;
/// Yaw-rate bias of the odometry (rad/s): dead reckoning turns away from the truth.
const BIAS: f64 = 0.02;

/// True controls of a loop around the partition: straight, turn left, … (v, ω) per step.
fn route() -> Vec<(f64, f64)> {
    let mut controls = Vec::new();
    for (metres, turn) in [(8.0, true), (4.0, true), (8.0, true), (4.0, false)] {
        controls.extend(std::iter::repeat_n((1.0, 0.0), (metres / DT) as usize));
        if turn {
            let steps = 20;
            let omega = std::f64::consts::FRAC_PI_2 / (steps as f64 * DT);
            controls.extend(std::iter::repeat_n((0.3, omega), steps));
        }
    }
    controls
}

fn filter(kind: OptimiserKind) -> GridFastSlam {
    let config = FastSlamConfig {
        particles: 20,
        seed: 3,
        motion: MotionModel::Unicycle(Unicycle {
            sigma_v: 0.05,
            sigma_omega: 0.05,
        }),
        ..FastSlamConfig::default()
    };
    let grid = GridConfig {
        resolution: 0.05,
        keyframe_distance: 0.3,
        max_range: MAX_RANGE,
        ..GridConfig::default()
    };
    let optimiser = OptimiserConfig {
        kind,
        ..OptimiserConfig::default()
    };
    GridFastSlam::new(
        config,
        grid,
        ScanMatchConfig::default(),
        &optimiser,
        MoveConfig::default(),
    )
    .unwrap()
}

/// Runs the route: per step the truth, the dead-reckoned pose and the estimate.
fn drive(slam: &mut GridFastSlam) -> Vec<(Pose2, Pose2, Pose2)> {
    let model = MotionModel::Unicycle(Unicycle::default());
    let mut rng = seeded(11);
    let (mut truth, mut reckoned) = (Pose2::default(), Pose2::default());
    let mut out = Vec::new();
    let mut ranges = vec![0f32; BEAMS];
    for (v, omega) in route() {
        let exact = Control {
            v,
            omega,
            steering: 0.0,
            ..Control::ZERO
        };
        truth = model.propagate(&truth, &exact, DT);
        let measured = Control {
            v: v + 0.02 * rng.sample::<f64, _>(StandardNormal),
            omega: omega + BIAS + 0.01 * rng.sample::<f64, _>(StandardNormal),
            steering: 0.0,
            ..Control::ZERO
        };
        reckoned = model.propagate(&reckoned, &measured, DT);
        slam.predict(&measured, DT).unwrap();
        let increment = std::f64::consts::TAU / BEAMS as f64;
        for (k, r) in ranges.iter_mut().enumerate() {
            let range = cast(&WALLS, truth.x, truth.y, truth.theta + k as f64 * increment);
            let noisy = range + 0.01 * rng.sample::<f64, _>(StandardNormal);
            *r = if range < MAX_RANGE {
                noisy as f32
            } else {
                f32::INFINITY
            };
        }
        let scan = RangeScan {
            angle_min: 0.0,
            angle_increment: increment,
            range_min: 0.1,
            range_max: MAX_RANGE,
            ranges: &ranges,
        };
        slam.observe(&scan).unwrap();
        out.push((truth, reckoned, slam.estimate().mean));
    }
    out
}

fn rmse(path: &[(Pose2, Pose2, Pose2)], pick: impl Fn(&(Pose2, Pose2, Pose2)) -> Pose2) -> f64 {
    let sum: f64 = path
        .iter()
        .map(|step| {
            let p = pick(step);
            (p.x - step.0.x).powi(2) + (p.y - step.0.y).powi(2)
        })
        .sum();
    (sum / path.len() as f64).sqrt()
}

#[test]
fn the_scan_matcher_holds_the_path_that_biased_odometry_loses() {
    for kind in [OptimiserKind::Hill, OptimiserKind::Pso] {
        let mut slam = filter(kind);
        let path = drive(&mut slam);
        let dead_reckoning = rmse(&path, |s| s.1);
        let estimate = rmse(&path, |s| s.2);
        assert!(
            dead_reckoning > 0.5,
            "the odometry drifts: {dead_reckoning} m"
        );
        assert!(
            estimate < 0.1 * dead_reckoning,
            "{kind}: ATE {estimate} m, dead reckoning {dead_reckoning} m"
        );
        assert!(slam.keyframes() > 50, "{} keyframes", slam.keyframes());
        let stats = slam.move_stats().unwrap();
        assert_eq!(
            stats.steps,
            slam.keyframes() - 1,
            "every keyframe but the first matched"
        );
    }
}

#[test]
fn one_and_two_threads_give_the_same_numbers() {
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut slam = filter(OptimiserKind::Hill);
            let path = drive(&mut slam);
            let bytes = slam.grid_bytes();
            (path, slam.occupancy().unwrap().cells, bytes)
        })
    };
    assert_eq!(on(1), on(2));
}
