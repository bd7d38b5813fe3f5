//! The noise fit and the noise check's suspect on simulated runs in process: with the
//! sensor's or the odometry's noise configured four times too small (σ), the check names
//! that source and the fitted noise lies within 30 % of the simulator's — the smoothing
//! back-end's variance components (docs/ALGORITHMS.md §1, "Noise fit"; §8.4). A recorded
//! robot with the profile fitted on it names no suspect; with its odometry σ's set a
//! quarter, the filter running on the back-end's fit keeps unknown association within
//! 1.5× known, where the profile alone does not. The ignored tests print the
//! measurements the docs quote.

use fastslam_client::Metrics;
use fastslam_client::warnings::Warnings;
use fastslam_estimation::fastslam::Adapt;
use fastslam_replay::dataset::Association;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::{Overrides, ServiceConfig};
use fastslam_stack::{offline, settings};

/// Bailey's short run with known association; its configuration's noise is the
/// simulator's.
const SHORT: &str = "bailey-short";

/// Bailey's webmap, twice round its loop: the odometry's variance component needs a
/// whole trajectory whose landmarks check it (a redundancy of about 300 here, 17–40 on
/// [`SHORT`]'s 60 s).
const WEBMAP: &str = "bailey-webmap";

/// The service configuration of `scenario` with the odometry's and the sensor's σ's
/// multiplied by `odometry` and `sensor`, and `adapt` set.
fn config(scenario: &Scenario, odometry: f64, sensor: f64, adapt: Adapt) -> ServiceConfig {
    let mut config = settings::service_config(scenario, None, &Overrides::default()).unwrap();
    let filter = &mut config.filter;
    filter.motion = filter.motion.scaled(odometry * odometry);
    filter.sensor.sigma_range *= sensor;
    filter.sensor.sigma_bearing *= sensor;
    filter.noise.adapt = adapt;
    config
}

/// The in-process run of `scenario` with seed `seed` under `config`.
fn run(scenario: &Scenario, seed: u64, config: &ServiceConfig) -> Metrics {
    let source = offline::Source::Simulation(Box::new(scenario.clone()));
    offline::run_in_process(&source, seed, config)
        .unwrap()
        .metrics
}

/// Whether the fitted σ's at `at` (the odometry's two: 0..2, the sensor's: 2..4) lie
/// within 30 % of the truth's.
fn within_30_percent(fitted: &[f64; 4], truth: &[f64; 4], at: std::ops::Range<usize>) -> bool {
    (fitted[at.clone()].iter().zip(&truth[at])).all(|(f, t)| (f / t - 1.0).abs() < 0.3)
}

/// Runs `scenario` with seeds 1–3 and the odometry's and the sensor's σ's multiplied by
/// `odometry` and `sensor` (one of them ¼), and asserts the check names `suspect` and
/// fits the σ's of the source set too small within 30 % of the truth, from the
/// back-end's whole solve.
fn assert_blamed_and_fitted(scenario: &str, odometry: f64, sensor: f64, suspect: &str) {
    let scenario = Scenario::load(scenario).unwrap();
    let at = if suspect == "odometry" { 0..2 } else { 2..4 };
    for seed in [1, 2, 3] {
        let m = run(
            &scenario,
            seed,
            &config(&scenario, odometry, sensor, Adapt::Off),
        );
        let f = &m.filter;
        assert_eq!(f.nis_suspect, suspect, "seed {seed}: {f:?}");
        assert_eq!(f.noise_fit, "smoother", "seed {seed}");
        // The summary's warning names the same source.
        let warned = Warnings::of(&m).lines;
        assert!(
            warned
                .iter()
                .any(|l| l.contains(&format!("the {suspect} noise at σ"))),
            "seed {seed}: {warned:?}"
        );
        let truth: [f64; 4] =
            std::array::from_fn(|i| f.noise_profile[i] / if i < 2 { odometry } else { sensor });
        assert!(
            within_30_percent(&f.noise_fitted, &truth, at.clone()),
            "seed {seed}: fitted {:?}, truth {truth:?}",
            f.noise_fitted
        );
    }
}

#[test]
fn a_sensor_noise_four_times_too_small_is_blamed_on_the_sensor_and_fitted() {
    assert_blamed_and_fitted(SHORT, 1.0, 0.25, "sensor");
}

#[test]
fn an_odometry_noise_four_times_too_small_is_blamed_on_the_odometry_and_fitted() {
    assert_blamed_and_fitted(WEBMAP, 0.25, 1.0, "odometry");
}

/// One line of the measurement.
fn show(what: &str, m: &Metrics) {
    let f = &m.filter;
    println!(
        "{what}: ate {:.3} nees {:.2} nis {:.2} high {:.2} suspect {:?} profile {:.4?} fitted {:.4?} by {}",
        m.estimate.ate_rmse_m,
        m.consistency.nees_mean,
        f.nis_mean,
        f.nis_high_fraction,
        f.nis_suspect,
        f.noise_profile,
        f.noise_fitted,
        f.noise_fit
    );
}

/// MRCLAM robot 1 under `association` with its profile's odometry σ's multiplied by
/// `odometry`, seed `seed`, `adapt` set.
fn run_mrclam(seed: u64, association: Association, odometry: f64, adapt: Adapt) -> Metrics {
    let set = fastslam_replay::registry::find("mrclam").unwrap();
    let source = offline::Source::replay(set, None, 1, association, None).unwrap();
    let overrides = Overrides {
        seed: Some(seed),
        ..Overrides::default()
    };
    let mut config = source.service_config(None, &overrides).unwrap();
    config.filter.motion = config.filter.motion.scaled(odometry * odometry);
    config.filter.noise.adapt = adapt;
    offline::run_in_process(&source, seed, &config)
        .unwrap()
        .metrics
}

#[test]
fn a_recorded_robot_with_its_profile_names_no_suspect() {
    // The profile is fitted on this robot: the back-end finds its odometry as modelled
    // and its sensor better than modelled, which is no suspect.
    let f = run_mrclam(1, Association::Known, 1.0, Adapt::Off).filter;
    assert_eq!(
        (f.nis_suspect.as_str(), f.noise_fit.as_str()),
        ("", "smoother")
    );
    assert!(
        within_30_percent(&f.noise_fitted, &f.noise_profile, 0..2),
        "{f:?}"
    );
}

/// MRCLAM robot 1 with its odometry σ's a quarter of the profile's, seeds 1–3 under
/// `association` and `adapt`: the mean ATE and the most landmarks mapped.
fn mrclam_odometry_too_small(association: Association, adapt: Adapt) -> (f64, usize) {
    let runs: Vec<Metrics> = (1..=3)
        .map(|seed| run_mrclam(seed, association, 0.25, adapt))
        .collect();
    let ate = runs.iter().map(|m| m.estimate.ate_rmse_m).sum::<f64>() / 3.0;
    let most = runs.iter().map(|m| m.map.estimated).max().unwrap();
    (ate, most)
}

#[test]
fn unknown_association_holds_when_the_filter_runs_on_the_back_ends_noise_fit() {
    let (known, _) = mrclam_odometry_too_small(Association::Known, Adapt::Smoother);
    let (unknown, mapped) = mrclam_odometry_too_small(Association::Unknown, Adapt::Smoother);
    assert!(
        unknown <= 1.5 * known,
        "unknown {unknown} m, known {known} m"
    );
    assert!(
        mapped as f64 <= 1.3 * 15.0,
        "{mapped} landmarks mapped for 15"
    );
    // On the profile alone the same runs map landmarks again and drift.
    let (known, _) = mrclam_odometry_too_small(Association::Known, Adapt::Off);
    let (unknown, mapped) = mrclam_odometry_too_small(Association::Unknown, Adapt::Off);
    assert!(
        unknown > 1.5 * known,
        "unknown {unknown} m, known {known} m"
    );
    assert!(
        mapped as f64 > 1.3 * 15.0,
        "{mapped} landmarks mapped for 15"
    );
}

#[test]
#[ignore = "measurement: MRCLAM robot 1, odometry σ as profiled and a quarter, both associations, every adaptation, ten seeds"]
fn measure_mrclam() {
    for odometry in [1.0, 0.25] {
        for association in [Association::Known, Association::Unknown] {
            for adapt in [Adapt::Off, Adapt::Innovations, Adapt::Smoother] {
                for seed in 1..=10 {
                    let m = run_mrclam(seed, association, odometry, adapt);
                    let what = format!("mrclam odo {odometry} {association:?} {adapt:?}");
                    show(&format!("{what} seed {seed}"), &m);
                }
            }
        }
    }
}

#[test]
#[ignore = "measurement: prints the fit and the errors under every adaptation, over ten seeds"]
fn measure() {
    for name in [SHORT, WEBMAP] {
        let scenario = Scenario::load(name).unwrap();
        for (odometry, sensor) in [(1.0, 1.0), (0.25, 1.0), (1.0, 0.25)] {
            for adapt in [Adapt::Off, Adapt::Innovations, Adapt::Smoother] {
                for seed in 1..=10 {
                    let m = run(&scenario, seed, &config(&scenario, odometry, sensor, adapt));
                    let what = format!("{name} odo {odometry} sensor {sensor} {adapt:?}");
                    show(&format!("{what} seed {seed}"), &m);
                }
            }
        }
    }
}
