//! The odometry constraints' weight fitted at the end of the data
//! ([`PoseGraphMapper::fit_odometry_weight`], [`PoseGraphMapper::finish`]), on a
//! simulated ring whose odometry is more precise than its model says.

use super::{Keyframe, LoopClosure, LoopClosureConfig, Odometry, OdometryFit, PoseGraphMapper};
use crate::pose::Pose2;
use crate::rng::SimRng;
use nalgebra::Matrix3;
use rand_distr::{Distribution, StandardNormal};

/// Keyframes around the ring.
const KEYFRAMES: usize = 240;
/// The front end's steps: modelled and true σ (m, rad).
const STEP_SIGMA: (f64, f64) = (0.03, 0.01);
/// The odometry's modelled σ; its true σ is a quarter of it (m, rad).
const ODOMETRY_SIGMA: (f64, f64) = (0.06, 0.02);

/// `delta` with Gaussian noise of σ `(xy, θ)` on each component.
fn noisy(delta: &Pose2, sigma: (f64, f64), rng: &mut SimRng) -> Pose2 {
    let mut normal = || -> f64 { StandardNormal.sample(rng) };
    Pose2::new(
        delta.x + sigma.0 * normal(),
        delta.y + sigma.0 * normal(),
        delta.theta + sigma.1 * normal(),
    )
}

/// The mapper after a solve of the ring (twice around a circle of 0.5 m steps, each
/// keyframe after the first lap closed against the submap it passed a lap before), and
/// the true poses; the odometry constraints as `odometry_constraints` says.
fn ring(seed: u64, odometry_constraints: bool) -> (PoseGraphMapper, Vec<Pose2>) {
    let mut rng = crate::rng::seeded(seed);
    let step = Pose2::new(0.5, 0.0, 2.0 * std::f64::consts::TAU / KEYFRAMES as f64);
    let truth: Vec<Pose2> =
        std::iter::successors(Some(Pose2::default()), |p| Some(p.compose(&step)))
            .take(KEYFRAMES)
            .collect();
    let diagonal =
        |s: (f64, f64)| Matrix3::from_diagonal(&[s.0 * s.0, s.0 * s.0, s.1 * s.1].into());
    let config = LoopClosureConfig {
        between_floor_xy: 1e-6,
        between_floor_theta: 1e-6,
        odometry_constraints,
        ..LoopClosureConfig::default()
    };
    let mut mapper = PoseGraphMapper::new(config).unwrap();
    let mut front_end = Pose2::default();
    for (k, p) in truth.iter().enumerate() {
        let mut odometry = None;
        if k > 0 {
            let previous = front_end;
            front_end = previous.compose(&noisy(&step, STEP_SIGMA, &mut rng));
            let quarter = (ODOMETRY_SIGMA.0 / 4.0, ODOMETRY_SIGMA.1 / 4.0);
            odometry = Some(Odometry {
                predicted: previous.compose(&noisy(&step, quarter, &mut rng)),
                covariance: rotated(&diagonal(ODOMETRY_SIGMA), previous.theta),
            });
        }
        let keyframe = Keyframe {
            stamp_ns: k as u64,
            pose: front_end,
            covariance: rotated(&diagonal(STEP_SIGMA), front_end.theta),
            points: Vec::new(),
            beams: Vec::new(),
            sensor: Pose2::default(),
            odometry,
        };
        mapper.add_keyframe(keyframe).unwrap();
        let lap = KEYFRAMES / 2;
        if k >= lap {
            let submap = (k - lap) / mapper.config().keyframes_per_submap;
            let anchor = mapper.submaps()[submap].anchor();
            let seen = truth[anchor].inverse().compose(p);
            mapper
                .add_loop_closure(LoopClosure {
                    keyframe: k,
                    submap,
                    pose: noisy(&seen, (0.05, 0.01), &mut rng),
                    score: 0.9,
                    lever: 5.0,
                    curvature: None,
                })
                .unwrap();
        }
    }
    mapper.solve().unwrap();
    (mapper, truth)
}

/// A covariance given on a keyframe's own axes, on the map's axes.
fn rotated(covariance: &Matrix3<f64>, theta: f64) -> Matrix3<f64> {
    let (s, c) = theta.sin_cos();
    let r = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
    r * covariance * r.transpose()
}

/// Mean position error of the steps between consecutive keyframes of `poses` against
/// `truth` (m): the short relations the odometry holds best.
fn step_error(poses: &[Pose2], truth: &[Pose2]) -> f64 {
    let steps = |p: &[Pose2]| -> Vec<Pose2> {
        p.windows(2)
            .map(|w| w[0].inverse().compose(&w[1]))
            .collect()
    };
    let sum: f64 = (steps(poses).iter().zip(steps(truth)))
        .map(|(p, t)| (p.x - t.x).hypot(p.y - t.y))
        .sum();
    sum / (truth.len() - 1) as f64
}

#[test]
fn odometry_more_precise_than_its_model_is_weighted_up_and_the_steps_improve() {
    for seed in 1..=3 {
        let (mut mapper, truth) = ring(seed, true);
        let before = step_error(mapper.poses(), &truth);
        let fit = mapper
            .fit_odometry_weight()
            .expect("enough redundancy to fit");
        // The odometry's σ is a quarter of its model's: its factor is about 1/16 of the
        // rest's (Helmert's estimate is linear and rough: a factor of 2 either way).
        assert!((4.0..64.0).contains(&fit.weight), "seed {seed}: {fit:?}");
        mapper.solve().unwrap();
        let after = step_error(mapper.poses(), &truth);
        assert!(after < 0.8 * before, "seed {seed}: {before} → {after}");
    }
}

#[test]
fn without_odometry_constraints_nothing_is_fitted() {
    let (mut mapper, _) = ring(1, false);
    let before = mapper.graph().clone();
    assert!(mapper.fit_odometry_weight().is_none());
    assert_eq!(
        mapper.graph().betweens,
        before.betweens,
        "no weight changed"
    );
    let empty = PoseGraphMapper::new(LoopClosureConfig::default());
    assert!(empty.unwrap().fit_odometry_weight().is_none());
}

#[test]
fn finish_solves_what_came_since_then_weights_the_odometry_and_solves_again() {
    let (mut mapper, truth) = ring(1, true);
    let (k, submap) = (KEYFRAMES - 1, 0);
    let anchor = mapper.submaps()[submap].anchor();
    let closure = LoopClosure {
        keyframe: k,
        submap,
        pose: truth[anchor].inverse().compose(&truth[k]),
        score: 0.9,
        lever: 5.0,
        curvature: None,
    };
    mapper.add_loop_closure(closure).unwrap();
    let finished = mapper.finish();
    assert_eq!(
        finished.solutions.len(),
        2,
        "the closure's solve, then the last"
    );
    assert!(matches!(finished.odometry, OdometryFit::Weighted(_)));

    mapper.config.fit_odometry_at_end = false;
    let finished = mapper.finish();
    assert!(finished.solutions.is_empty(), "nothing came since");
    assert_eq!(finished.odometry, OdometryFit::Off);

    let (mut without, _) = ring(1, false);
    let finished = without.finish();
    assert!(finished.solutions.is_empty(), "nothing came since");
    assert_eq!(finished.odometry, OdometryFit::Unfitted);
}
