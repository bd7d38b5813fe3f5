//! Fuzzes the validation of every input message type with 10⁶ seeded random cases each
//! (the generators of the proptest suite) and prints cases per second. Not part of the
//! test suite: `cargo bench -p fastslam-protocol --bench validate_fuzz` (set
//! `FUZZ_CASES` for another count). A panic anywhere fails the run.

#[path = "../tests/fuzz_input/mod.rs"]
mod fuzz_input;

use fastslam_protocol::validate::{self, MotionLimits, StreamCheck};
use fuzz_input::Words;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use std::time::Instant;

/// Runs `case` `n` times on words from a generator seeded with `seed`; prints the rate
/// and how many cases validation accepted.
fn fuzz(name: &str, n: u64, seed: u64, mut case: impl FnMut(&mut Words) -> bool) {
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut next = move || rng.next_u64();
    let mut words = Words(&mut next);
    let start = Instant::now();
    let accepted = (0..n).filter(|_| black_box(case(&mut words))).count();
    let s = start.elapsed().as_secs_f64();
    println!(
        "{name:<14} {n} cases, {accepted} accepted, {:.2} s, {:.0} cases/s",
        s,
        n as f64 / s
    );
}

fn main() {
    let n: u64 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000);
    let limits = MotionLimits::default();
    fuzz("odometry", n, 1, |w| {
        let (a, b) = (fuzz_input::odometry(w), fuzz_input::odometry(w));
        validate::odometry(&b).is_ok() && validate::odometry_motion(&b, Some(&a), &limits).is_ok()
    });
    fuzz("ground_truth", n, 2, |w| {
        validate::ground_truth(&fuzz_input::ground_truth(w)).is_ok()
    });
    fuzz("observations", n, 3, |w| {
        let (h, items) = fuzz_input::observations(w);
        validate::observations(&h, &items).is_ok()
    });
    fuzz("laser_scan", n, 4, |w| {
        let (h, data) = fuzz_input::laser_scan(w);
        validate::laser_scan(&h, &data).is_ok()
    });
    fuzz("landmark_map", n, 5, |w| {
        let (h, items) = fuzz_input::landmark_map(w);
        validate::landmark_map(&h, &items).is_ok()
    });
    let mut check = StreamCheck::new(10_000_000_000);
    fuzz("headers", n, 6, |w| check.accept(w.header()).is_ok());
}
