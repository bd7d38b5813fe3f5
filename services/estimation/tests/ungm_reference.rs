//! The UNGM benchmark's reference (docs/ALGORITHMS.md §5): a bootstrap particle filter with
//! 20 000 particles approximates the posterior mean, the floor no filter on this model
//! beats on average. Our own earlier measurement put its 50-run mean RMSE at 2.76
//! (Q = 1, R = 0.1) and 4.52 (Q = 10, R = 1); the benchmark must reproduce both within 5 %.

use fastslam_estimation::ungm::{BenchmarkConfig, HIGH_NOISE, LOW_NOISE, Method, Ungm, evaluate};

#[test]
fn bootstrap_filter_with_20000_particles_reproduces_the_reference_within_5_percent() {
    for ((q, r), reference) in [(LOW_NOISE, 2.76), (HIGH_NOISE, 4.52)] {
        let model = Ungm::new(q, r).unwrap();
        let config = BenchmarkConfig::default();
        let result = evaluate(&model, &Method::default(), 20_000, &config).unwrap();
        let rmse = result.rmse;
        println!(
            "Q = {q}, R = {r}: RMSE {:.3} ± {:.3} over {} runs (95 % CI of the mean {:.3}–{:.3}), coverage {:.3}",
            rmse.mean, rmse.std, rmse.n, rmse.ci95.0, rmse.ci95.1, result.coverage.mean
        );
        assert_eq!(rmse.n, config.runs);
        assert!(
            (rmse.mean - reference).abs() < 0.05 * reference,
            "Q = {q}: {} vs the reference {reference}",
            rmse.mean
        );
    }
}
