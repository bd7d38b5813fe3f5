//! Scores a [`Recording`] (docs/ALGORITHMS.md §6): against ground truth when the run has
//! it — trajectory error (ATE, RPE, heading, final; see [`crate::scoring`]), consistency
//! (NEES), map error with an optimal landmark assignment — and, with a relations file,
//! the relation errors of each trajectory ([`crate::relations`]); with or without truth,
//! filter health from the status topic and cost (step time, end-to-end latency, CPU time
//! and peak memory). `METRICS.md` documents every field.

use crate::align::Se2;
use crate::recording::{Estimate, Recording, StampedPose};
use crate::reference::{self, NoiseModel, ReferenceMetrics};
use crate::relations::{MAX_GAP_S, Relation, score_stamped};
use crate::resources::ProcessUsage;
use crate::stats::{Spread, mean};
use fastslam_estimation::wrap_angle;
use fastslam_protocol::MapLandmark;
use fastslam_protocol::status::{noise_fit, noise_suspect};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

pub use crate::account::InputAccount;
pub use crate::scoring::{
    AlignMode, Alignment, ScoreAt, TrajectoryMetrics, error, fit_alignment, fit_se2, interpolate,
    sampled_at, scored_at, trajectory,
};

/// Estimated landmarks farther than this from every true one count as spurious (m).
pub const LANDMARK_CUTOFF_M: f64 = 5.0;
/// Upper 95 % point of χ² with 3 degrees of freedom: a consistent filter's pose NEES
/// stays below it at 95 % of the steps.
pub const CHI2_3_95: f64 = 7.814_727_903_251_178;
/// The service's iceoryx2 node name, whose CPU time is the filter's cost.
pub const SERVICE_NODE: &str = "fastslam-service";

/// Everything the client measured, as written to `metrics.json` (whose shape leaves out
/// what a run did not measure, see [`crate::metrics_json`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Metrics {
    /// Every stream ended: true when the client received the end of every stream it
    /// waits for; false when the run was interrupted before. It says nothing of what the
    /// streams carried (see [`Metrics::inputs`] and the pose count).
    pub complete: bool,
    /// The run had ground truth. Without it, the truth-based numbers — the errors of each
    /// [`TrajectoryMetrics`], [`Metrics::consistency`], [`Metrics::map`] and the smoothed
    /// map — are not measured: NaN or 0 here, absent from `metrics.json`; and there is no
    /// reference.
    pub ground_truth: bool,
    /// How the estimate was aligned with the truth before scoring.
    pub alignment: Alignment,
    /// Where the trajectories were compared with the truth.
    pub scored_at: ScoreAt,
    /// The service's pose estimates against ground truth and the relations.
    pub estimate: TrajectoryMetrics,
    /// Dead reckoning (the odometry's own pose) at the same stamps: the baseline.
    pub dead_reckoning: TrajectoryMetrics,
    /// The achievable-accuracy reference (absent without sightings with landmark ids,
    /// without the filter's noise model or without ground truth), see
    /// [`crate::reference`].
    pub reference: Option<ReferenceMetrics>,
    /// The smoothing back-end's last solution (absent when the service ran without
    /// one), see [`Metrics::with_smoothed`].
    pub smoothed: Option<SmoothedMetrics>,
    /// Consistency of the estimate's covariance (measured only with ground truth).
    pub consistency: Consistency,
    /// The final landmark map against the true one (measured only with ground truth).
    pub map: MapMetrics,
    /// Filter health from the service's status topic.
    pub filter: FilterHealth,
    /// Inputs the service dropped or rejected, from its status topic.
    pub inputs: InputAccount,
    /// What the run cost: time and memory. Not reproducible bit for bit (wall clock).
    pub cost: Cost,
}

/// The smoothing back-end's trajectory and map against ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedMetrics {
    /// Its trajectory (the poses at the scans with sightings), scored as the estimate.
    pub trajectory: TrajectoryMetrics,
    /// χ² per degree of freedom of its solution.
    pub chi2_per_dof: f64,
    /// Solves the back-end ran.
    pub solves: u32,
    /// Its map against the true landmarks (measured only with ground truth).
    pub map: MapMetrics,
}

/// Normalised estimation error squared of the pose (x, y, θ).
///
/// A pose whose covariance is not positive definite (the particles collapsed onto one
/// pose, leaving a covariance of rounding noise) has no finite NEES — the filter claims no
/// uncertainty in some direction. It is counted in `singular`, left out of the mean, and
/// counted as outside the 95 % bound.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Consistency {
    /// Poses with a positive definite covariance (those the mean is taken over).
    pub poses: usize,
    /// Poses whose covariance is not positive definite.
    pub singular: usize,
    /// Mean NEES over `poses` (≈ 3 for a consistent filter; larger means over-confident).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub nees_mean: f64,
    /// Fraction of all compared poses (`poses + singular`) with NEES below the χ²₃ 95 %
    /// point (≈ 0.95 when consistent).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub nees_within_95: f64,
}

/// The estimated map against the true landmarks.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MapMetrics {
    /// Landmarks in the estimated map.
    pub estimated: usize,
    /// Landmarks in the true map.
    pub truth: usize,
    /// Estimated landmarks assigned to a true one within the cut-off.
    pub matched: usize,
    /// True landmarks without an estimate.
    pub missed: usize,
    /// Estimated landmarks without a true one.
    pub spurious: usize,
    /// RMSE of the matched landmarks' position error (m).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub rmse_m: f64,
    /// The assignment cut-off (m).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub cutoff_m: f64,
}

/// How the particle set fared, from the service's status messages.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FilterHealth {
    /// Observation steps with a status message.
    pub steps: usize,
    /// Steps that resampled.
    pub resamplings: usize,
    /// Number of particles (of the last step).
    pub particles: u32,
    /// Mean effective sample size before resampling.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub n_eff_mean: f64,
    /// Smallest effective sample size.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub n_eff_min: f64,
    /// Mean of `N_eff / particles` (1 = all weights equal).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub n_eff_ratio_mean: f64,
    /// Mean number of distinct particles after a step (all steps).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub distinct_mean: f64,
    /// Mean number of distinct particles right after resampling (diversity).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub distinct_after_resampling_mean: f64,
    /// Fewest distinct particles after a step.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub distinct_min: f64,
    /// The noise check: mean over the steps of the windowed NIS per degree of freedom
    /// (1 when the noise model fits the data).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub nis_mean: f64,
    /// Fraction of the steps at which the noise check failed (NIS above its χ² band for
    /// a whole window).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub nis_high_fraction: f64,
    /// Where the noise check points: with the smoothing back-end's fit (`noise_fit` is
    /// `smoother`), the source whose variance component is at least twice the model's
    /// (the larger); else, when the NIS check failed, the suspect of most failed steps.
    /// `odometry`, `sensor`, or empty.
    pub nis_suspect: String,
    /// Solves of the smoothing back-end withheld as torn (docs/ALGORITHMS.md §8.3).
    #[serde(default)]
    pub smoother_torn_solves: u32,
    /// The landmark filter associated its observations without ids.
    #[serde(default)]
    pub unknown_association: bool,
    /// The configured noise as standard deviations at the last step: the motion model's
    /// two (`sigma_v` and `sigma_omega` or `sigma_steering`), `sigma_range`,
    /// `sigma_bearing` (zeros without a noise fit).
    #[serde(default)]
    pub noise_profile: [f64; 4],
    /// The same four as the noise fit had them at the last step (docs/ALGORITHMS.md §1,
    /// "Noise fit").
    #[serde(default)]
    pub noise_fitted: [f64; 4],
    /// Where `noise_fitted` comes from: `smoother` (the back-end's variance components
    /// of its last whole solve), `innovations` (the filter's fit), or empty (no fit).
    #[serde(default)]
    pub noise_fit: String,
}

/// Time and memory the run took.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Cost {
    /// The service's filter update time per observation step, as it reported it (ms).
    pub step_time_ms: Spread,
    /// End-to-end latency from an observation's publication to the publication of the
    /// pose it produced, as the client received both (ms).
    pub latency_ms: Spread,
    /// CPU time and peak memory of each process of the stack.
    pub processes: Vec<ProcessUsage>,
    /// CPU time of the FastSLAM service (s); NaN when it was not found.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub service_cpu_s: f64,
    /// CPU time of all processes of the stack together (s).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub stack_cpu_s: f64,
    /// Wall time from the first observation to the last pose the client received (s):
    /// the run streamed through the processes, start-up and scoring left out; NaN when
    /// no pose arrived.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub stream_wall_s: f64,
}

impl Metrics {
    /// Fails when every stream ended without a single pose estimate (a route that never
    /// moves, no scan reaching the filter): such a run is a failure, not a success with
    /// no metrics. `folder` is the run folder, named in the error.
    ///
    /// # Errors
    /// One line saying so, when the run is complete and has no pose.
    pub fn require_a_pose(&self, folder: &std::path::Path) -> anyhow::Result<()> {
        if self.complete && self.estimate.poses == 0 {
            anyhow::bail!(
                "the run ended without a pose estimate: every stream ended before a scan \
                 reached the filter ({} inputs rejected); run folder {}",
                self.inputs.rejected_total,
                folder.display()
            );
        }
        Ok(())
    }

    /// Reads a run folder's `metrics.json` back.
    ///
    /// # Errors
    /// When the file cannot be read or is not metrics this client writes.
    pub fn read(path: &std::path::Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Scores `rec` (already aligned as `alignment` says, see [`fit_alignment`]) at the
    /// stamps `at` says (see [`scored_at`]); `complete` says whether every stream ended
    /// normally. A recording without ground truth ([`Recording::without_truth`]) is
    /// scored at its estimates, with nothing measured against truth.
    pub fn compute(rec: &Recording, complete: bool, alignment: Alignment, at: ScoreAt) -> Self {
        let ground_truth = !rec.without_truth;
        let rec = &scored_at(rec, if ground_truth { at } else { ScoreAt::Estimates });
        let estimates: Vec<StampedPose> = rec.estimates.iter().map(|e| e.pose).collect();
        let dead_reckoning = sampled_at(&rec.dead_reckoning, &estimates);
        let score = |poses: &[StampedPose]| {
            if ground_truth {
                trajectory(poses, &rec.truth)
            } else {
                TrajectoryMetrics::unmeasured(poses.len())
            }
        };
        Self {
            complete,
            ground_truth,
            alignment,
            scored_at: at,
            estimate: score(&estimates),
            dead_reckoning: score(&dead_reckoning),
            reference: None,
            smoothed: None,
            consistency: if ground_truth {
                consistency(rec)
            } else {
                Consistency::unmeasured()
            },
            map: if ground_truth {
                map(&rec.map, &rec.true_map, LANDMARK_CUTOFF_M)
            } else {
                MapMetrics::unmeasured()
            },
            filter: filter_health(rec),
            inputs: InputAccount::of(rec),
            cost: cost(rec),
        }
    }
}

impl Metrics {
    /// The reference's ATE RMSE (m); not a number without a reference.
    pub fn reference_ate_m(&self) -> f64 {
        self.reference.map_or(f64::NAN, |r| r.ate_rmse_m)
    }

    /// Adds the smoothing back-end's last solution in `rec` (nothing without one),
    /// scored as these metrics are; `rec.smoothed` and `rec.smoothed_map` are brought into
    /// the truth's frame (by the smoothed trajectory's own fit when aligning).
    pub fn with_smoothed(mut self, rec: &mut Recording) -> Self {
        let Some((chi2_per_dof, solves)) = rec.smoothed_fit else {
            return self;
        };
        let align = self.alignment.method;
        let transform = match align {
            AlignMode::None => Se2::IDENTITY,
            _ => fit_se2(&rec.smoothed, &rec.truth),
        };
        let trajectory = if self.ground_truth {
            reference::score(&rec.smoothed, &rec.truth, align, self.scored_at)
        } else {
            TrajectoryMetrics::unmeasured(rec.smoothed.len())
        };
        rec.smoothed = reference::aligned(&rec.smoothed, &rec.truth, align);
        rec.smoothed_map = (rec.smoothed_map.iter())
            .map(|l| transform.apply_landmark(l))
            .collect();
        self.smoothed = Some(SmoothedMetrics {
            trajectory,
            chi2_per_dof,
            solves,
            map: if self.ground_truth {
                map(&rec.smoothed_map, &rec.true_map, LANDMARK_CUTOFF_M)
            } else {
                MapMetrics::unmeasured()
            },
        });
        self
    }

    /// The smoothed trajectory's ATE RMSE (m); not a number without one.
    pub fn smoothed_ate_m(&self) -> f64 {
        (self.smoothed.as_ref()).map_or(f64::NAN, |s| s.trajectory.ate_rmse_m)
    }

    /// Adds the reference of `rec` solved under `model` (nothing when it has none, or
    /// without ground truth to score it against), scored as these metrics are; its poses,
    /// in the truth's frame, go into `rec.reference` for the run folder.
    pub fn with_reference(mut self, rec: &mut Recording, model: &NoiseModel) -> Self {
        if !self.ground_truth {
            return self;
        }
        let solved = reference::solve(rec, model);
        let align = self.alignment.method;
        self.reference = (solved.as_ref()).map(|r| r.score(&rec.truth, align, self.scored_at));
        rec.reference = (solved.as_ref()).map_or_else(Vec::new, |r| r.aligned(&rec.truth, align));
        rec.reference_graph = solved.map(|r| r.graph);
        self
    }

    /// Adds the errors of the estimate, dead reckoning (sampled at the estimate stamps,
    /// as it is scored against truth) and the smoothed trajectory of `rec` (call it after
    /// [`Metrics::with_smoothed`]) against `relations`, whose times are on a clock where
    /// stamp 0 is `epoch_s` and whose motions are of `body`, posed on the base (see
    /// [`crate::relations`]). A trajectory none of whose relations can be scored gets none.
    pub fn with_relations(
        mut self,
        rec: &Recording,
        relations: &[Relation],
        epoch_s: f64,
        body: &Se2,
    ) -> Self {
        let score = |p: &[StampedPose]| score_stamped(relations, p, epoch_s, body, MAX_GAP_S);
        let estimates: Vec<StampedPose> = rec.estimates.iter().map(|e| e.pose).collect();
        self.estimate.relations = score(&estimates);
        self.dead_reckoning.relations = score(&sampled_at(&rec.dead_reckoning, &estimates));
        if let Some(s) = &mut self.smoothed {
            s.trajectory.relations = score(&rec.smoothed);
        }
        self
    }
}

impl Consistency {
    /// The consistency of a run without ground truth: nothing compared.
    pub fn unmeasured() -> Self {
        Self {
            poses: 0,
            singular: 0,
            nees_mean: f64::NAN,
            nees_within_95: f64::NAN,
        }
    }
}

impl MapMetrics {
    /// The map scores of a run without ground truth: nothing compared.
    pub fn unmeasured() -> Self {
        map(&[], &[], LANDMARK_CUTOFF_M)
    }
}

/// NEES of an estimate against the truth at its stamp, through the Cholesky factor of its
/// covariance (which exists exactly when the covariance is positive definite). `None`
/// without truth at the stamp; `Some(None)` when the covariance is not positive definite
/// (see [`Consistency`]).
pub fn nees(e: &Estimate, truth: &[StampedPose]) -> Option<Option<f64>> {
    let t = interpolate(truth, e.pose.stamp_ns)?;
    let err = Vector3::new(
        e.pose.x - t.x,
        e.pose.y - t.y,
        wrap_angle(e.pose.theta - t.theta),
    );
    Some(
        Matrix3::from_row_slice(&e.covariance)
            .cholesky()
            .map(|c| err.dot(&c.solve(&err)))
            .filter(|v| v.is_finite()),
    )
}

/// NEES of each estimate against the truth at its stamp.
pub fn consistency(rec: &Recording) -> Consistency {
    let compared: Vec<Option<f64>> = rec
        .estimates
        .iter()
        .filter_map(|e| nees(e, &rec.truth))
        .collect();
    let nees: Vec<f64> = compared.iter().flatten().copied().collect();
    Consistency {
        poses: nees.len(),
        singular: compared.len() - nees.len(),
        nees_mean: mean(&nees),
        nees_within_95: if compared.is_empty() {
            f64::NAN
        } else {
            nees.iter().filter(|&&v| v <= CHI2_3_95).count() as f64 / compared.len() as f64
        },
    }
}

/// Filter health over the status messages.
pub fn filter_health(rec: &Recording) -> FilterHealth {
    let s = &rec.status;
    let of =
        |f: &dyn Fn(&crate::recording::StatusSample) -> f64| s.iter().map(f).collect::<Vec<f64>>();
    let n_eff = of(&|x| x.n_eff);
    let distinct = of(&|x| f64::from(x.distinct));
    let high: Vec<&crate::recording::StatusSample> = s.iter().filter(|x| x.nis_high).collect();
    let after: Vec<f64> = s
        .iter()
        .filter(|x| x.resampled)
        .map(|x| f64::from(x.distinct))
        .collect();
    FilterHealth {
        steps: s.len(),
        resamplings: after.len(),
        particles: s.last().map_or(0, |x| x.particles),
        n_eff_mean: mean(&n_eff),
        n_eff_min: n_eff.iter().copied().fold(f64::NAN, f64::min),
        n_eff_ratio_mean: mean(&of(&|x| x.n_eff / f64::from(x.particles.max(1)))),
        distinct_mean: mean(&distinct),
        distinct_after_resampling_mean: mean(&after),
        distinct_min: distinct.iter().copied().fold(f64::NAN, f64::min),
        nis_mean: mean(
            &of(&|x| x.nis)
                .into_iter()
                .filter(|v| v.is_finite())
                .collect::<Vec<_>>(),
        ),
        nis_high_fraction: high.len() as f64 / s.len().max(1) as f64,
        nis_suspect: match (s.last(), high.iter().filter(|x| x.nis_pose).count()) {
            (Some(last), _) if last.noise_fit == noise_fit::SMOOTHER => match last.noise_suspect {
                noise_suspect::ODOMETRY => "odometry".into(),
                noise_suspect::SENSOR => "sensor".into(),
                _ => String::new(),
            },
            _ if high.is_empty() => String::new(),
            (_, pose) if 2 * pose >= high.len() => "odometry".into(),
            _ => "sensor".into(),
        },
        smoother_torn_solves: rec.torn_solves,
        unknown_association: rec.unknown_association,
        noise_profile: s.last().map_or([0.0; 4], |x| x.noise_profile),
        noise_fitted: s.last().map_or([0.0; 4], |x| x.noise_fitted),
        noise_fit: match s.last().map(|x| x.noise_fit) {
            Some(noise_fit::SMOOTHER) => "smoother".into(),
            Some(noise_fit::INNOVATIONS) => "innovations".into(),
            _ => String::new(),
        },
    }
}

/// Step times, latencies and process usage.
pub fn cost(rec: &Recording) -> Cost {
    let service_cpu_s = rec
        .processes
        .iter()
        .filter(|p| p.name == SERVICE_NODE)
        .map(|p| p.cpu_s)
        .reduce(|a, b| a + b)
        .unwrap_or(f64::NAN);
    Cost {
        step_time_ms: Spread::of(rec.status.iter().map(|x| x.step_time_s * 1e3)),
        latency_ms: Spread::of(rec.latencies.iter().map(|l| l.1 * 1e3)),
        processes: rec.processes.clone(),
        service_cpu_s,
        stack_cpu_s: rec.processes.iter().map(|p| p.cpu_s).sum(),
        stream_wall_s: rec.streamed_s.unwrap_or(f64::NAN),
    }
}

/// Assigns estimated to true landmarks minimising the total squared distance (Hungarian
/// method), then drops pairs farther apart than `cutoff_m`.
pub fn map(estimated: &[MapLandmark], truth: &[MapLandmark], cutoff_m: f64) -> MapMetrics {
    let pairs = assign(estimated, truth, cutoff_m);
    let matched = pairs.len();
    let rmse_m = crate::stats::rms(&pairs);
    MapMetrics {
        estimated: estimated.len(),
        truth: truth.len(),
        matched,
        missed: truth.len() - matched,
        spurious: estimated.len() - matched,
        rmse_m,
        cutoff_m,
    }
}

/// Distances of the optimally assigned pairs within the cut-off.
fn assign(a: &[MapLandmark], b: &[MapLandmark], cutoff_m: f64) -> Vec<f64> {
    use pathfinding::prelude::{Matrix, kuhn_munkres_min};
    // The Hungarian method wants rows ≤ columns and integer costs: squared distance in
    // mm², with pairs beyond the cut-off all at the same (prohibitive) cost.
    let (rows, cols) = if a.len() <= b.len() { (a, b) } else { (b, a) };
    if rows.is_empty() {
        return Vec::new();
    }
    let dist = |p: &MapLandmark, q: &MapLandmark| (p.x - q.x).hypot(p.y - q.y);
    let beyond = ((cutoff_m * 1e3).powi(2) as i64 + 1) * 4;
    let weights = Matrix::from_fn(rows.len(), cols.len(), |(i, j)| {
        let d = dist(&rows[i], &cols[j]);
        if d <= cutoff_m {
            (d * 1e3).powi(2) as i64
        } else {
            beyond
        }
    });
    let (_, columns) = kuhn_munkres_min(&weights);
    columns
        .iter()
        .enumerate()
        .map(|(i, &j)| dist(&rows[i], &cols[j]))
        .filter(|&d| d <= cutoff_m)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::StatusSample;

    fn pose(t: u64, x: f64, y: f64, theta: f64) -> StampedPose {
        StampedPose {
            stamp_ns: t,
            x,
            y,
            theta,
        }
    }

    fn lm(x: f64, y: f64) -> MapLandmark {
        MapLandmark {
            x,
            y,
            ..Default::default()
        }
    }

    #[test]
    fn metrics_json_reads_back_with_nan_as_null() {
        let rec = Recording::default();
        let m = Metrics::compute(&rec, false, Alignment::default(), ScoreAt::Estimates);
        assert!(m.estimate.ate_rmse_m.is_nan(), "nothing to score: NaN");
        let json = serde_json::to_string_pretty(&m).unwrap();
        assert!(json.contains("\"ate_rmse_m\": null"), "{json}");
        let back: Metrics = serde_json::from_str(&json).unwrap();
        assert!(back.estimate.ate_rmse_m.is_nan());
        assert_eq!(serde_json::to_string_pretty(&back).unwrap(), json);
    }

    #[test]
    fn map_assignment_is_optimal_not_greedy() {
        // Greedy would pair e0 with t1 (0.9 m) and leave e1 to t0 (2.0 m);
        // the optimum pairs e0–t0 (1.0) and e1–t1 (1.0).
        let truth = [lm(0.0, 0.0), lm(1.9, 0.0)];
        let est = [lm(1.0, 0.0), lm(2.9, 0.0)];
        let m = map(&est, &truth, 5.0);
        assert_eq!((m.matched, m.missed, m.spurious), (2, 0, 0));
        assert!((m.rmse_m - 1.0).abs() < 1e-9, "{}", m.rmse_m);
    }

    #[test]
    fn map_counts_missed_and_spurious_beyond_cutoff() {
        let truth = [lm(0.0, 0.0), lm(100.0, 0.0), lm(200.0, 0.0)];
        let est = [lm(0.3, 0.4), lm(50.0, 0.0)];
        let m = map(&est, &truth, 5.0);
        assert_eq!((m.matched, m.missed, m.spurious), (1, 2, 1));
        assert!((m.rmse_m - 0.5).abs() < 1e-9);
    }

    #[test]
    fn a_covariance_that_is_not_positive_definite_is_singular_not_a_negative_nees() {
        // Particles collapsed onto one pose give a covariance of rounding noise: symmetric
        // and invertible, but indefinite. Its "NEES" would be a huge negative number.
        let indefinite = [1e-20, 0.0, 0.0, 0.0, 1e-20, 0.0, 0.0, 0.0, -1e-22];
        let ok = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let estimate = |t: u64, covariance: [f64; 9]| crate::recording::Estimate {
            pose: pose(t, 0.0, 0.0, 0.1),
            covariance,
        };
        let rec = Recording {
            truth: vec![pose(0, 0.0, 0.0, 0.0), pose(1, 0.0, 0.0, 0.0)],
            estimates: vec![estimate(0, indefinite), estimate(1, ok)],
            ..Default::default()
        };
        let c = consistency(&rec);
        assert_eq!((c.poses, c.singular), (1, 1));
        assert!((c.nees_mean - 0.01).abs() < 1e-12, "{}", c.nees_mean);
        assert_eq!(
            c.nees_within_95, 0.5,
            "a singular pose is outside the bound"
        );
    }

    #[test]
    fn nees_of_a_one_sigma_error_is_one() {
        let cov = [4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let rec = Recording {
            truth: vec![pose(0, 0.0, 0.0, 0.0)],
            estimates: vec![crate::recording::Estimate {
                pose: pose(0, 2.0, 0.0, 0.0),
                covariance: cov,
            }],
            ..Default::default()
        };
        let c = consistency(&rec);
        assert_eq!(c.poses, 1);
        assert!((c.nees_mean - 1.0).abs() < 1e-12);
        assert_eq!(c.nees_within_95, 1.0);
    }

    #[test]
    fn scoring_at_sparse_truth_compares_at_each_fix_inside_the_estimate() {
        // Truth on a curve, fixes every 10 stamps; the estimate follows it exactly at
        // every stamp 5..=35, so only the fixes 10, 20, 30 lie inside it.
        let curve = |t: u64| pose(t, t as f64, (t as f64 * 0.3).sin() * 4.0, 0.0);
        let cov = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let rec = Recording {
            truth: (0..5).map(|k| curve(10 * k)).collect(),
            estimates: (5..=35)
                .map(|t| crate::recording::Estimate {
                    pose: curve(t),
                    covariance: cov,
                })
                .collect(),
            ..Default::default()
        };
        let at_truth = Metrics::compute(&rec, true, Alignment::default(), ScoreAt::Truth);
        assert_eq!(at_truth.estimate.poses, 3);
        assert!(
            at_truth.estimate.ate_rmse_m < 1e-12,
            "{:?}",
            at_truth.estimate
        );
        // At the estimates, the truth interpolated between far fixes is off the curve.
        let at_estimates = Metrics::compute(&rec, true, Alignment::default(), ScoreAt::Estimates);
        assert_eq!(at_estimates.estimate.poses, 31);
        assert!(at_estimates.estimate.ate_rmse_m > 0.1);
    }

    #[test]
    fn se2_alignment_removes_a_frame_offset_and_moves_the_map_with_it() {
        // The estimate is the truth seen from a rotated, shifted frame.
        let frame = Se2 {
            x: 4.0,
            y: -1.0,
            theta: 0.3,
        };
        let truth: Vec<_> = (0..20)
            .map(|k| pose(k, k as f64, (k as f64 * 0.4).sin() * 3.0, 0.2))
            .collect();
        let to_estimate = frame.inverse();
        let cov = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let rec = Recording {
            estimates: truth
                .iter()
                .map(|p| crate::recording::Estimate {
                    pose: to_estimate.apply_pose(p),
                    covariance: cov,
                })
                .collect(),
            dead_reckoning: truth.clone(),
            map: vec![{
                let (x, y) = to_estimate.apply(10.0, 5.0);
                MapLandmark {
                    x,
                    y,
                    ..lm(0.0, 0.0)
                }
            }],
            true_map: vec![lm(10.0, 5.0)],
            truth,
            ..Default::default()
        };
        let unaligned = Metrics::compute(&rec, true, Alignment::default(), ScoreAt::Estimates);
        assert!(unaligned.estimate.ate_rmse_m > 1.0);
        let alignment = fit_alignment(&rec, AlignMode::Se2);
        let m = Metrics::compute(&alignment.apply(&rec), true, alignment, ScoreAt::Estimates);
        assert!(m.estimate.ate_rmse_m < 1e-9, "{:?}", m.estimate);
        assert!(m.estimate.heading_rmse_rad < 1e-9);
        assert!(m.map.rmse_m < 1e-9 && m.map.matched == 1, "{:?}", m.map);
        let t = m.alignment.estimate;
        assert!((t.x - frame.x).abs() < 1e-9 && (t.theta - frame.theta).abs() < 1e-9);
        // Dead reckoning already sat in the true frame: its fit is the identity.
        assert!(m.alignment.dead_reckoning.x.abs() < 1e-9);
        // Relative errors do not depend on the frame.
        assert_eq!(m.estimate.rpe.len(), crate::rpe::RPE_DELTAS_M.len());
        assert!(m.estimate.rpe[0].translation_rmse_m < 1e-9);
    }

    fn status(stamp_ns: u64, n_eff: f64, distinct: u32, resampled: bool) -> StatusSample {
        StatusSample {
            stamp_ns,
            n_eff,
            particles: 10,
            distinct,
            resampled,
            landmarks: 3,
            step_time_s: 0.001 * stamp_ns as f64,
            nis: 1.0,
            nis_high: stamp_ns >= 2,
            nis_pose: stamp_ns != 3,
            noise_profile: [0.0; 4],
            noise_fitted: [0.0; 4],
            noise_fit: 1,
            noise_suspect: 0,
        }
    }

    #[test]
    fn filter_health_summarises_the_status_stream() {
        let rec = Recording {
            status: vec![
                status(1, 9.0, 10, false),
                status(2, 3.0, 4, true),
                status(3, 6.0, 6, true),
            ],
            ..Default::default()
        };
        let h = filter_health(&rec);
        assert_eq!((h.steps, h.resamplings, h.particles), (3, 2, 10));
        assert!((h.n_eff_mean - 6.0).abs() < 1e-12 && h.n_eff_min == 3.0);
        assert!((h.n_eff_ratio_mean - 0.6).abs() < 1e-12);
        assert!((h.distinct_mean - 20.0 / 3.0).abs() < 1e-12);
        assert_eq!(
            (h.distinct_after_resampling_mean, h.distinct_min),
            (5.0, 4.0)
        );
        assert!((h.nis_mean - 1.0).abs() < 1e-12);
        assert!((h.nis_high_fraction - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(
            h.nis_suspect, "odometry",
            "half the failed steps blame the pose"
        );
        assert_eq!(h.noise_fit, "innovations");
        let mut smoothed = rec.clone();
        let last = smoothed.status.last_mut().unwrap();
        (last.noise_fit, last.noise_suspect) = (noise_fit::SMOOTHER, noise_suspect::SENSOR);
        let h = filter_health(&smoothed);
        assert_eq!(
            (h.nis_suspect.as_str(), h.noise_fit.as_str()),
            ("sensor", "smoother"),
            "the back-end's verdict stands over the failed steps'"
        );
        let c = cost(&rec);
        assert_eq!(c.step_time_ms.samples, 3);
        assert!((c.step_time_ms.median - 2.0).abs() < 1e-9);
        assert!(c.service_cpu_s.is_nan() && c.stack_cpu_s == 0.0);
    }

    #[test]
    fn service_cpu_is_the_service_node_s() {
        let usage = |name: &str, cpu_s: f64| ProcessUsage {
            name: name.into(),
            pid: 1,
            cpu_user_s: cpu_s,
            cpu_system_s: 0.0,
            cpu_s,
            peak_rss_mib: 1.0,
        };
        let rec = Recording {
            processes: vec![usage("truth-sim", 0.5), usage(SERVICE_NODE, 2.0)],
            latencies: vec![(1, 0.002), (2, 0.004), (3, 0.003)],
            ..Default::default()
        };
        let c = cost(&rec);
        assert_eq!((c.service_cpu_s, c.stack_cpu_s), (2.0, 2.5));
        assert!((c.latency_ms.median - 3.0).abs() < 1e-9 && (c.latency_ms.p99 - 4.0).abs() < 1e-9);
    }
}
