//! A synthetic FastSLAM workload for benchmarks: a filter whose particles share a map of
//! M landmarks, and the scan the robot takes after one control step. Used by the
//! criterion benchmark (`benches/fastslam_step.rs`) and by `fastslam-stack bench`.
//!
//! The world grows with M at a fixed landmark density (one per 100 m², jittered grid), so
//! the robot — in the middle, with Bailey's 30 m front half-plane sensor — sees about 14
//! landmarks whatever M is: the workload isolates the cost of the map's size. Every
//! particle starts with the whole map (shared), and `neff_ratio = 1` makes every step
//! resample. Every random draw is seeded (by M).

use crate::fastslam::{FastSlam, FastSlamConfig, MapLandmark, OptimiserRefiner, PoseRefiner};
use crate::fastslam::{PoseEstimate, Proposal, StepReport};
use crate::motion::{Control, MotionModel};
use crate::moves::{MoveConfig, MoveCorrection};
use crate::observation::{Observation, Sensor, measure};
use crate::optimise::{OptimiserConfig, OptimiserKind};
use crate::pose::Pose2;
use crate::rng::seeded;
use crate::{Error, Result};
use nalgebra::{Matrix2, Vector2};
use rand::RngExt;
use rand_distr::StandardNormal;

/// Landmark spacing of the jittered grid (m).
const SPACING: f64 = 10.0;
/// Odometry / scan period of one step (s).
pub const DT: f64 = 0.2;
/// The control of every step: 3 m/s with a slight steer.
pub const CONTROL: Control = Control {
    v: 3.0,
    omega: 0.0,
    steering: 0.05,
    ..Control::ZERO
};

/// One benchmark case: a filter ready for a step, its scan, and the optimiser of step 2.
#[derive(Debug)]
pub struct Workload {
    /// The filter before the step (clone it for each measured step).
    pub filter: FastSlam,
    /// The scan taken after one step of [`CONTROL`] over [`DT`] from the origin.
    pub scan: Vec<Observation>,
    /// The optimiser moving predicted poses (`None` for plain FastSLAM).
    pub refiner: Option<OptimiserRefiner>,
}

impl Workload {
    /// `n` particles sharing a map of `m` landmarks, with `proposal` and optimiser `kind`
    /// (default K and move settings).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for `n = 0`, [`Error::InvalidInput`] for `m = 0`.
    pub fn new(n: usize, m: usize, proposal: Proposal, kind: OptimiserKind) -> Result<Self> {
        if m == 0 {
            return Err(Error::InvalidInput {
                what: "workload landmarks",
                reason: "must be at least 1".into(),
            });
        }
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
        let filter = FastSlam::with_prior_map(config, Pose2::default(), &world)?;
        let optimiser = OptimiserConfig {
            kind,
            ..OptimiserConfig::default()
        };
        let refiner = OptimiserRefiner::new(&optimiser, MoveConfig::default(), 1)?;
        Ok(Self {
            filter,
            scan,
            refiner,
        })
    }

    /// The same workload with the optimiser in `correction` mode (the filter defers
    /// sampling when the mode needs it, as the service does).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] on a workload built without an optimiser.
    pub fn with_correction(mut self, correction: MoveCorrection) -> Result<Self> {
        let Some(old) = &self.refiner else {
            return Err(Error::InvalidParameter {
                name: "moves.correction",
                reason: "the workload has no optimiser to correct".into(),
            });
        };
        let optimiser = old.optimiser_config().clone();
        let moves = MoveConfig {
            correction,
            ..MoveConfig::default()
        };
        let refiner = OptimiserRefiner::new(&optimiser, moves, 1)?;
        if refiner.as_ref().is_some_and(|r| r.needs_gaussian_prior()) {
            self.filter = self.filter.defer_sampling()?;
        }
        self.refiner = refiner;
        Ok(self)
    }

    /// One filter step on `filter` (a clone of [`Workload::filter`]): predict with
    /// [`CONTROL`] over [`DT`], then update with the scan and the optimiser.
    ///
    /// # Errors
    /// The filter's error (none for a workload built by [`Workload::new`]).
    pub fn step(&mut self, filter: &mut FastSlam) -> Result<StepReport> {
        self.step_publishing(filter, |_| {})
    }

    /// [`step`](Self::step), handing the estimate to `publish` as soon as the filter has
    /// it, before the map updates ([`FastSlam::update_publishing`]).
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn step_publishing(
        &mut self,
        filter: &mut FastSlam,
        publish: impl FnOnce(&PoseEstimate),
    ) -> Result<StepReport> {
        filter.predict(&CONTROL, DT)?;
        let sensor = filter.config().sensor.clone();
        let refiner = self.refiner.as_mut().map(|r| r as &mut dyn PoseRefiner);
        filter.update_publishing(&self.scan, &sensor, refiner, publish)
    }
}

/// The CPU model, logical cores and kernel, from `/proc`: printed with every benchmark's
/// figures, which mean little without the machine they ran on.
pub fn machine() -> String {
    let read = |p: &str| std::fs::read_to_string(p).unwrap_or_default();
    let cpuinfo = read("/proc/cpuinfo");
    let model = cpuinfo
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .map_or("unknown CPU", |m| m.trim_start_matches([' ', '\t', ':']));
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let kernel = read("/proc/sys/kernel/osrelease");
    format!("{model}, {cores} logical cores, Linux {}", kernel.trim())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scan_sees_about_the_same_landmarks_whatever_the_map_size() {
        let small = Workload::new(10, 100, Proposal::Motion, OptimiserKind::None).unwrap();
        let large = Workload::new(10, 10_000, Proposal::Motion, OptimiserKind::None).unwrap();
        assert!((8..=20).contains(&small.scan.len()), "{}", small.scan.len());
        assert!((8..=20).contains(&large.scan.len()), "{}", large.scan.len());
        let mut w = large;
        let mut filter = w.filter.clone();
        let report = w.step(&mut filter).unwrap();
        assert!(report.resampled && report.matched > 0);
        assert!(Workload::new(10, 0, Proposal::Motion, OptimiserKind::None).is_err());
    }

    #[test]
    fn fastslam_1_without_the_motion_prior_gives_bit_identical_results() {
        let mut w = Workload::new(50, 300, Proposal::Motion, OptimiserKind::None).unwrap();
        let mut with = w.filter.clone();
        let mut without = w.filter.clone().without_motion_prior().unwrap();
        // The noise check reads the motion prior: the filter's own figures must agree.
        let filter_part = |r: crate::fastslam::StepReport| crate::fastslam::StepReport {
            innovations: Default::default(),
            ..r
        };
        for _ in 0..5 {
            assert_eq!(
                filter_part(w.step(&mut with).unwrap()),
                filter_part(w.step(&mut without).unwrap())
            );
        }
        assert_eq!(with.estimate(), without.estimate());
        assert_eq!(with.best_map(), without.best_map());
        let mut refined = Workload::new(10, 100, Proposal::Motion, OptimiserKind::Coa).unwrap();
        let mut filter = refined.filter.clone().without_motion_prior().unwrap();
        assert!(
            refined.step(&mut filter).is_err(),
            "a refiner needs the prior"
        );
        let fastslam2 = Workload::new(10, 100, Proposal::FastSlam2, OptimiserKind::None).unwrap();
        assert!(fastslam2.filter.without_motion_prior().is_err());
    }
}
