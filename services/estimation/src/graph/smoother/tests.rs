//! The smoothing back-end's graph on simulated laps: loops, fusion, window solves.

use super::*;
use crate::motion::Unicycle;
use crate::observation::measure;

fn noise() -> NoiseModel {
    NoiseModel {
        motion: MotionModel::Unicycle(Unicycle {
            sigma_v: 0.1,
            sigma_omega: 0.05,
        }),
        sensor: Matrix2::from_diagonal(&Vector2::new(0.1 * 0.1, 0.02 * 0.02)),
        floor: Matrix3::identity() * 1e-10,
    }
}

/// Keyed sightings of every landmark within 12 m of `pose`.
fn sightings(pose: &Pose2, landmarks: &[Vector2<f64>]) -> Vec<Observation> {
    (landmarks.iter().enumerate())
        .filter_map(|(k, m)| {
            let z = measure(pose, m);
            (z[0] < 12.0).then_some(Observation {
                range: z[0],
                bearing: z[1],
                id: Some(k as u64),
            })
        })
        .collect()
}

/// Sixteen landmarks around a circle of 18 m radius, and the control that drives it
/// once in 100 s from the origin.
fn circle() -> (Vec<Vector2<f64>>, Control) {
    let landmarks = (0..16)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 16.0;
            Vector2::new(18.0 * a.cos(), 15.9 + 18.0 * a.sin())
        })
        .collect();
    let control = Control {
        v: 1.0,
        omega: std::f64::consts::TAU / 100.0,
        steering: 0.0,
        ..Control::ZERO
    };
    (landmarks, control)
}

/// Two laps of a 100 s circle with landmarks around it, fed at 10 Hz with a scan every
/// second. Odometry and sightings carry `noise_scale` times the model's noise (seed
/// `seed`; 0: exact data), and the second lap's landmarks are keyed `100 + k` when
/// `rekey` (as a filter that mapped them again after its path drifted would key
/// them). Returns the smoother, the true poses at the scans and the feed results.
fn laps(
    config: SmootherConfig,
    noise_scale: f64,
    rekey: bool,
    seed: u64,
) -> (Smoother, Vec<Pose2>, Vec<bool>) {
    laps_solved(config, noise_scale, rekey, seed, &mut |_| ())
}

/// [`laps`], handing every solution a due solve gives to `solved` (no solve when it is
/// never due).
fn laps_solved(
    config: SmootherConfig,
    noise_scale: f64,
    rekey: bool,
    seed: u64,
    solved: &mut dyn FnMut(Solution),
) -> (Smoother, Vec<Pose2>, Vec<bool>) {
    use rand::RngExt;
    let mut rng = crate::rng::seeded(seed);
    let mut normal =
        move |sigma: f64| noise_scale * sigma * rng.sample::<f64, _>(rand_distr::StandardNormal);
    let model = noise();
    let (landmarks, truth_control) = circle();
    let mut smoother = Smoother::new(config, model.clone()).unwrap();
    let (mut x, mut truth, mut due) = (Pose2::default(), Vec::new(), Vec::new());
    for k in 1..=2000_u64 {
        let (from_ns, to_ns) = ((k - 1) * 100_000_000, k * 100_000_000);
        let control = Control {
            v: truth_control.v + normal(0.1),
            omega: truth_control.omega + normal(0.05),
            steering: 0.0,
            ..Control::ZERO
        };
        smoother.feed(&Feed::Control {
            from_ns,
            to_ns,
            control,
        });
        x = model.motion.propagate(&x, &truth_control, 0.1);
        if k % 10 == 0 {
            truth.push(x);
            let seen = (sightings(&x, &landmarks).into_iter())
                .map(|o| Observation {
                    range: o.range + normal(0.1),
                    bearing: o.bearing + normal(0.02),
                    id: o.id.map(|id| if rekey && k > 1000 { 100 + id } else { id }),
                })
                .collect();
            let now = smoother.feed(&Feed::Scan {
                stamp_ns: to_ns,
                sightings: seen,
            });
            if now {
                solved(smoother.solve().unwrap());
            }
            due.push(now);
        }
    }
    (smoother, truth, due)
}

/// [`laps`] with odometry and sightings as noisy as the model says, solved at the end.
fn drifting_laps(config: SmootherConfig, rekey: bool, seed: u64) -> Solution {
    laps(config, 1.0, rekey, seed).0.solve().unwrap()
}

#[test]
fn landmarks_mapped_again_after_a_drift_are_fused_and_close_the_loop() {
    let apart = |a: &Solution, b: &Solution| {
        (a.poses.iter().zip(&b.poses))
            .map(|((_, p), (_, q))| (p.x - q.x).hypot(p.y - q.y))
            .fold(0.0, f64::max)
    };
    let unfused = SmootherConfig {
        fuse_duplicates: false,
        ..SmootherConfig::default()
    };
    for seed in 1..=5 {
        let known = drifting_laps(unfused.clone(), false, seed);
        let open = drifting_laps(unfused.clone(), true, seed);
        let fused = drifting_laps(SmootherConfig::default(), true, seed);
        assert_eq!(known.landmarks.len(), 16);
        assert_eq!(open.landmarks.len(), 32);
        // Every second-lap key fused into its own first-lap landmark, none into a
        // neighbour: the graph is that of the true keys, and so is its solution.
        assert_eq!(fused.fused, 16, "seed {seed}");
        let mut keys: Vec<u64> = fused.landmarks.iter().map(|l| l.0).collect();
        keys.sort_unstable();
        assert_eq!(keys, (0..16).collect::<Vec<u64>>(), "seed {seed}");
        assert!(apart(&fused, &known) < 1e-3, "seed {seed}");
        assert!(
            apart(&open, &known) > 0.3,
            "seed {seed}: the open loop is {} m from the closed one: no drift to close",
            apart(&open, &known)
        );
    }
}

#[test]
fn a_loop_asks_for_one_solve_and_exact_data_is_solved_exactly() {
    let config = SmootherConfig {
        loop_gap_s: 50.0,
        min_poses_between_solves: 30,
        kernel: KernelKind::None,
        fuse_duplicates: false,
        ..SmootherConfig::default()
    };
    let (mut smoother, truth, due) = laps(config, 0.0, false, 0);
    // A landmark is out of sight for more than 50 s only once the lap comes round
    // (one scan a second): the first re-sighting after that asks.
    let first = due.iter().position(|&d| d).expect("a loop closes");
    assert!((50..100).contains(&first), "scan {first}");
    assert!(due[..first].iter().all(|&d| !d));
    assert_eq!(smoother.poses(), truth.len() + 1);
    let solution = smoother.solve().unwrap();
    assert!(!smoother.has_news());
    let worst = (solution.poses[1..].iter().zip(&truth))
        .map(|((_, p), t)| (p.x - t.x).hypot(p.y - t.y))
        .fold(0.0, f64::max);
    assert!(worst < 1e-6, "exact data: {worst} m");
    assert!(solution.fit.chi2_per_dof < 1e-9);
}

#[test]
fn without_a_loop_no_solve_is_asked() {
    let config = SmootherConfig {
        loop_gap_s: 500.0,
        fuse_duplicates: false,
        ..SmootherConfig::default()
    };
    let (_, _, due) = laps(config, 0.0, false, 0);
    assert!(due.iter().all(|&d| !d));
}

#[test]
fn a_landmark_seen_once_from_the_fixed_start_has_the_sensor_covariance() {
    let model = noise();
    let mut smoother = Smoother::new(SmootherConfig::default(), model.clone()).unwrap();
    let obs = Observation {
        range: 10.0,
        bearing: 0.5,
        id: Some(7),
    };
    smoother.feed(&Feed::Scan {
        stamp_ns: 0,
        sightings: vec![obs],
    });
    let solution = smoother.solve().unwrap();
    let (key, _, cov) = solution.landmarks[0];
    let (_, g) = inverse(&Pose2::default(), &obs.z());
    let expected = g * model.sensor * g.transpose();
    assert_eq!(key, 7);
    // The start's prior (variance 1e-8) adds about r² · 1e-8 to it.
    assert!(
        (cov - expected).norm() < 1e-4 * expected.norm(),
        "{cov} vs {expected}"
    );
}

/// Windows of 40 poses, a solve every 10 once a loop closed: mostly window solves.
fn windowed() -> SmootherConfig {
    SmootherConfig {
        loop_gap_s: 50.0,
        min_poses_between_solves: 10,
        window_poses: 40,
        fuse_duplicates: false,
        ..SmootherConfig::default()
    }
}

/// Largest distance between the poses of two solutions.
fn apart(a: &Solution, b: &Solution) -> f64 {
    (a.poses.iter().zip(&b.poses))
        .map(|((_, p), (_, q))| (p.x - q.x).hypot(p.y - q.y))
        .fold(0.0, f64::max)
}

#[test]
fn window_solves_on_the_way_end_where_one_whole_solve_does() {
    for seed in 1..=3 {
        let mut kinds = Vec::new();
        let (mut smoother, ..) = laps_solved(windowed(), 1.0, false, seed, &mut |s| {
            kinds.push(s.whole);
        });
        let windows = kinds.iter().filter(|&&whole| !whole).count();
        assert!(windows >= 5, "seed {seed}: {kinds:?}");
        assert!(kinds.iter().any(|&whole| whole), "seed {seed}: {kinds:?}");
        assert!(
            smoother.has_news(),
            "window solves since the last whole one"
        );
        let last = smoother.solve_whole().unwrap();
        assert!(last.whole && !smoother.has_news());
        let once = laps(windowed(), 1.0, false, seed).0.solve().unwrap();
        assert!(once.whole);
        assert!(
            apart(&last, &once) < 1e-6,
            "seed {seed}: {} m",
            apart(&last, &once)
        );
        assert!((last.fit.chi2_per_dof - once.fit.chi2_per_dof).abs() < 1e-6);
    }
}

#[test]
fn a_window_solve_at_the_whole_solution_moves_nothing() {
    // The held poses at the optimum: the window's own optimum given them is the same
    // point, so a window solve (its held sightings summed at the optimum) stays there,
    // to the whole solve's tolerance.
    for seed in 1..=3 {
        let (mut smoother, ..) = laps(windowed(), 1.0, false, seed);
        let whole = smoother.solve_whole().unwrap();
        let window = smoother.solve().unwrap();
        assert!(!window.whole);
        assert!(smoother.has_news(), "a window solve since the whole one");
        assert!(
            apart(&whole, &window) < 1e-6,
            "seed {seed}: {}",
            apart(&whole, &window)
        );
        for (a, b) in whole.landmarks.iter().zip(&window.landmarks) {
            assert_eq!(a.0, b.0);
            assert!((a.1 - b.1).norm() < 1e-6, "seed {seed}: {a:?} {b:?}");
        }
    }
}

#[test]
fn window_solves_on_exact_data_are_exact() {
    let mut solutions = Vec::new();
    let (_, truth, _) = laps_solved(windowed(), 0.0, false, 0, &mut |s| solutions.push(s));
    assert!(solutions.iter().filter(|s| !s.whole).count() >= 5);
    for s in &solutions {
        // The poses at the scans so far (after the start) against the truth.
        let worst = (s.poses[1..].iter().zip(&truth))
            .map(|((_, p), t)| (p.x - t.x).hypot(p.y - t.y))
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "solve {}: {worst} m", s.solves);
    }
}

#[test]
fn settings_out_of_range_are_refused_by_name() {
    let refused = |config: SmootherConfig| match config.validate() {
        Err(Error::InvalidParameter { name, .. }) => name,
        other => panic!("{other:?}"),
    };
    let base = SmootherConfig::default;
    assert!(base().validate().is_ok());
    let growth = SmootherConfig {
        whole_growth: 1.0,
        ..base()
    };
    assert_eq!(refused(growth), "smoother.whole_growth");
    let nowhere = SmootherConfig {
        graph_out: Some("/no/such/folder/graph.g2o".into()),
        ..base()
    };
    assert_eq!(refused(nowhere), "smoother.graph_out");
    let here = SmootherConfig {
        graph_out: Some("graph.g2o".into()),
        ..base()
    };
    assert!(here.validate().is_ok());
}

#[test]
fn without_a_window_every_solve_is_whole() {
    let config = SmootherConfig {
        window_poses: 0,
        ..windowed()
    };
    let mut kinds = Vec::new();
    laps_solved(config, 1.0, false, 1, &mut |s| kinds.push(s.whole));
    assert!(
        kinds.len() >= 5 && kinds.iter().all(|&whole| whole),
        "{kinds:?}"
    );
}
