//! Per-particle work on rayon's threads only where it pays, into reused buffers.
//!
//! Handing a batch to rayon's pool from a thread outside it wakes a worker and parks the
//! caller on a futex until the batch is done: tens of microseconds per call on a busy
//! machine, more than 100 particles' prediction or association costs. Below
//! [`MIN_PARALLEL_WORK`] the batch runs on the calling thread. Each closure seeds its own
//! random stream and the outputs keep the input order, so the results are bit-identical
//! either way: the choice is only about speed.
//!
//! Outputs go into a caller's vector that keeps its capacity from step to step
//! (`collect_into_vec`, or clear and extend), so a step allocates no scratch space.

use rayon::prelude::*;

/// Smallest batch (particles × work units per particle, an observation being one unit)
/// spread over threads. Measured with `fastslam-stack bench --parts step` on 2 cores
/// (BENCHMARKS.md): with 15 observations, parallel steps were as fast as sequential ones
/// at N = 100 (1 600 units), 9 % faster at N = 300 and 28 % faster at N = 1000.
pub(crate) const MIN_PARALLEL_WORK: usize = 4000;

/// Whether `items` pieces of `units` work units each are worth spreading over threads.
pub(crate) fn pays(items: usize, units: usize) -> bool {
    rayon::current_num_threads() > 1 && items.saturating_mul(units.max(1)) >= MIN_PARALLEL_WORK
}

/// `out = items.map(f)` in order, on rayon's threads when `parallel`.
pub(crate) fn map_into<T: Sync, R: Send>(
    parallel: bool,
    items: &[T],
    out: &mut Vec<R>,
    f: impl Fn(usize, &T) -> R + Sync + Send,
) {
    if parallel {
        items
            .par_iter()
            .enumerate()
            .map(|(i, item)| f(i, item))
            .collect_into_vec(out);
    } else {
        out.clear();
        out.extend(items.iter().enumerate().map(|(i, item)| f(i, item)));
    }
}

/// `f(item, other)` for each pair of `items` and `others` (of equal length), in order, on
/// rayon's threads when `parallel`; `f` may change both.
pub(crate) fn zip_mut<T: Send, U: Send>(
    parallel: bool,
    items: &mut [T],
    others: &mut [U],
    f: impl Fn(&mut T, &mut U) + Sync + Send,
) {
    if parallel {
        items
            .par_iter_mut()
            .zip(others.par_iter_mut())
            .for_each(|(item, other)| f(item, other));
    } else {
        for (item, other) in items.iter_mut().zip(others.iter_mut()) {
            f(item, other);
        }
    }
}
