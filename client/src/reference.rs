//! The achievable-accuracy reference of a run (docs/ALGORITHMS.md §8): the full-SLAM
//! maximum a posteriori solution over what crossed IPC — every odometry control and every
//! landmark observation, with the landmark ids the data carries — solved in one batch.
//! A filter approximates this posterior; its error is what the data supports, so a
//! filter's ATE divided by the reference's says how far from achievable it lands.
//!
//! The graph is the smoothing back-end's (`fastslam_estimation::graph::Smoother`: a pose
//! at every scan with sightings, the first at the first odometry stamp and fixed at the
//! origin where the service starts, odometry factors with the filter's motion model and
//! noise, a range–bearing factor per sighting with the filter's sensor noise), keyed by
//! the true ids, without a robust kernel, and solved once by Levenberg–Marquardt from
//! dead reckoning.

use crate::align::Se2;
use crate::recording::{Recording, StampedPose};
use crate::scoring::{AlignMode, ScoreAt, TrajectoryMetrics, fit_se2, interpolate, trajectory};
use fastslam_estimation::graph::{Feed, Graph, KernelKind, Smoother, SmootherConfig, SolveOptions};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The noise the reference assumes: the filter's own models.
pub use fastslam_estimation::graph::NoiseModel;

/// The reference as `metrics.json` reports it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ReferenceMetrics {
    /// ATE RMSE of the reference trajectory (m), scored as the estimate is.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub ate_rmse_m: f64,
    /// Position error of the reference's last pose (m).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub final_error_m: f64,
    /// χ² of the solution per degree of freedom: about 1 when the noise model fits.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub chi2_per_dof: f64,
    /// Wall time of the solve (s).
    pub solve_s: f64,
    /// Poses in the graph (one per scan with sightings, plus the start).
    pub poses: usize,
    /// Landmarks in the graph.
    pub landmarks: usize,
}

/// The solved reference: its trajectory and how well it fits.
#[derive(Debug, Clone)]
pub struct Reference {
    /// The poses at the scans with sightings, in the service's frame.
    pub poses: Vec<StampedPose>,
    /// χ² per degree of freedom at the solution.
    pub chi2_per_dof: f64,
    /// Wall time of the solve (s).
    pub solve_s: f64,
    /// Landmarks in the graph.
    pub landmarks: usize,
    /// The solved graph.
    pub graph: Graph,
}

/// Solves the reference of `rec` under `model`; `None` when the recording has no
/// sightings with landmark ids (raw scans, or ids stripped) or the solve fails.
pub fn solve(rec: &Recording, model: &NoiseModel) -> Option<Reference> {
    let started = Instant::now();
    let config = SmootherConfig {
        kernel: KernelKind::None,
        max_iterations: SolveOptions::default().max_iterations,
        // The data's own ids: nothing is mapped twice.
        fuse_duplicates: false,
        ..SmootherConfig::default()
    };
    let mut graph = Smoother::new(config, model.clone()).ok()?;
    let mut last_ns = rec.controls.first()?.stamp_ns;
    // The first pose sits at the first odometry stamp.
    graph.feed(&Feed::Control {
        from_ns: last_ns,
        to_ns: last_ns,
        control: rec.controls[0].control,
    });
    let mut controls = rec.controls[1..].iter().peekable();
    for scan in &rec.sightings {
        while let Some(c) = controls.next_if(|c| c.stamp_ns <= scan.stamp_ns) {
            graph.feed(&Feed::Control {
                from_ns: last_ns,
                to_ns: c.stamp_ns,
                control: c.control,
            });
            last_ns = last_ns.max(c.stamp_ns);
        }
        graph.feed(&Feed::Scan {
            stamp_ns: scan.stamp_ns,
            sightings: scan.observations.clone(),
        });
    }
    let solution = graph.solve().ok()?;
    Some(Reference {
        poses: (solution.poses.iter())
            .map(|&(stamp_ns, p)| StampedPose {
                stamp_ns,
                x: p.x,
                y: p.y,
                theta: p.theta,
            })
            .collect(),
        chi2_per_dof: solution.fit.chi2_per_dof,
        solve_s: started.elapsed().as_secs_f64(),
        landmarks: solution.landmarks.len(),
        graph: graph.into_graph(),
    })
}

/// A solved trajectory (the reference's, the smoother's) in the truth's frame: as
/// solved, or aligned onto `truth` (fitted to its own poses) when `align` asks — what is
/// scored and drawn.
pub fn aligned(poses: &[StampedPose], truth: &[StampedPose], align: AlignMode) -> Vec<StampedPose> {
    let transform = match align {
        AlignMode::None => Se2::IDENTITY,
        _ => fit_se2(poses, truth),
    };
    poses.iter().map(|p| transform.apply_pose(p)).collect()
}

/// Scores a solved trajectory against `truth` as the estimate is scored: aligned onto
/// the truth when `align` asks ([`aligned`]), at its poses or at the truth's stamps as
/// `at` says.
pub fn score(
    poses: &[StampedPose],
    truth: &[StampedPose],
    align: AlignMode,
    at: ScoreAt,
) -> TrajectoryMetrics {
    let aligned = aligned(poses, truth, align);
    let scored = match at {
        ScoreAt::Estimates => aligned,
        ScoreAt::Truth => truth
            .iter()
            .filter_map(|t| interpolate(&aligned, t.stamp_ns))
            .collect(),
    };
    trajectory(&scored, truth)
}

impl Reference {
    /// The reference's poses in the truth's frame ([`aligned`]).
    pub fn aligned(&self, truth: &[StampedPose], align: AlignMode) -> Vec<StampedPose> {
        aligned(&self.poses, truth, align)
    }

    /// Scores the reference against `truth` as the estimate is scored ([`score`]).
    pub fn score(&self, truth: &[StampedPose], align: AlignMode, at: ScoreAt) -> ReferenceMetrics {
        let TrajectoryMetrics {
            ate_rmse_m,
            final_error_m,
            ..
        } = score(&self.poses, truth, align, at);
        ReferenceMetrics {
            ate_rmse_m,
            final_error_m,
            chi2_per_dof: self.chi2_per_dof,
            solve_s: self.solve_s,
            poses: self.poses.len(),
            landmarks: self.landmarks,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::{Sightings, StampedControl};
    use fastslam_estimation::Pose2;
    use fastslam_estimation::motion::{Control, MotionModel, Unicycle};
    use fastslam_estimation::observation::{Observation, measure};
    use fastslam_estimation::rng::seeded;
    use nalgebra::Vector2;
    use nalgebra::{Matrix2, Matrix3};
    use rand::RngExt;
    use rand_distr::StandardNormal;

    const STEP_NS: u64 = 100_000_000;

    /// A unicycle on a circle among 12 landmarks, odometry every 0.1 s, a scan every
    /// fifth: the recording a client would make, with `noise` standard deviations of
    /// control and observation noise (0: exact data).
    fn circle(noise: f64, seed: u64) -> (Recording, NoiseModel) {
        let mut rng = seeded(seed);
        let mut normal = move || noise * rng.sample::<f64, _>(StandardNormal);
        let motion = MotionModel::Unicycle(Unicycle {
            sigma_v: 0.1,
            sigma_omega: 0.05,
        });
        let model = NoiseModel {
            motion: motion.clone(),
            sensor: Matrix2::from_diagonal(&Vector2::new(0.1 * 0.1, 0.02 * 0.02)),
            floor: Matrix3::identity() * 1e-10,
        };
        let landmarks: Vec<Vector2<f64>> = (0..12)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 12.0;
                Vector2::new(14.0 * a.cos(), 10.0 + 14.0 * a.sin())
            })
            .collect();
        let control = Control {
            v: 1.0,
            omega: 0.1,
            steering: 0.0,
            ..Control::ZERO
        };
        let mut rec = Recording::default();
        let mut x = Pose2::default();
        for k in 0..=750_u64 {
            let stamp_ns = k * STEP_NS;
            if k > 0 {
                x = motion.propagate(&x, &control, 0.1);
            }
            rec.truth.push(StampedPose {
                stamp_ns,
                x: x.x,
                y: x.y,
                theta: x.theta,
            });
            let measured = Control {
                v: control.v + 0.1 * normal(),
                omega: control.omega + 0.05 * normal(),
                steering: 0.0,
                ..Control::ZERO
            };
            rec.controls.push(StampedControl {
                stamp_ns,
                control: measured,
            });
            if k % 5 == 0 && k > 0 {
                let observations = (landmarks.iter().enumerate())
                    .map(|(id, m)| (id, measure(&x, m)))
                    .filter(|(_, z)| z[0] < 12.0)
                    .map(|(id, z)| Observation {
                        range: z[0] + 0.1 * normal(),
                        bearing: z[1] + 0.02 * normal(),
                        id: Some(id as u64),
                    })
                    .collect();
                rec.sightings.push(Sightings {
                    stamp_ns,
                    observations,
                });
            }
        }
        (rec, model)
    }

    #[test]
    fn exact_data_gives_an_exact_reference() {
        let (rec, model) = circle(0.0, 1);
        let reference = solve(&rec, &model).unwrap();
        let m = reference.score(&rec.truth, AlignMode::None, ScoreAt::Estimates);
        assert_eq!(m.poses, 151);
        assert_eq!(m.landmarks, 12);
        assert!(m.ate_rmse_m < 1e-6, "{m:?}");
    }

    #[test]
    fn noisy_data_gives_a_reference_better_than_dead_reckoning_that_fits_its_noise() {
        for seed in 1..=5 {
            let (rec, model) = circle(1.0, seed);
            let m =
                solve(&rec, &model)
                    .unwrap()
                    .score(&rec.truth, AlignMode::None, ScoreAt::Estimates);
            // Dead reckoning from the same controls, at the same stamps.
            let mut dead = Pose2::default();
            let mut poses = vec![];
            for w in rec.controls.windows(2) {
                dead = model.motion.propagate(&dead, &w[1].control, 0.1);
                if w[1].stamp_ns % (5 * STEP_NS) == 0 {
                    poses.push(StampedPose {
                        stamp_ns: w[1].stamp_ns,
                        x: dead.x,
                        y: dead.y,
                        theta: dead.theta,
                    });
                }
            }
            let dead_reckoning = trajectory(&poses, &rec.truth).ate_rmse_m;
            assert!(
                m.ate_rmse_m < 0.5 * dead_reckoning,
                "seed {seed}: {m:?}, DR {dead_reckoning}"
            );
            assert!((m.chi2_per_dof - 1.0).abs() < 0.25, "seed {seed}: {m:?}");
        }
    }

    #[test]
    fn no_sightings_no_reference() {
        let (mut rec, model) = circle(0.0, 1);
        rec.sightings.clear();
        assert!(solve(&rec, &model).is_none());
    }
}
