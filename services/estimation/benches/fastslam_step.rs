//! Cost of one FastSLAM step (predict + update with unknown association) against the
//! number of particles N and the map size M, and with each optimiser (and FastSLAM 2.0's
//! proposal) at N = 100.
//!
//! The world grows with M at a fixed landmark density (one per 100 m², jittered grid), so
//! the robot — in the middle, Bailey's 30 m front half-plane sensor — sees about 14
//! landmarks whatever M is: the benchmark isolates the cost of the map's size. Every
//! particle starts with the whole map (shared), `neff_ratio = 1` makes every step
//! resample, and each measured step starts from the same cloned filter.
//!
//! After the criterion groups it prints growth ratios of the median step time: at N = 100
//! when M grows 10× (the requirement: < 2×), at M = 1000 when N grows 10× (≈ 10× expected:
//! the work is per particle), and each optimiser's step against plain FastSLAM's.

use criterion::{BatchSize, BenchmarkId, Criterion};
use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::{
    FastSlam, FastSlamConfig, MapLandmark, OptimiserRefiner, PoseRefiner, Proposal,
};
use fastslam_estimation::motion::{Control, MotionModel};
use fastslam_estimation::moves::MoveConfig;
use fastslam_estimation::observation::{Observation, Sensor, measure};
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::rng::seeded;
use nalgebra::{Matrix2, Vector2};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Landmark spacing of the jittered grid (m).
const SPACING: f64 = 10.0;
/// Odometry / scan period of one step (s).
const DT: f64 = 0.2;
const CONTROL: Control = Control {
    v: 3.0,
    omega: 0.0,
    steering: 0.05,
};

/// A filter with `n` particles sharing a map of `m` landmarks, and the scan the robot
/// takes after one step.
fn scenario(n: usize, m: usize) -> (FastSlam, Vec<Observation>) {
    scenario_with(n, m, Proposal::Motion)
}

/// [`scenario`] with the given proposal.
fn scenario_with(n: usize, m: usize, proposal: Proposal) -> (FastSlam, Vec<Observation>) {
    let mut rng = seeded(m as u64);
    let side = (m as f64).sqrt().ceil() as usize;
    let half = side as f64 * SPACING / 2.0;
    let world: Vec<MapLandmark> = (0..m)
        .map(|k| MapLandmark {
            id: k as u64,
            mean: Vector2::new(
                (k % side) as f64 * SPACING - half + rng.random_range(0.0..SPACING),
                (k / side) as f64 * SPACING - half + rng.random_range(0.0..SPACING),
            ),
            covariance: Matrix2::identity() * 0.05,
            hits: 10,
        })
        .collect();
    let mut config = FastSlamConfig {
        particles: n,
        proposal,
        ..FastSlamConfig::default()
    };
    config.resampling.neff_ratio = 1.0;
    let sensor = Sensor::default();
    let truth = MotionModel::default().propagate(&Pose2::default(), &CONTROL, DT);
    let scan = world
        .iter()
        .map(|l| measure(&truth, &l.mean))
        .filter(|z| sensor.sees(z, 0.0, 0.0))
        .map(|z| Observation {
            range: z[0] + sensor.sigma_range * rng.sample::<f64, _>(StandardNormal),
            bearing: z[1] + sensor.sigma_bearing * rng.sample::<f64, _>(StandardNormal),
            id: None,
        })
        .collect();
    let slam = FastSlam::with_prior_map(config, Pose2::default(), &world).expect("valid scenario");
    (slam, scan)
}

fn step(slam: FastSlam, scan: &[Observation]) -> FastSlam {
    step_with(slam, scan, None)
}

/// One step with `refiner` as step 2.
fn step_with(
    mut slam: FastSlam,
    scan: &[Observation],
    refiner: Option<&mut OptimiserRefiner>,
) -> FastSlam {
    slam.predict(&CONTROL, DT).expect("finite control");
    let sensor = slam.config().sensor.clone();
    let refiner = refiner.map(|r| r as &mut dyn PoseRefiner);
    slam.update_with(scan, &sensor, refiner)
        .expect("usable weights");
    slam
}

/// The refiner of optimiser `kind` with the default K and move settings.
fn refiner(kind: OptimiserKind) -> Option<OptimiserRefiner> {
    let config = OptimiserConfig {
        kind,
        ..OptimiserConfig::default()
    };
    OptimiserRefiner::new(&config, MoveConfig::default(), 1).expect("valid optimiser")
}

fn bench_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("fastslam_step");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for n in [10, 100, 1000] {
        for m in [10, 100, 1000, 10_000] {
            let (slam, scan) = scenario(n, m);
            group.bench_with_input(BenchmarkId::new(format!("N={n}"), m), &m, |b, _| {
                b.iter_batched(
                    || slam.clone(),
                    |s| step(s, black_box(&scan)),
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();
}

/// Map size of the optimiser group and of the growth in N.
const M_FIXED: usize = 1000;

fn bench_optimisers(c: &mut Criterion) {
    let mut group = c.benchmark_group("optimiser_step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for (label, proposal, kind) in optimiser_cases() {
        let (slam, scan) = scenario_with(100, M_FIXED, proposal);
        let mut refiner = refiner(kind);
        group.bench_function(BenchmarkId::new("N=100", label), |b| {
            b.iter_batched(
                || slam.clone(),
                |s| step_with(s, black_box(&scan), refiner.as_mut()),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

/// Plain FastSLAM, FastSLAM 2.0, then every optimiser (with the motion proposal).
fn optimiser_cases() -> Vec<(String, Proposal, OptimiserKind)> {
    let mut cases = vec![
        ("none".to_string(), Proposal::Motion, OptimiserKind::None),
        (
            "fastslam2".to_string(),
            Proposal::FastSlam2,
            OptimiserKind::None,
        ),
    ];
    cases.extend(
        OptimiserKind::ALL[1..]
            .iter()
            .map(|&k| (k.to_string(), Proposal::Motion, k)),
    );
    cases
}

/// A filter, its scan and its refiner: one case of the growth measurements.
type Case = (String, FastSlam, Vec<Observation>, Option<OptimiserRefiner>);

/// Median wall time (s) of one step of each case, the cases interleaved run by run so that
/// background load affects all alike; each step starts from the same filter (clone and drop
/// not timed).
fn medians(cases: &mut [Case], runs: usize) -> Vec<f64> {
    let mut times = vec![Vec::with_capacity(runs); cases.len()];
    for _ in 0..runs {
        for ((_, slam, scan, refiner), t) in cases.iter_mut().zip(&mut times) {
            let input = slam.clone();
            let start = Instant::now();
            let out = step_with(input, black_box(scan), refiner.as_mut());
            t.push(start.elapsed());
            drop(black_box(out));
        }
    }
    times
        .iter_mut()
        .map(|t| {
            t.sort_unstable();
            t[runs / 2].as_secs_f64()
        })
        .collect()
}

/// Prints `cases`' medians and the ratio of each to `base(index)`'s.
fn print_ratios(title: &str, cases: &mut [Case], runs: usize, base: impl Fn(usize) -> usize) {
    let t = medians(cases, runs);
    println!("\n{title} (median of {runs} interleaved steps):");
    for (k, (label, _, scan, _)) in cases.iter().enumerate() {
        let ratio = if base(k) == k {
            String::new()
        } else {
            format!("   {:.2}x {}", t[k] / t[base(k)], cases[base(k)].0)
        };
        println!(
            "  {label:<22} {:>10.1} µs ({} observations){ratio}",
            t[k] * 1e6,
            scan.len()
        );
    }
}

fn print_growth() {
    let case = |label: String, n, m, proposal, kind| {
        let (slam, scan) = scenario_with(n, m, proposal);
        (label, slam, scan, refiner(kind))
    };
    let mut by_m: Vec<Case> = [100, 1000, 10_000]
        .into_iter()
        .map(|m| {
            case(
                format!("N = 100, M = {m}"),
                100,
                m,
                Proposal::Motion,
                OptimiserKind::None,
            )
        })
        .collect();
    print_ratios(
        "FastSLAM step against M (requirement: < 2x for 10x M)",
        &mut by_m,
        201,
        |k| k.saturating_sub(1),
    );
    let mut by_n: Vec<Case> = [10, 100, 1000]
        .into_iter()
        .map(|n| {
            let label = format!("N = {n}, M = {M_FIXED}");
            case(label, n, M_FIXED, Proposal::Motion, OptimiserKind::None)
        })
        .collect();
    print_ratios("FastSLAM step against N", &mut by_n, 51, |k| {
        k.saturating_sub(1)
    });
    let mut by_method: Vec<Case> = optimiser_cases()
        .into_iter()
        .map(|(label, proposal, kind)| case(label, 100, M_FIXED, proposal, kind))
        .collect();
    print_ratios(
        &format!("Step with each optimiser (K = 10) at N = 100, M = {M_FIXED}"),
        &mut by_method,
        21,
        |_| 0,
    );
}

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    bench_step(&mut criterion);
    bench_optimisers(&mut criterion);
    criterion.final_summary();
    print_growth();
}
