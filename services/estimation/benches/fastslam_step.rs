//! Cost of one FastSLAM step (predict + update with unknown association) against the
//! number of particles N and the map size M, and with each optimiser (and FastSLAM 2.0's
//! proposal) at N = 100, on the synthetic workload of
//! [`fastslam_estimation::workload`]: each measured step starts from the same cloned
//! filter (clone and drop not timed).
//!
//! After the criterion groups it prints the machine and growth ratios of the median step
//! time: at N = 100 when M grows 10× (the target: ≤ 1.5×), at M = 1000 when N
//! grows 10× (≈ 10× expected: the work is per particle), and each optimiser's step against
//! plain FastSLAM's. `fastslam-stack bench` prints the same figures for the full grid.

use criterion::{BatchSize, BenchmarkId, Criterion};
use fastslam_estimation::fastslam::Proposal;
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_estimation::workload::{Workload, machine};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// The workload of `n` particles, `m` landmarks, `proposal` and optimiser `kind`.
fn workload(n: usize, m: usize, proposal: Proposal, kind: OptimiserKind) -> Workload {
    Workload::new(n, m, proposal, kind).expect("valid workload")
}

fn bench_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("fastslam_step");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for n in [10, 100, 1000] {
        for m in [10, 100, 1000, 10_000] {
            let mut w = workload(n, m, Proposal::Motion, OptimiserKind::None);
            let start = w.filter.clone();
            group.bench_with_input(BenchmarkId::new(format!("N={n}"), m), &m, |b, _| {
                b.iter_batched(
                    || start.clone(),
                    |mut f| {
                        w.step(&mut f).expect("usable weights");
                        f
                    },
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
        let mut w = workload(100, M_FIXED, proposal, kind);
        let start = w.filter.clone();
        group.bench_function(BenchmarkId::new("N=100", label), |b| {
            b.iter_batched(
                || start.clone(),
                |mut f| {
                    w.step(&mut f).expect("usable weights");
                    f
                },
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

/// A label and its workload: one case of the growth measurements.
type Case = (String, Workload);

/// Median wall time (s) of one step of each case, the cases interleaved run by run so that
/// background load affects all alike; each step starts from the same filter (clone and drop
/// not timed).
fn medians(cases: &mut [Case], runs: usize) -> Vec<f64> {
    let mut times = vec![Vec::with_capacity(runs); cases.len()];
    for _ in 0..runs {
        for ((_, w), t) in cases.iter_mut().zip(&mut times) {
            let mut filter = w.filter.clone();
            let start = Instant::now();
            w.step(black_box(&mut filter)).expect("usable weights");
            t.push(start.elapsed());
            drop(black_box(filter));
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
    for (k, (label, w)) in cases.iter().enumerate() {
        let ratio = if base(k) == k {
            String::new()
        } else {
            format!("   {:.2}x {}", t[k] / t[base(k)], cases[base(k)].0)
        };
        println!(
            "  {label:<22} {:>10.1} µs ({} observations){ratio}",
            t[k] * 1e6,
            w.scan.len()
        );
    }
}

fn print_growth() {
    let case = |label: String, n, m, proposal, kind| (label, workload(n, m, proposal, kind));
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
        "FastSLAM step against M (target: <= 1.5x for 10x M)",
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
    println!("machine: {}", machine());
    let mut criterion = Criterion::default().configure_from_args();
    bench_step(&mut criterion);
    bench_optimisers(&mut criterion);
    criterion.final_summary();
    print_growth();
}
