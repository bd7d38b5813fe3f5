//! Reference tests of the optimisers on the standard test functions (docs/ALGORITHMS.md §4,
//! `optimizer-reference/`): Sphere, Rastrigin, Rosenbrock and Ackley in 3 and 10 dimensions,
//! unshifted and shifted, population 30, 200 generations, [`SEEDS`] seeds per case. Each
//! median is compared with the matching column of `summary.csv` (20 seeds): COA with
//! COA_MATLAB / COA_mealpy, BA with BOA_MATLAB, GWO with GWO_mealpy, QPSO with QPSO_ref, PSO
//! with PSO_canonical; ICOA and IBA have no reference and are compared with COA and BA.
//!
//! # "Within an order of magnitude"
//!
//! Values are floored at [`FLOOR`] = 1e-8 — anything below counts as solved, so 1e-150 and
//! 1e-148 compare equal — and compared in log10. A median passes when it lies within one
//! decade of the reference's interquartile range `[q25, q75]`: one decade around the median
//! where the reference is tight, wider where the reference's own median is noise (QPSO on
//! 3-D Rastrigin: median 1e-6, IQR 0 … 3.4e-4; the shifted median is 1.2e-4).
//!
//! # Deviations (explained, asserted as they are)
//!
//! - **COA** draws `r` per dimension (docs/ALGORITHMS.md §4.1); both references draw one scalar
//!   per member, which moves a coati along a line through the origin (phase 1) and along the
//!   box diagonal (phase 2). A control run of the same code with scalar `r` (15 seeds)
//!   reproduced COA_mealpy: shifted Sphere 10-D 854 (ref 1195), shifted Rosenbrock 10-D
//!   7.4e4 (9.2e4), shifted Ackley 10-D 13.2 (12.0), unshifted Rosenbrock 10-D 0.088 (0.10).
//!   With per-dimension `r` the origin bias is weaker: on shifted functions ours is better than
//!   both references by orders of magnitude, and on unshifted 10-D Rosenbrock — optimum at
//!   (1, …, 1) on the diagonal the scalar version walks along — ours stalls near the origin
//!   (f(0) = 9).
//! - **ICOA** multiplies `X` by `ω(k) ∈ [0.15, 0.65]` (eq. 15 as printed), a pull toward the
//!   origin: as good as COA where the optimum is at the origin, far worse where it is not.
//!   With `ω ≡ 1` (control) it is within 10× of COA everywhere, so the weight is the cause.
//!   Inside the filter the origin is the predicted cloud's centre (§3).
//! - **BA** uses `I = exp(−ΔF)` and `X + (g* − X) L F` (§4.3); BOA_MATLAB uses `I = f` and
//!   `X + (r² g* − X) F`, a pull toward the origin that solves the unshifted functions. Ours
//!   has no origin bias: unshifted and shifted results agree within a decade, and on the
//!   shifted functions it matches BOA_MATLAB. It costs N evaluations per generation (BOA_MATLAB
//!   evaluates every butterfly twice: 12 030).
//! - **IBA** moves a butterfly only within the fragrance radius `η F ≤ 0.5 × 0.22` half-widths
//!   of its partner (§4.4); random members of a population spread over the box are ≈ 0.8 √D
//!   half-widths apart, so on test functions IBA (almost) never moves and its median is the
//!   best of the 30 initial points.
//!
//! Run with `cargo test -p fastslam-estimation --release --test optimiser_reference --
//! --nocapture` to print every table (≈ 4 s on 2 cores in release; unoptimised builds
//! take ≈ 50 s).

use TestFunction::{Ackley, Rastrigin, Rosenbrock, Sphere};
use fastslam_estimation::optimise::test_functions::{Benchmark, TestFunction};
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind, Population, Problem};
use fastslam_estimation::rng::stream;
use rayon::prelude::*;
use std::sync::OnceLock;

/// Members per population, as in the reference runs.
const POPULATION: usize = 30;
/// Generations per run, as in the reference runs.
const ITERATIONS: usize = 200;
/// Seeds per case (the references used 20; an odd count makes the median a run's value).
const SEEDS: u64 = 31;
/// Fitness below which a run counts as solved: comparisons floor values here.
const FLOOR: f64 = 1e-8;
/// Evaluations per run of the methods costing N per generation, initial population included.
const EVALUATIONS_N: u64 = (POPULATION * (ITERATIONS + 1)) as u64;

/// Median and quartiles of the best fitness over seeds.
#[derive(Debug, Clone, Copy)]
struct Quartiles {
    median: f64,
    q25: f64,
    q75: f64,
}

const fn r(median: f64, q25: f64, q75: f64) -> Quartiles {
    Quartiles { median, q25, q75 }
}

/// The reference columns used here, in the order of [`Case::reference`].
#[derive(Debug, Clone, Copy)]
enum Column {
    CoaMatlab,
    CoaMealpy,
    BoaMatlab,
    GwoMealpy,
    QpsoRef,
    PsoCanonical,
}

/// One row of `summary.csv`.
struct Case {
    shifted: bool,
    function: TestFunction,
    dim: usize,
    reference: [Quartiles; 6],
}

const fn row(shifted: bool, function: TestFunction, dim: usize, reference: [Quartiles; 6]) -> Case {
    Case {
        shifted,
        function,
        dim,
        reference,
    }
}

/// `summary.csv` (median, q25, q75) for COA_MATLAB, COA_mealpy, BOA_MATLAB, GWO_mealpy,
/// QPSO_ref, PSO_canonical, generated from the file with Python's csv module.
const CASES: [Case; 16] = [
    row(
        false,
        Ackley,
        3,
        [
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(4.242e-06, 3.375e-06, 5.659e-06),
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(1.162e-07, 5.187e-08, 2.472e-07),
        ],
    ),
    row(
        false,
        Ackley,
        10,
        [
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(7.91e-06, 7.409e-06, 8.758e-06),
            r(7.341e-13, 3.006e-13, 1.093e-12),
            r(5.632e-06, 2.826e-06, 1.766e-05),
            r(0.01425, 0.007796, 0.02812),
        ],
    ),
    row(
        false,
        Rastrigin,
        3,
        [
            r(0.0, 0.0, 0.0),
            r(0.0, 0.0, 0.0),
            r(3.217, 1.407, 3.874),
            r(0.0, 0.0, 0.2488),
            r(1.072e-06, 0.0, 0.0003422),
            r(1.18e-12, 3.055e-13, 1.528e-11),
        ],
    ),
    row(
        false,
        Rastrigin,
        10,
        [
            r(0.0, 0.0, 0.0),
            r(0.0, 0.0, 0.0),
            r(17.88, 0.000919, 39.21),
            r(5.126, 3.368, 6.484),
            r(5.783, 4.402, 11.16),
            r(8.538, 6.21, 11.3),
        ],
    ),
    row(
        false,
        Rosenbrock,
        3,
        [
            r(0.0, 0.0, 0.0),
            r(0.03512, 0.0007141, 0.3294),
            r(0.8384, 0.07167, 1.554),
            r(0.02293, 0.006128, 0.05676),
            r(0.1212, 0.03419, 0.3776),
            r(0.0628, 0.01585, 0.134),
        ],
    ),
    row(
        false,
        Rosenbrock,
        10,
        [
            r(0.0, 0.0, 0.0),
            r(0.1005, 0.009428, 0.3362),
            r(8.938, 8.923, 8.951),
            r(6.52, 6.257, 7.008),
            r(7.363, 6.789, 116.5),
            r(7.777, 7.286, 19.25),
        ],
    ),
    row(
        false,
        Sphere,
        3,
        [
            r(1.424e-151, 9.126e-154, 2.837e-149),
            r(7.975e-151, 5.43e-154, 1.505e-148),
            r(1.111e-08, 8.594e-09, 1.451e-08),
            r(4.409e-71, 7.478e-74, 9.271e-68),
            r(1.219e-35, 5.27e-37, 1.36e-34),
            r(3.507e-14, 1.362e-14, 9.362e-14),
        ],
    ),
    row(
        false,
        Sphere,
        10,
        [
            r(2.536e-148, 6.831e-151, 4.915e-147),
            r(3.222e-151, 6.646e-155, 1.975e-147),
            r(3.724e-08, 3.285e-08, 4.155e-08),
            r(1.022e-24, 1.166e-25, 2.396e-24),
            r(8.948e-11, 9.372e-12, 2.88e-10),
            r(0.0007266, 0.0004748, 0.001087),
        ],
    ),
    row(
        true,
        Ackley,
        3,
        [
            r(3.233, 2.146, 4.584),
            r(0.3092, 0.127, 0.6474),
            r(3.135, 2.687, 3.599),
            r(0.02068, 0.0157, 0.02905),
            r(4.441e-16, 4.441e-16, 4.441e-16),
            r(1.397e-07, 1.187e-07, 2.175e-07),
        ],
    ),
    row(
        true,
        Ackley,
        10,
        [
            r(15.68, 14.81, 16.05),
            r(11.99, 11.33, 12.67),
            r(14.05, 13.03, 15.66),
            r(1.212, 1.081, 1.287),
            r(2.382e-06, 9e-07, 5.281e-06),
            r(0.01477, 0.008563, 0.02009),
        ],
    ),
    row(
        true,
        Rastrigin,
        3,
        [
            r(2.003, 1.377, 2.145),
            r(1.052, 0.9956, 1.352),
            r(5.005, 3.322, 5.409),
            r(0.995, 5.912e-05, 0.995),
            r(0.0001222, 1.402e-08, 0.0004416),
            r(1.073e-12, 5.24e-14, 4.982e-12),
        ],
    ),
    row(
        true,
        Rastrigin,
        10,
        [
            r(50.83, 47.9, 55.68),
            r(47.74, 41.01, 50.75),
            r(58.29, 54.25, 60.96),
            r(13.16, 9.763, 24.46),
            r(7.238, 5.2, 11.5),
            r(8.535, 6.041, 13.1),
        ],
    ),
    row(
        true,
        Rosenbrock,
        3,
        [
            r(4.574, 1.264, 520.7),
            r(0.8632, 0.1693, 1.845),
            r(1565.0, 29.65, 2340.0),
            r(0.06682, 0.03216, 0.2733),
            r(0.1445, 0.05233, 0.2531),
            r(0.09484, 0.02396, 0.1447),
        ],
    ),
    row(
        true,
        Rosenbrock,
        10,
        [
            r(668900.0, 534300.0, 1416000.0),
            r(92040.0, 28850.0, 123700.0),
            r(1736000.0, 781100.0, 2668000.0),
            r(71.37, 20.08, 224.3),
            r(7.379, 7.075, 8.788),
            r(9.655, 7.43, 52.69),
        ],
    ),
    row(
        true,
        Sphere,
        3,
        [
            r(15.61, 7.836, 48.02),
            r(0.05209, 0.01812, 0.1366),
            r(85.38, 27.08, 121.7),
            r(0.0001307, 7.556e-05, 0.0002609),
            r(0.0, 0.0, 0.0),
            r(2.658e-14, 1.219e-14, 7.223e-14),
        ],
    ),
    row(
        true,
        Sphere,
        10,
        [
            r(3365.0, 2848.0, 3854.0),
            r(1195.0, 839.4, 1443.0),
            r(4387.0, 3778.0, 5371.0),
            r(0.07743, 0.0474, 0.1628),
            r(1.632e-10, 1.105e-11, 2.008e-09),
            r(0.0005857, 0.0002044, 0.001833),
        ],
    ),
];

impl Case {
    fn reference(&self, column: Column) -> Quartiles {
        self.reference[column as usize]
    }

    fn is(&self, shifted: bool, function: TestFunction, dim: usize) -> bool {
        (self.shifted, self.function, self.dim) == (shifted, function, dim)
    }

    fn label(&self) -> String {
        format!(
            "{}{} {}-D",
            if self.shifted { "shifted " } else { "" },
            self.function.name(),
            self.dim
        )
    }
}

/// What our runs gave for one case.
#[derive(Debug, Clone, Copy)]
struct Measured {
    best: Quartiles,
    /// Median fitness evaluations per run, the initial population included.
    evaluations: u64,
}

/// Runs `config` on every case and seed (in parallel; each run is sequential and seeded by
/// (seed, case), so the numbers do not depend on scheduling).
fn measure(config: &OptimiserConfig) -> Vec<Measured> {
    CASES
        .par_iter()
        .enumerate()
        .map(|(case_index, case)| {
            let problem =
                Benchmark::new(case.function, case.dim, case.shifted).expect("embedded case");
            let mut runs: Vec<(f64, u64)> = (0..SEEDS)
                .into_par_iter()
                .map(|seed| {
                    let mut rng = stream(seed, &[case_index as u64]);
                    let mut optimiser = config
                        .build(&mut rng)
                        .expect("valid config")
                        .expect("an optimiser");
                    let start = optimiser.initial_positions(problem.bounds(), POPULATION, &mut rng);
                    let mut population =
                        Population::evaluate(&problem, start).expect("finite start");
                    let summary = optimiser
                        .run(&problem, &mut population, ITERATIONS, &mut rng)
                        .expect("run");
                    (
                        summary.best.fitness,
                        summary.evaluations + POPULATION as u64,
                    )
                })
                .collect();
            let mut evaluations: Vec<u64> = runs.iter().map(|r| r.1).collect();
            evaluations.sort_unstable();
            runs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let quantile = |q: f64| runs[((runs.len() - 1) as f64 * q).round() as usize].0;
            Measured {
                best: r(quantile(0.5), quantile(0.25), quantile(0.75)),
                evaluations: evaluations[evaluations.len() / 2],
            }
        })
        .collect()
}

/// The default-config measurement of `kind`, computed once for all tests that need it.
fn measured(kind: OptimiserKind) -> &'static [Measured] {
    static CACHE: [OnceLock<Vec<Measured>>; 8] = [const { OnceLock::new() }; 8];
    let slot = OptimiserKind::ALL
        .iter()
        .position(|&k| k == kind)
        .expect("a kind");
    CACHE[slot].get_or_init(|| {
        measure(&OptimiserConfig {
            kind,
            ..OptimiserConfig::default()
        })
    })
}

/// log10 of `value` floored at [`FLOOR`].
fn decades(value: f64) -> f64 {
    value.max(FLOOR).log10()
}

/// Within one decade of the reference's interquartile range (see the module docs).
fn within_reference(ours: f64, reference: Quartiles) -> bool {
    let v = decades(ours);
    decades(reference.q25) - 1.0 <= v && v <= decades(reference.q75) + 1.0
}

/// Prints our quartiles next to the reference columns.
fn print_table(title: &str, ours: &[Measured], columns: &[Column]) {
    println!(
        "\n{title}\n{:<24} {:>28}  reference medians",
        "case", "ours median [q25, q75]"
    );
    for (case, m) in CASES.iter().zip(ours) {
        let references: Vec<String> = columns
            .iter()
            .map(|&c| format!("{c:?} {:.3e}", case.reference(c).median))
            .collect();
        println!(
            "{:<24} {:>10.3e} [{:.1e}, {:.1e}]  {}   ({} evaluations)",
            case.label(),
            m.best.median,
            m.best.q25,
            m.best.q75,
            references.join("  "),
            m.evaluations
        );
    }
}

/// A case by (shifted, function, dimension).
type Key = (bool, TestFunction, usize);

fn listed(list: &[Key], case: &Case) -> bool {
    list.iter()
        .any(|&(shifted, function, dim)| case.is(shifted, function, dim))
}

/// Our median for the case `(shifted, function, dim)`.
fn median_of(ours: &[Measured], shifted: bool, function: TestFunction, dim: usize) -> f64 {
    let at = CASES
        .iter()
        .position(|c| c.is(shifted, function, dim))
        .expect("a listed case");
    ours[at].best.median
}

/// What one optimiser must reproduce of its reference implementations: every case within
/// a decade of at least one reference column's interquartile range, except the listed
/// cases, which must be more than a decade better (or worse) than every column, each for
/// a reason given where the list is defined; and its cost per run.
struct Expectation {
    kind: OptimiserKind,
    columns: &'static [Column],
    better: &'static [Key],
    worse: &'static [Key],
    /// Fitness evaluations per run, initial population included.
    evaluations: u64,
}

/// COA cases more than a decade better than both references: per-dimension `r` weakens the
/// origin bias that holds the references back on shifted functions (module docs).
/// Measured (31 seeds) vs COA_mealpy / COA_MATLAB: Ackley 3-D 5.5e-3 vs 0.31 / 3.2,
/// Rastrigin 3-D 1.5e-5 vs 1.05 / 2.0, Rosenbrock 10-D 8.1 vs 9.2e4 / 6.7e5, Sphere 3-D
/// 3.4e-5 vs 0.052 / 15.6, Sphere 10-D 0.028 vs 1195 / 3365.
const COA_BETTER_THAN_REFERENCE: [Key; 5] = [
    (true, Ackley, 3),
    (true, Rastrigin, 3),
    (true, Rosenbrock, 10),
    (true, Sphere, 3),
    (true, Sphere, 10),
];

/// The COA case worse than both references by more than a decade: unshifted Rosenbrock 10-D,
/// 8.9 vs 0.10 (mealpy) / 0 (MATLAB). The references' scalar `r` walks along the box diagonal,
/// where the optimum (1, …, 1) lies; ours stalls near the origin, f(0) = 9.
const COA_WORSE_THAN_REFERENCE: [Key; 1] = [(false, Rosenbrock, 10)];

/// The optimisers compared with reference implementations case by case.
const EXPECTATIONS: [Expectation; 4] = [
    Expectation {
        kind: OptimiserKind::Coa,
        columns: &[Column::CoaMealpy, Column::CoaMatlab],
        better: &COA_BETTER_THAN_REFERENCE,
        worse: &COA_WORSE_THAN_REFERENCE,
        evaluations: 15_030, // 2.5 N per generation + N initial
    },
    Expectation {
        kind: OptimiserKind::Gwo,
        columns: &[Column::GwoMealpy],
        better: &[],
        worse: &[],
        evaluations: EVALUATIONS_N,
    },
    Expectation {
        kind: OptimiserKind::Qpso,
        columns: &[Column::QpsoRef],
        better: &[],
        worse: &[],
        evaluations: EVALUATIONS_N,
    },
    Expectation {
        kind: OptimiserKind::Pso,
        columns: &[Column::PsoCanonical],
        better: &[],
        worse: &[],
        evaluations: EVALUATIONS_N,
    },
];

/// The cases where `e`'s optimiser departs from what `e` expects, described.
fn departures(e: &Expectation) -> Vec<String> {
    let ours = measured(e.kind);
    print_table(&format!("{} vs {:?}", e.kind, e.columns), ours, e.columns);
    let mut out = Vec::new();
    for (case, m) in CASES.iter().zip(ours) {
        let median = m.best.median;
        let references = e.columns.iter().map(|&c| case.reference(c));
        let (best, worst_q75) = references.fold((f64::INFINITY, 0.0_f64), |(b, w), r| {
            (b.min(r.median), w.max(r.q75))
        });
        let ok = if listed(e.better, case) {
            decades(median) + 1.0 < decades(best)
        } else if listed(e.worse, case) {
            decades(median) > decades(worst_q75) + 1.0
        } else {
            e.columns
                .iter()
                .any(|&c| within_reference(median, case.reference(c)))
        };
        if !ok {
            out.push(format!(
                "{}: {median:.3e} (best reference {best:.3e})",
                case.label()
            ));
        }
        if m.evaluations != e.evaluations {
            out.push(format!("{}: {} evaluations", case.label(), m.evaluations));
        }
    }
    out
}

#[test]
fn every_optimiser_lands_within_a_decade_of_its_references_but_where_listed() {
    for e in &EXPECTATIONS {
        let departures = departures(e);
        assert!(departures.is_empty(), "{}: {departures:#?}", e.kind);
    }
}

/// ICOA cases more than 10× worse than COA: the optimum is away from the origin and
/// `ω(k) X` (ω from 0.65 to 0.15) drags candidates toward it. Measured (31 seeds), ICOA vs
/// COA: shifted Ackley 3-D 1.7 vs 5.5e-3, shifted Rastrigin 3-D 1.1 vs 1.5e-5, shifted
/// Rosenbrock 3-D 2.6 vs 0.034, shifted Rosenbrock 10-D 9.0e3 vs 8.1, shifted Sphere 3-D
/// 0.74 vs 3.4e-5, shifted Sphere 10-D 228 vs 0.028, unshifted Rosenbrock 3-D (optimum at 1)
/// 0.79 vs 0.049. Elsewhere ICOA is within 10× of COA: it solves the origin-centred functions
/// (Sphere 10-D 1e-227 vs COA's 1e-90) and lands at 7.0 vs 1.7 (shifted Ackley 10-D) and
/// 40 vs 11 (shifted Rastrigin 10-D).
const ICOA_INERTIA_COSTS: [Key; 7] = [
    (true, Ackley, 3),
    (true, Rastrigin, 3),
    (true, Rosenbrock, 3),
    (true, Rosenbrock, 10),
    (true, Sphere, 3),
    (true, Sphere, 10),
    (false, Rosenbrock, 3),
];

/// True when `a` is at most ten times `b`, both floored at [`FLOOR`].
fn within_ten_times(a: f64, b: f64) -> bool {
    decades(a) <= decades(b) + 1.0
}

#[test]
fn icoa_is_within_ten_times_coa_except_where_its_inertia_weight_pulls_toward_the_origin() {
    let (icoa, coa) = (measured(OptimiserKind::Icoa), measured(OptimiserKind::Coa));
    print_table(
        "icoa (reference columns for orientation)",
        icoa,
        &[Column::CoaMealpy],
    );
    for ((case, i), c) in CASES.iter().zip(icoa).zip(coa) {
        let (i, c) = (i.best.median, c.best.median);
        if listed(&ICOA_INERTIA_COSTS, case) {
            assert!(
                !within_ten_times(i, c),
                "{}: ICOA {i:.3e}, COA {c:.3e}",
                case.label()
            );
        } else {
            assert!(
                within_ten_times(i, c),
                "{}: ICOA {i:.3e} worse than 10 × COA {c:.3e}",
                case.label()
            );
        }
    }
    assert!(
        icoa.iter().all(|m| m.evaluations == 21_030),
        "3.5 N per generation + N initial"
    );
}

#[test]
fn icoa_without_inertia_weight_is_within_ten_times_coa_on_every_shifted_function() {
    // The control for the list above: ω ≡ 1 leaves the chaotic coefficient and the elite
    // Cauchy jump. (On unshifted 10-D Rastrigin this control lands at 2.1 where COA reaches 0:
    // the chaotic coefficient, mean 0.45 and correlated from one dimension to the next, pulls
    // less exactly to the origin than U(0,1). The printed ω reaches 0 there.)
    let mut config = OptimiserConfig {
        kind: OptimiserKind::Icoa,
        ..OptimiserConfig::default()
    };
    config.icoa.omega_max = 1.0;
    config.icoa.omega_min = 1.0;
    let control = measure(&config);
    print_table("icoa with ω ≡ 1", &control, &[Column::CoaMealpy]);
    let coa = measured(OptimiserKind::Coa);
    for ((case, i), c) in CASES
        .iter()
        .zip(&control)
        .zip(coa)
        .filter(|((case, _), _)| case.shifted)
    {
        let (i, c) = (i.best.median, c.best.median);
        assert!(
            within_ten_times(i, c),
            "{}: ICOA(ω ≡ 1) {i:.3e}, COA {c:.3e}",
            case.label()
        );
    }
}

/// The BA case more than a decade from BOA_MATLAB: shifted Ackley 3-D, 0.21 vs 3.1 (IQR 2.7 …
/// 3.6); BOA_mealpy105 lands at 2.6. Ours is better here.
const BA_BETTER_THAN_REFERENCE: Key = (true, Ackley, 3);

#[test]
fn ba_matches_boa_on_shifted_functions_and_is_translation_invariant() {
    let all = measured(OptimiserKind::Ba);
    print_table("ba vs BOA_MATLAB", all, &[Column::BoaMatlab]);
    for (case, m) in CASES.iter().zip(all) {
        let ours = m.best.median;
        let boa = case.reference(Column::BoaMatlab);
        if case.is(
            BA_BETTER_THAN_REFERENCE.0,
            BA_BETTER_THAN_REFERENCE.1,
            BA_BETTER_THAN_REFERENCE.2,
        ) {
            assert!(
                decades(ours) + 1.0 < decades(boa.median),
                "{}: {ours:.3e}",
                case.label()
            );
        } else if case.shifted {
            assert!(
                within_reference(ours, boa),
                "{}: {ours:.3e} vs BOA {:.3e}",
                case.label(),
                boa.median
            );
        } else {
            // BOA_MATLAB's `r² g* − X` pulls toward the origin and solves unshifted Sphere
            // (1e-8); ours has no such pull, so its unshifted result is its shifted result.
            let shifted = median_of(all, true, case.function, case.dim);
            assert!(
                (decades(ours) - decades(shifted)).abs() <= 1.0,
                "{}: {ours:.3e} vs shifted {shifted:.3e}",
                case.label()
            );
        }
        assert_eq!(
            m.evaluations, EVALUATIONS_N,
            "N per generation (BOA_MATLAB evaluates twice: 12 030)"
        );
    }
}

#[test]
fn iba_stays_put_on_test_functions_because_no_partner_is_within_its_fragrance_radius() {
    let (iba, ba) = (measured(OptimiserKind::Iba), measured(OptimiserKind::Ba));
    print_table(
        "iba (BOA_MATLAB for orientation)",
        iba,
        &[Column::BoaMatlab],
    );
    for ((case, i), b) in CASES.iter().zip(iba).zip(ba) {
        // The median run never made a candidate: its best is the best of the 30 initial points.
        assert_eq!(i.evaluations, POPULATION as u64, "{}", case.label());
        assert!(i.best.median >= b.best.median, "{}", case.label());
    }
}

#[test]
fn orderings_where_the_references_differ_by_orders_of_magnitude() {
    let m = |kind, shifted, function, dim| median_of(measured(kind), shifted, function, dim);
    use OptimiserKind::{Ba, Coa, Gwo, Icoa, Pso, Qpso};
    // Shifted Sphere 10-D — references: QPSO 1.6e-10, PSO 5.9e-4, GWO 0.077, COA 1195, BOA 4387.
    // Ours: QPSO 3.9e-11, PSO 5.7e-4, COA 0.028, GWO 0.27, BA 4.1e3. PSO beats COA by 1.7
    // decades here, not 6 as in the references: our COA's per-dimension r (module docs).
    assert!(m(Qpso, true, Sphere, 10) * 1e3 < m(Pso, true, Sphere, 10));
    assert!(m(Pso, true, Sphere, 10) * 10.0 < m(Coa, true, Sphere, 10));
    assert!(m(Gwo, true, Sphere, 10) * 1e3 < m(Ba, true, Sphere, 10));
    // Shifted Ackley 10-D — references: QPSO 2.4e-6, PSO 0.015, GWO 1.2.
    assert!(m(Qpso, true, Ackley, 10) * 1e3 < m(Pso, true, Ackley, 10));
    assert!(m(Pso, true, Ackley, 10) * 10.0 < m(Gwo, true, Ackley, 10));
    // Shifted Rosenbrock 10-D — references: QPSO 7.4, PSO 9.7 against BOA 1.7e6.
    assert!(m(Qpso, true, Rosenbrock, 10) * 1e3 < m(Ba, true, Rosenbrock, 10));
    assert!(m(Pso, true, Rosenbrock, 10) * 1e3 < m(Ba, true, Rosenbrock, 10));
    // COA's and ICOA's near-perfect unshifted results vanish when shifted.
    for kind in [Coa, Icoa] {
        assert!(
            m(kind, false, Sphere, 10) < 1e-50 && m(kind, true, Sphere, 10) > 1e-3,
            "{kind}"
        );
        assert!(
            m(kind, false, Rastrigin, 10) == 0.0 && m(kind, true, Rastrigin, 10) > 1.0,
            "{kind}"
        );
    }
}
