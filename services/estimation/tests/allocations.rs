//! Heap allocations of one filter step, counted by a counting global allocator.
//!
//! The service's hot loop is the filter step: a step in steady state should not allocate
//! scratch space, only what the persistent maps need (a written landmark copies the nodes
//! on its path when the particle shares them after resampling). This binary holds one
//! test so nothing else allocates while it counts (with one rayon thread or many: the
//! counter is global).
//!
//! The thread pool itself allocates now and then: its workers' start-up, and a new block
//! of its job queue every few dozen jobs. So the test starts every worker first, counts
//! several steps and judges the quietest one: an allocation per particle or per
//! observation happens in every step, so it cannot hide in the minimum.

use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::{
    AssociationConfig, AssociationMode, FastSlam, FastSlamConfig, MapLandmark, Proposal,
    ResamplingConfig,
};
use fastslam_estimation::motion::Control;
use fastslam_estimation::observation::{Observation, measure};
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_estimation::workload::Workload;
use nalgebra::{Matrix2, Vector2};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The system allocator, counting allocations (reallocations included).
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f`.
fn count(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    f();
    ALLOCATIONS.load(Ordering::SeqCst) - before
}

/// A localisation filter (fixed map of `m` surveyed landmarks, known association) with
/// `n` particles that resamples every step, and the scan it sees from the origin.
fn localisation(n: usize, m: usize) -> (FastSlam, Vec<Observation>) {
    let config = FastSlamConfig {
        particles: n,
        association: AssociationConfig {
            mode: AssociationMode::Known,
            ..AssociationConfig::default()
        },
        resampling: ResamplingConfig {
            neff_ratio: 1.0,
            ..ResamplingConfig::default()
        },
        ..FastSlamConfig::default()
    };
    let landmarks: Vec<MapLandmark> = (0..m)
        .map(|i| MapLandmark {
            id: i as u64,
            mean: Vector2::new(5.0 + (i % 5) as f64 * 4.0, -10.0 + (i / 5) as f64 * 4.0),
            covariance: Matrix2::identity() * 0.1,
            hits: 3,
        })
        .collect();
    let start = Pose2::default();
    let scan = landmarks
        .iter()
        .map(|l| {
            let z = measure(&start, &l.mean);
            Observation {
                range: z[0],
                bearing: z[1],
                id: Some(l.id),
            }
        })
        .collect();
    let mut filter = FastSlam::with_prior_map(config, start, &landmarks).unwrap();
    filter.fix_map();
    (filter, scan)
}

/// Steps counted after the warm-up.
const COUNTED_STEPS: usize = 8;

/// The fewest and the most allocations of a step's two halves.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Counts {
    predict: (usize, usize),
    update: (usize, usize),
}

/// Allocations of predict and update over `COUNTED_STEPS` steps after a few uncounted
/// ones (buffers grown).
fn steady_step(filter: &mut FastSlam, scan: &[Observation]) -> Counts {
    let sensor = filter.config().sensor.clone();
    let control = Control {
        v: 0.5,
        omega: 0.0,
        steering: 0.0,
        ..Control::ZERO
    };
    for _ in 0..5 {
        filter.predict(&control, 0.1).unwrap();
        filter.update_with(scan, &sensor, None).unwrap();
    }
    let mut predict = Vec::new();
    let mut update = Vec::new();
    for _ in 0..COUNTED_STEPS {
        predict.push(count(|| filter.predict(&control, 0.1).unwrap()));
        update.push(count(|| {
            let report = filter.update_with(scan, &sensor, None).unwrap();
            assert!(report.resampled && report.rejected == 0, "{report:?}");
        }));
    }
    let range = |v: &[usize]| (*v.iter().min().unwrap(), *v.iter().max().unwrap());
    Counts {
        predict: range(&predict),
        update: range(&update),
    }
}

#[test]
fn a_steady_state_step_allocates_nothing_per_particle_or_observation() {
    // Localisation with known association reads the maps by id and writes none, so the
    // step's own buffers are all that could allocate: nothing may grow with N or the scan.
    // Every worker of the pool runs once, so none starts up while the test counts.
    rayon::broadcast(|_| ());
    let mut allocations = Vec::new();
    for (n, m) in [(100, 20), (400, 20), (100, 40)] {
        let (mut filter, scan) = localisation(n, m);
        let counts = steady_step(&mut filter, &scan);
        eprintln!("N = {n}, {m} observations: allocations (fewest, most) {counts:?}");
        assert_eq!(counts.predict.0, 0, "the prediction allocated (N = {n})");
        allocations.push(counts.update.0);
    }
    // What is left is resampling's draw (ancestors, their weights and the distinct
    // count): a few vectors per resampling, whatever N and the scan size.
    assert!(
        allocations.iter().all(|&a| a == allocations[0] && a <= 4),
        "allocations per update grew with N or the scan: {allocations:?}"
    );

    // Mapping (unknown association, negative evidence, shared maps written) also
    // allocates for the maps' copy-on-write nodes and the spatial index's range queries:
    // reported here, and in BENCHMARKS.md.
    let workload = Workload::new(100, 1000, Proposal::Motion, OptimiserKind::None).unwrap();
    let mut filter = workload.filter.clone();
    let counts = steady_step(&mut filter, &workload.scan);
    eprintln!("mapping, N = 100, M = 1000: allocations (fewest, most) {counts:?}");
    assert_eq!(
        counts.predict.0, 0,
        "the mapping filter's prediction allocated"
    );
}
