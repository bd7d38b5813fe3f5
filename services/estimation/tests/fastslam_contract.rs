//! What the FastSLAM filter promises its callers, on small simulated runs
//! ([`common::bailey`]): results independent of the thread count, bad inputs rejected
//! without harm, prior maps shared and checked, the estimate published before the maps
//! are written, resampled copies sharing maps, and a refiner's poses weighed.

mod common;

use common::bailey::*;
use fastslam_estimation::fastslam::{
    AssociationMode, FastSlam, FastSlamConfig, MapLandmark, OptimiserRefiner, Particle,
    PoseRefiner, Proposal, ResamplingConfig, Scan, WeightBasis,
};
use fastslam_estimation::motion::Control;
use fastslam_estimation::moves::{MoveConfig, MoveCorrection};
use fastslam_estimation::observation::{Observation, Sensor};
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::{Error, Pose2, Result};
use nalgebra::{Matrix2, Vector2};

/// The mixed scenario with `base`'s particle count and proposal, and `optimiser` with
/// `correction` as step 2.
fn scenario_with(
    base: &FastSlamConfig,
    optimiser: &OptimiserConfig,
    correction: Option<MoveCorrection>,
) -> (Vec<Particle>, Vec<MapLandmark>) {
    let mut sim = Sim::new(corridor(80.0, 12.0), 3);
    let config = FastSlamConfig {
        particles: base.particles,
        proposal: base.proposal,
        ..config(AssociationMode::Unknown, 3)
    };
    let moves = MoveConfig {
        correction: correction.unwrap_or_default(),
        ..MoveConfig::default()
    };
    let mut refiner = OptimiserRefiner::new(optimiser, moves, config.seed).unwrap();
    let mut slam = FastSlam::new(config, Pose2::default()).unwrap();
    if refiner.as_ref().is_some_and(|r| r.needs_gaussian_prior()) {
        slam = slam.defer_sampling().unwrap();
    }
    let clutter = |s: usize, _: &Pose2| {
        (s % 7 == 3)
            .then_some(Observation {
                range: 8.0 + s as f64 * 0.1,
                bearing: -0.4,
                id: None,
            })
            .into_iter()
            .collect()
    };
    let route = |s: usize| 0.1 * ((s as f64) * 0.1).sin();
    let refiner = refiner.as_mut().map(|r| r as &mut dyn PoseRefiner);
    sim.run_refined(&mut slam, 60, route, clutter, refiner);
    (slam.particles().to_vec(), slam.best_map())
}

/// Runs `scenario` in rayon pools of one and two threads and asserts identical results.
fn assert_thread_count_does_not_matter(
    what: &str,
    scenario: impl Fn() -> (Vec<Particle>, Vec<MapLandmark>) + Send + Sync,
) {
    let in_pool = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(&scenario)
    };
    let (one, map_one) = in_pool(1);
    let (two, map_two) = in_pool(2);
    assert_eq!(map_one, map_two, "{what}");
    assert!(!map_one.is_empty(), "{what}");
    for (a, b) in one.iter().zip(&two) {
        assert_eq!(a.pose(), b.pose(), "{what}");
        assert_eq!(a.log_weight().to_bits(), b.log_weight().to_bits(), "{what}");
        let la: Vec<_> = a.map().iter().copied().collect();
        let lb: Vec<_> = b.map().iter().copied().collect();
        assert_eq!(la, lb, "{what}");
    }
}

#[test]
fn results_are_bit_identical_with_one_or_two_threads() {
    // Enough particles that every per-particle stage runs on both threads (smaller batches
    // stay on the calling thread, see `MIN_PARALLEL_WORK`), against one thread.
    let many = FastSlamConfig {
        particles: 4000,
        ..FastSlamConfig::default()
    };
    assert_thread_count_does_not_matter("FastSLAM 1.0", || {
        scenario_with(&many, &OptimiserConfig::default(), None)
    });
}

#[test]
fn optimisers_and_fastslam2_are_bit_identical_with_one_or_two_threads() {
    // 30 particles and 5 generations keep it quick; every optimiser, every correction and
    // both proposals run at least once. FastSLAM 2.0 alone gets 600 particles, so that its
    // proposal runs on both threads.
    let small = |proposal| FastSlamConfig {
        particles: 30,
        proposal,
        ..FastSlamConfig::default()
    };
    let optimiser = |kind| OptimiserConfig {
        kind,
        iterations: 5,
        ..OptimiserConfig::default()
    };
    assert_thread_count_does_not_matter("fastslam2", || {
        scenario_with(
            &FastSlamConfig {
                particles: 600,
                ..small(Proposal::FastSlam2)
            },
            &optimiser(OptimiserKind::None),
            None,
        )
    });
    for (k, kind) in OptimiserKind::ALL.into_iter().skip(1).enumerate() {
        let correction = MoveCorrection::ALL[k % 3];
        let proposal = Proposal::ALL[(k / 2) % 2];
        let what = format!("{kind} with {correction} correction and {proposal} proposal");
        assert_thread_count_does_not_matter(&what, || {
            scenario_with(&small(proposal), &optimiser(kind), Some(correction))
        });
    }
}

#[test]
fn bad_inputs_are_rejected_without_touching_the_filter() {
    let mut slam = FastSlam::new(config(AssociationMode::Known, 1), Pose2::default()).unwrap();
    let good = Control {
        v: 3.0,
        omega: 0.0,
        steering: 0.1,
        ..Control::ZERO
    };
    slam.predict(&good, DT).unwrap();
    let before: Vec<Pose2> = slam.particles().iter().map(|p| *p.pose()).collect();
    for (control, dt) in [
        (
            Control {
                v: f64::NAN,
                ..good
            },
            DT,
        ),
        (
            Control {
                steering: f64::INFINITY,
                ..good
            },
            DT,
        ),
        (good, f64::NAN),
        (good, -1.0),
        (Control { v: 1e308, ..good }, 1e10),
    ] {
        assert!(matches!(
            slam.predict(&control, dt),
            Err(Error::InvalidInput { .. })
        ));
    }
    let after: Vec<Pose2> = slam.particles().iter().map(|p| *p.pose()).collect();
    assert_eq!(before, after);

    let observations = [
        Observation {
            range: 10.0,
            bearing: 0.1,
            id: Some(1),
        },
        Observation {
            range: f64::NAN,
            bearing: 0.1,
            id: Some(2),
        },
        Observation {
            range: 10.0,
            bearing: f64::NEG_INFINITY,
            id: Some(3),
        },
        Observation {
            range: -3.0,
            bearing: 0.1,
            id: Some(4),
        },
        Observation {
            range: 12.0,
            bearing: 0.2,
            id: None,
        },
        Observation {
            range: 1e300,
            bearing: 0.2,
            id: Some(5),
        },
    ];
    let report = slam.update(&observations).unwrap();
    assert_eq!(report.rejected, 5);
    assert_eq!(report.new_landmarks, slam.particles().len());
    assert!(
        slam.particles()
            .iter()
            .all(|p| p.map().len() == 1 && p.pose().is_finite())
    );
    let bad_sensor = Sensor {
        sigma_bearing: f64::NAN,
        ..Sensor::default()
    };
    assert!(matches!(
        slam.update_with(&observations, &bad_sensor, None),
        Err(Error::InvalidParameter { .. })
    ));
}

#[test]
fn prior_map_is_shared_and_checked() {
    let landmark = MapLandmark {
        id: 4,
        mean: Vector2::new(10.0, 1.0),
        covariance: Matrix2::identity() * 0.01,
        hits: 5,
    };
    let slam =
        FastSlam::with_prior_map(FastSlamConfig::default(), Pose2::default(), &[landmark]).unwrap();
    let first = slam.particles()[0].map();
    assert!(
        slam.particles()
            .iter()
            .all(|p| p.map().shares_storage_with(first))
    );
    assert_eq!(slam.best_map(), vec![landmark]);
    for bad in [
        MapLandmark {
            mean: Vector2::new(f64::NAN, 0.0),
            ..landmark
        },
        MapLandmark {
            covariance: Matrix2::new(1.0, 0.5, 0.4, 1.0),
            ..landmark
        },
        MapLandmark {
            covariance: -Matrix2::identity(),
            ..landmark
        },
    ] {
        let r = FastSlam::with_prior_map(FastSlamConfig::default(), Pose2::default(), &[bad]);
        assert!(matches!(r, Err(Error::InvalidInput { .. })));
    }
    let twice = FastSlam::with_prior_map(
        FastSlamConfig::default(),
        Pose2::default(),
        &[landmark, landmark],
    );
    assert!(twice.is_err());
    let nan_start = Pose2 {
        x: f64::NAN,
        y: 0.0,
        theta: 0.0,
    };
    assert!(FastSlam::new(FastSlamConfig::default(), nan_start).is_err());
}

#[test]
fn the_estimate_is_published_before_the_maps_are_written() {
    // `Sim::run` checks at every scan without resampling that the estimate handed to
    // `publish` equals `estimate()` after the step; this run takes both branches.
    let mut sim = Sim::new(corridor(60.0, 10.0), 5);
    let mut slam = FastSlam::new(config(AssociationMode::Unknown, 5), Pose2::default()).unwrap();
    let errors = sim.run(&mut slam, 40, |s| 0.05 * (s as f64 * 0.2).sin(), no_clutter);
    assert!(
        errors.resampled > 0 && errors.resampled < 40,
        "resampled after {} of 40 scans",
        errors.resampled
    );
    // When the step resamples, the published estimate is the cloud before resampling: the
    // same filter configured never to resample ends the step holding it.
    let with = |neff_ratio| FastSlamConfig {
        resampling: ResamplingConfig {
            neff_ratio,
            ..slam.config().resampling.clone()
        },
        ..slam.config().clone()
    };
    let mut always = FastSlam::from_state(with(1.0), &slam.state()).unwrap();
    let mut never = FastSlam::from_state(with(0.0), &slam.state()).unwrap();
    let control = sim.odometry(0.0);
    always.predict(&control, DT).unwrap();
    never.predict(&control, DT).unwrap();
    let scan = sim.scan();
    let sensor = slam.config().sensor.clone();
    let mut published = None;
    let report = always
        .update_publishing(&scan, &sensor, None, |e| published = Some(*e))
        .unwrap();
    assert!(!never.update(&scan).unwrap().resampled);
    assert!(report.resampled, "{report:?}");
    assert_eq!(published, Some(never.estimate()));
    assert_ne!(
        published,
        Some(always.estimate()),
        "resampling changed the cloud"
    );
    // The published map is that of the particle that weighed most, resampled or not
    // (after resampling every copy weighs the same, so the weights cannot tell).
    assert_eq!(always.best().pose(), never.best().pose());
    assert_eq!(always.best_map(), never.best_map());
    assert_ne!(
        always.particles()[0].pose(),
        never.best().pose(),
        "the test needs a best particle other than the first copy"
    );
    // A failing step publishes nothing.
    let bad = Sensor {
        max_range: -1.0,
        ..Sensor::default()
    };
    let mut published = false;
    assert!(
        slam.update_publishing(&sim.scan(), &bad, None, |_| published = true)
            .is_err()
    );
    assert!(!published);
}

#[test]
fn resampled_copies_share_their_maps() {
    let mut sim = Sim::new(corridor(60.0, 10.0), 9);
    let mut config = config(AssociationMode::Known, 9);
    config.resampling.neff_ratio = 1.0;
    let mut slam = FastSlam::new(config, Pose2::default()).unwrap();
    sim.run(&mut slam, 30, |_| 0.0, no_clutter);
    for _ in 0..CONTROLS_PER_SCAN {
        let control = sim.odometry(0.0);
        slam.predict(&control, DT).unwrap();
    }
    let scan = sim.scan();
    let report = slam.update(&scan).unwrap();
    assert!(report.resampled && report.distinct < slam.particles().len());
    let particles = slam.particles();
    let shared = (1..particles.len())
        .filter(|&i| {
            particles[i]
                .map()
                .shares_storage_with(particles[i - 1].map())
        })
        .count();
    assert_eq!(
        shared,
        particles.len() - report.distinct,
        "copies of one ancestor share its map"
    );
}

/// A stand-in optimiser: puts every particle on the true pose.
struct Oracle {
    truth: Pose2,
    calls: Vec<(u64, usize)>,
}

impl PoseRefiner for Oracle {
    fn refine(
        &mut self,
        scan: &Scan<'_>,
        particles: &mut [Particle],
        _: &mut [WeightBasis],
    ) -> Result<()> {
        self.calls.push((scan.step(), scan.observations().len()));
        for p in particles.iter_mut() {
            assert!(scan.log_likelihood(p.map(), &self.truth).is_finite());
            p.set_pose(self.truth)?;
        }
        Ok(())
    }
}

#[test]
fn refiner_moves_poses_before_weighing() {
    let mut sim = Sim::new(corridor(60.0, 10.0), 2);
    let mut slam = FastSlam::new(config(AssociationMode::Known, 2), Pose2::default()).unwrap();
    let mut oracle = Oracle {
        truth: Pose2::default(),
        calls: Vec::new(),
    };
    for _ in 0..20 {
        for _ in 0..CONTROLS_PER_SCAN {
            let control = sim.odometry(0.0);
            slam.predict(&control, DT).unwrap();
        }
        let scan = sim.scan();
        oracle.truth = sim.truth;
        let sensor = slam.config().sensor.clone();
        slam.update_with(&scan, &sensor, Some(&mut oracle)).unwrap();
        let error = distance(&slam.estimate().mean, &sim.truth);
        assert!(
            error < 1e-9,
            "every particle was moved onto the truth: {error}"
        );
    }
    assert_eq!(oracle.calls.len(), 20);
    assert!(
        oracle
            .calls
            .windows(2)
            .all(|w| w[1].0 == w[0].0 + CONTROLS_PER_SCAN as u64 + 1)
    );
}
