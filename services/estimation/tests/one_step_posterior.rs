//! FastSLAM's optimiser modes against the exact posterior of one step
//! (docs/ALGORITHMS.md §3.1): a vehicle with a surveyed map drives for a second, then
//! observes four landmarks. The exact posterior of its pose is
//! `p(z | x, m) · prior(x)`, computed by importance sampling with 200 000 draws from the
//! prior the filter uses (the Gaussian `N(x̂, P)` when sampling is deferred, the motion
//! model's own draws otherwise). Over seeded repetitions of the filter, its pose estimate
//! must match that posterior's mean and variance within four standard errors in the
//! corrected modes — and miss it in the papers' mode, which collapses the cloud.

use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::{
    AssociationMode, FastSlam, FastSlamConfig, MapLandmark, OptimiserRefiner, PoseEstimate,
    PoseRefiner, ResamplingConfig, Scan,
};
use fastslam_estimation::motion::{Control, MotionModel, Unicycle};
use fastslam_estimation::moves::{MoveConfig, MoveCorrection};
use fastslam_estimation::observation::{Observation, measure};
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::rng::{SimRng, seeded};
use fastslam_estimation::stats::Summary;
use nalgebra::{Matrix2, Vector2, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;

const LANDMARKS: [(f64, f64); 4] = [(8.0, 3.0), (10.0, -4.0), (14.0, 1.0), (6.0, -6.0)];
const CONTROL: Control = Control {
    v: 2.0,
    omega: 0.1,
    steering: 0.0,
    ..Control::ZERO
};
const CONTROLS: usize = 10;
const DT: f64 = 0.1;
const PARTICLES: usize = 400;
const REPETITIONS: u64 = 12;

fn motion() -> MotionModel {
    MotionModel::Unicycle(Unicycle {
        sigma_v: 0.3,
        sigma_omega: 0.05,
    })
}

fn config(seed: u64, neff_ratio: f64) -> FastSlamConfig {
    let mut config = FastSlamConfig {
        particles: PARTICLES,
        seed,
        motion: motion(),
        resampling: ResamplingConfig {
            neff_ratio,
            ..ResamplingConfig::default()
        },
        ..FastSlamConfig::default()
    };
    config.association.mode = AssociationMode::Known;
    config
}

/// The four landmarks, surveyed to 1 mm.
fn map() -> Vec<MapLandmark> {
    LANDMARKS
        .iter()
        .enumerate()
        .map(|(id, &(x, y))| MapLandmark {
            id: id as u64,
            mean: Vector2::new(x, y),
            covariance: Matrix2::identity() * 1e-6,
            hits: 10,
        })
        .collect()
}

/// The scan: the landmarks seen from a pose off the noise-free prediction, with fixed
/// noise.
fn scan() -> Vec<Observation> {
    let mut truth = Pose2::default();
    for _ in 0..CONTROLS {
        truth = motion().propagate(&truth, &CONTROL, DT);
    }
    let truth = Pose2::new(truth.x + 0.12, truth.y - 0.05, truth.theta + 0.03);
    let mut rng = seeded(99);
    LANDMARKS
        .iter()
        .enumerate()
        .map(|(id, &(x, y))| {
            let z = measure(&truth, &Vector2::new(x, y));
            Observation {
                range: z[0] + 0.1 * rng.sample::<f64, _>(StandardNormal),
                bearing: z[1] + 0.0175 * rng.sample::<f64, _>(StandardNormal),
                id: Some(id as u64),
            }
        })
        .collect()
}

/// The filter after the drive, with its refiner for `kind` in `correction` mode.
fn driven(
    kind: OptimiserKind,
    correction: MoveCorrection,
    seed: u64,
) -> (FastSlam, Option<OptimiserRefiner>) {
    let neff_ratio = if correction == MoveCorrection::ResampleMove {
        1.0
    } else {
        0.5
    };
    let config = config(seed, neff_ratio);
    let optimiser = OptimiserConfig {
        kind,
        ..OptimiserConfig::default()
    };
    let moves = MoveConfig {
        correction,
        ..MoveConfig::default()
    };
    let refiner = OptimiserRefiner::new(&optimiser, moves, seed).unwrap();
    let mut slam = FastSlam::with_prior_map(config, Pose2::default(), &map()).unwrap();
    if refiner.as_ref().is_some_and(|r| r.needs_gaussian_prior()) {
        slam = slam.defer_sampling().unwrap();
    }
    for _ in 0..CONTROLS {
        slam.predict(&CONTROL, DT).unwrap();
    }
    (slam, refiner)
}

/// Mean and per-component variance of the exact posterior under the prior `draw` samples.
fn exact(draw: impl Fn(&mut SimRng) -> Pose2) -> (Vector3<f64>, Vector3<f64>) {
    let slam = FastSlam::with_prior_map(config(0, 0.5), Pose2::default(), &map()).unwrap();
    let map = slam.particles()[0].map().clone();
    let observations = scan();
    let sensor = slam.config().sensor.clone();
    let association = slam.config().association.clone();
    let scan = Scan::new(&observations, &sensor, &association, 1);
    let mut rng = seeded(7);
    let draws: Vec<(Pose2, f64)> = (0..200_000)
        .map(|_| {
            let x = draw(&mut rng);
            (x, scan.log_likelihood(&map, &x))
        })
        .collect();
    let max = draws.iter().map(|d| d.1).fold(f64::NEG_INFINITY, f64::max);
    let weights: Vec<f64> = draws.iter().map(|d| (d.1 - max).exp()).collect();
    let total: f64 = weights.iter().sum();
    let v = |p: &Pose2| Vector3::new(p.x, p.y, p.theta);
    let mean = draws
        .iter()
        .zip(&weights)
        .map(|((p, _), w)| v(p) * *w)
        .sum::<Vector3<f64>>()
        / total;
    let variance = draws
        .iter()
        .zip(&weights)
        .map(|((p, _), w)| (v(p) - mean).component_mul(&(v(p) - mean)) * *w)
        .sum::<Vector3<f64>>()
        / total;
    (mean, variance)
}

/// The filter's estimate of the step in `correction` mode: the published one, or for
/// resample-move the cloud after resampling and the moves.
fn estimate(kind: OptimiserKind, correction: MoveCorrection, seed: u64) -> PoseEstimate {
    let (mut slam, mut refiner) = driven(kind, correction, seed);
    let sensor = slam.config().sensor.clone();
    let mut published = None;
    let refiner = refiner.as_mut().map(|r| r as &mut dyn PoseRefiner);
    let report = slam
        .update_publishing(&scan(), &sensor, refiner, |e| published = Some(*e))
        .unwrap();
    if correction == MoveCorrection::ResampleMove {
        assert!(report.resampled);
        slam.estimate()
    } else {
        published.unwrap()
    }
}

/// Whether the estimates' mean and variance match `(mean, variance)` within four standard
/// errors over the repetitions, per component; and the description.
fn check(
    kind: OptimiserKind,
    correction: MoveCorrection,
    (mean, variance): (Vector3<f64>, Vector3<f64>),
) -> (bool, String) {
    let estimates: Vec<PoseEstimate> = (0..REPETITIONS)
        .map(|r| estimate(kind, correction, 100 + r))
        .collect();
    let mut ok = true;
    let mut text = format!("{kind} {correction}:");
    for d in 0..3 {
        let means: Vec<f64> = estimates
            .iter()
            .map(|e| [e.mean.x, e.mean.y, e.mean.theta][d])
            .collect();
        let ratios: Vec<f64> = estimates
            .iter()
            .map(|e| e.covariance[(d, d)] / variance[d])
            .collect();
        let (m, v) = (Summary::of(&means), Summary::of(&ratios));
        let se = |s: &Summary| s.std / (s.n as f64).sqrt();
        let z = (m.mean - mean[d]) / se(&m).max(1e-4 * variance[d].sqrt());
        ok &= z.abs() <= 4.0 && (v.mean - 1.0).abs() <= 4.0 * se(&v);
        text += &format!(
            " [{d}] mean off by {z:+.1} SE, variance ratio {:.3} ± {:.3}",
            v.mean,
            se(&v)
        );
    }
    (ok, text)
}

/// The exact posterior under deferred sampling's Gaussian prior.
fn gaussian_posterior() -> (Vector3<f64>, Vector3<f64>) {
    let (slam, _) = driven(OptimiserKind::Coa, MoveCorrection::Proposal, 1);
    let prior = *slam.particles()[0].prior();
    let factor = prior.covariance.cholesky().unwrap().l();
    exact(move |rng| {
        let e = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
        let d = factor * e;
        let m = prior.mean;
        Pose2::new(m.x + d[0], m.y + d[1], m.theta + d[2])
    })
}

/// The exact posterior under the motion model's own draws.
fn sampled_posterior() -> (Vector3<f64>, Vector3<f64>) {
    exact(|rng| {
        let mut x = Pose2::default();
        for _ in 0..CONTROLS {
            x = motion().sample(&x, &CONTROL, DT, rng);
        }
        x
    })
}

#[test]
fn the_optimised_proposal_matches_the_exact_posterior() {
    let exact = gaussian_posterior();
    for kind in [OptimiserKind::Icoa, OptimiserKind::Gwo, OptimiserKind::Pso] {
        let (ok, text) = check(kind, MoveCorrection::Proposal, exact);
        println!("{text}");
        assert!(ok, "{text}");
    }
}

#[test]
fn resample_move_keeps_the_exact_posterior() {
    let exact = gaussian_posterior();
    for kind in [OptimiserKind::Coa, OptimiserKind::Iba, OptimiserKind::Qpso] {
        let (ok, text) = check(kind, MoveCorrection::ResampleMove, exact);
        println!("{text}");
        assert!(ok, "{text}");
    }
}

#[test]
fn the_papers_mode_misses_the_exact_posterior() {
    let exact = sampled_posterior();
    let (ok, text) = check(OptimiserKind::None, MoveCorrection::None, exact);
    println!("{text} (FastSLAM 1.0, no optimiser)");
    assert!(ok, "{text}");
    for kind in [OptimiserKind::Coa, OptimiserKind::Pso] {
        let (ok, text) = check(kind, MoveCorrection::None, exact);
        println!("{text}");
        assert!(!ok, "{text}");
    }
}
