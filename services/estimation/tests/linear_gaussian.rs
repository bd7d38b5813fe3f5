//! Proof that the corrected optimiser modes keep the particle filter a correct sampler
//! (docs/ALGORITHMS.md §3.1), and that the papers' mode does not.
//!
//! On a linear-Gaussian model the Kalman filter gives the exact posterior. For every
//! optimiser in every mode, seeded repetitions of the generic particle filter run on data
//! simulated from the model; per repetition the filter's weighted mean is standardised by
//! the Kalman posterior, `(m_PF − m_KF) / √P_KF`, and its weighted variance divided by
//! `P_KF`, both averaged over the steps — for the weighted cloud after weighing and for
//! the cloud each step carries to the next (after resampling and the moves). A correct filter's averages scatter around 0 and
//! 1 by Monte Carlo error only: the check asks both to lie within four standard errors
//! (over the repetitions) of those values. A filter with a wrong weight or a move that
//! does not leave the posterior invariant is pulled off them by far more.

use fastslam_estimation::moves::{MoveConfig, MoveCorrection, Mover};
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use fastslam_estimation::pf::{self, FilterConfig, StateSpaceModel};
use fastslam_estimation::rng::{SimRng, seeded};
use fastslam_estimation::stats::Summary;
use rand::RngExt;
use rand_distr::StandardNormal;

/// `x_t = x_{t−1} + w`, `y_t = x_t + v`, `w ~ N(0, Q)`, `v ~ N(0, R)`, `x_0 ~ N(0, 1)`.
struct RandomWalk {
    q: f64,
    r: f64,
    sigma: [f64; 1],
}

impl RandomWalk {
    fn new(q: f64, r: f64) -> Self {
        Self {
            q,
            r,
            sigma: [q.sqrt()],
        }
    }

    fn simulate(&self, steps: usize, rng: &mut SimRng) -> Vec<f64> {
        let mut x: f64 = rng.sample(StandardNormal);
        (0..steps)
            .map(|_| {
                x += self.sigma[0] * rng.sample::<f64, _>(StandardNormal);
                x + self.r.sqrt() * rng.sample::<f64, _>(StandardNormal)
            })
            .collect()
    }

    /// The exact posterior `(m_t, P_t)` of every step.
    fn kalman(&self, ys: &[f64]) -> Vec<(f64, f64)> {
        let (mut m, mut p) = (0.0, 1.0);
        ys.iter()
            .map(|y| {
                p += self.q;
                let k = p / (p + self.r);
                m += k * (y - m);
                p *= 1.0 - k;
                (m, p)
            })
            .collect()
    }
}

impl StateSpaceModel for RandomWalk {
    type Observation = f64;
    fn dim(&self) -> usize {
        1
    }
    fn sample_initial(&self, rng: &mut SimRng, x: &mut [f64]) {
        x[0] = rng.sample::<f64, _>(StandardNormal);
    }
    fn transition_mean(&self, _: usize, previous: &[f64], mean: &mut [f64]) {
        mean[0] = previous[0];
    }
    fn transition_sigma(&self) -> &[f64] {
        &self.sigma
    }
    fn log_likelihood(&self, _: usize, x: &[f64], y: &f64) -> f64 {
        -0.5 * (y - x[0]).powi(2) / self.r
    }
    fn observation_information(&self, _: usize, _: f64, _: &f64) -> f64 {
        1.0 / self.r
    }
}

const REPETITIONS: u64 = 24;
const STEPS: usize = 8;
const PARTICLES: usize = 200;

/// The standardised mean error and variance ratio of `kind` in `correction` mode, over
/// the repetitions.
fn against_kalman(kind: OptimiserKind, correction: MoveCorrection) -> (Summary, Summary) {
    // A precise observation (R < Q) makes the likelihood much narrower than the prior:
    // the case where moving particles toward it without a correct weight shows most.
    let model = RandomWalk::new(1.0, 0.25);
    let config = FilterConfig {
        particles: PARTICLES,
        ..FilterConfig::default()
    };
    let (mut errors, mut ratios) = (Vec::new(), Vec::new());
    for r in 0..REPETITIONS {
        let ys = model.simulate(STEPS, &mut seeded(1000 + r));
        let exact = model.kalman(&ys);
        let optimiser = OptimiserConfig {
            kind,
            ..OptimiserConfig::default()
        };
        let moves = MoveConfig {
            correction,
            ..MoveConfig::default()
        };
        let mut mover = Mover::new(&optimiser, moves, &mut seeded(r)).unwrap();
        let posteriors =
            pf::run(&model, &ys, &config, mover.as_mut(), &mut seeded(2000 + r)).unwrap();
        let (mut error, mut ratio) = (0.0, 0.0);
        let scale = 1.0 / (2 * STEPS) as f64;
        for (post, (m, p)) in posteriors.iter().zip(&exact) {
            error += (post.mean[0] - m) / p.sqrt() * scale;
            ratio += post.variance[0] / p * scale;
            error += (post.carried_mean[0] - m) / p.sqrt() * scale;
            ratio += post.carried_variance[0] / p * scale;
        }
        errors.push(error);
        ratios.push(ratio);
    }
    (Summary::of(&errors), Summary::of(&ratios))
}

/// Whether both averages lie within four standard errors of 0 and 1.
fn agrees(error: &Summary, ratio: &Summary) -> bool {
    let se = |s: &Summary| s.std / (s.n as f64).sqrt();
    error.mean.abs() <= 4.0 * se(error) && (ratio.mean - 1.0).abs() <= 4.0 * se(ratio)
}

fn report(kind: OptimiserKind, correction: MoveCorrection, e: &Summary, v: &Summary) -> String {
    format!(
        "{kind} {correction}: mean error {:+.3} ± {:.3} σ, variance ratio {:.3} ± {:.3} (± 1 SE)",
        e.mean,
        e.std / (e.n as f64).sqrt(),
        v.mean,
        v.std / (v.n as f64).sqrt()
    )
}

#[test]
fn the_bootstrap_filter_agrees_with_the_kalman_filter() {
    let (e, v) = against_kalman(OptimiserKind::None, MoveCorrection::None);
    println!(
        "{}",
        report(OptimiserKind::None, MoveCorrection::None, &e, &v)
    );
    assert!(agrees(&e, &v));
}

#[test]
fn every_optimiser_in_both_corrected_modes_agrees_with_the_kalman_filter() {
    for kind in OptimiserKind::ALL.into_iter().skip(1) {
        for correction in [MoveCorrection::Proposal, MoveCorrection::ResampleMove] {
            let (e, v) = against_kalman(kind, correction);
            let line = report(kind, correction, &e, &v);
            println!("{line}");
            assert!(agrees(&e, &v), "{line}");
        }
    }
}

#[test]
fn the_papers_mode_fails_the_same_check_for_every_optimiser() {
    for kind in OptimiserKind::ALL.into_iter().skip(1) {
        let (e, v) = against_kalman(kind, MoveCorrection::None);
        let line = report(kind, MoveCorrection::None, &e, &v);
        println!("{line}");
        assert!(!agrees(&e, &v), "{line}");
    }
}
