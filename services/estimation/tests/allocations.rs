//! Heap allocations of one filter step, counted by a counting global allocator.
//!
//! The service's hot loop is the filter step: a step in steady state should not allocate
//! scratch space, only what the persistent maps need (a written landmark copies the nodes
//! on its path when the particle shares them after resampling). This binary holds one
//! test so nothing else allocates while it counts.

use fastslam_estimation::fastslam::Proposal;
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_estimation::workload::{CONTROL, DT, Workload};
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

#[test]
fn a_steady_state_step_allocates_only_for_the_maps() {
    let (n, m) = (100, 1000);
    let workload = Workload::new(n, m, Proposal::Motion, OptimiserKind::None).unwrap();
    let mut filter = workload.filter.clone();
    let sensor = filter.config().sensor.clone();
    let scan = workload.scan.clone();
    for _ in 0..5 {
        filter.predict(&CONTROL, DT).unwrap();
        filter.update_with(&scan, &sensor, None).unwrap();
    }
    let predict = count(|| filter.predict(&CONTROL, DT).unwrap());
    let mut report = None;
    let update = count(|| report = Some(filter.update_with(&scan, &sensor, None).unwrap()));
    let report = report.unwrap();
    eprintln!("predict {predict}, update {update} allocations; {report:?}");
    assert_eq!(predict, 0, "the prediction allocated");
}
