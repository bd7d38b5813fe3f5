//! Data association and weighting of one scan against one particle's map
//! (docs/ALGORITHMS.md §1 step 3), read-only: it decides what each observation does and what it
//! contributes to the particle's log-weight; [`Particle`](super::Particle) applies the
//! decisions afterwards.
//!
//! Decisions the spec leaves open, taken here:
//! - **One scan, one assignment** (unknown association). Each observation is paired with
//!   every landmark in its search window; every landmark takes at most one observation
//!   per scan, so associating the whole scan before updating any landmark is exact. A
//!   pair is *assignable* when its normalised innovation squared is under `gate_reject`
//!   and, with `likelihood_ratio`, its likelihood `N(ν; 0, S)` is at least that of a new
//!   landmark (`log_p_new`). [`Assignment::Greedy`] (default): in scan order, each
//!   observation takes the most likely landmark the earlier ones left, if assignable.
//!   [`Assignment::Joint`]: each observation takes its most likely assignable landmark;
//!   where two take the same one, the scan's pairs are assigned jointly — the assignment
//!   with the largest total log-likelihood, each observation free to be "no mapped
//!   landmark" at `log_p_new` (Hungarian algorithm, `pathfinding`).
//!   [`Assignment::Sampled`]: each particle draws its association from the likelihoods
//!   (Montemerlo's data-association sampling); no gate, no ignored observation.
//! - **Unassigned observations** start a landmark when every landmark not taken by
//!   another observation (greedy: by an earlier one) lies beyond `gate_new`; otherwise they
//!   are *ignored* (ambiguous) and contribute `max(log N(ν; 0, S) of the most likely such
//!   landmark, log_p_new)`: the observation is that landmark or a new one, and we do not
//!   commit to either. A fixed 0 would depend on the units of `S`.
//! - **Pose uncertainty.** With `pose_uncertainty`, FastSLAM 2.0's proposal associates at
//!   the motion prior's mean with the prior's covariance added to every `S`
//!   (`Scan::associate_uncertain`), so after a long stretch without landmarks the gate
//!   has grown with the drift and a re-sighted landmark is recognised instead of
//!   duplicated. A FastSLAM 1.0 particle is a point: its pose uncertainty is the spread of
//!   the cloud.
//! - **Known association** updates the landmark with the observation's id without gating
//!   (the id is trusted); an id not yet in the map creates that landmark.
//! - **Search window** of unknown association: landmarks within
//!   `max(search_radius, 2 √gate_new σ_w)` metres of the observed point, where
//!   `σ_w = √(σ_r² + (r σ_b)²)` is the observation's spread in the world, widened by
//!   `2 √gate_new √(P_xx + P_yy + r² P_θθ)` with a pose covariance `P`. A landmark farther
//!   away is taken to have `d² > gate_new`, which holds unless its own covariance is much
//!   larger than the observation's.

mod config;
mod unknown;

pub use config::{Assignment, AssociationConfig, AssociationMode};

use super::ekf::{self, Innovation};
use super::landmarks::{LandmarkMap, Slot};
use crate::observation::{self, Observation, Sensor};
use crate::pose::Pose2;
use crate::rng::SimRng;
use nalgebra::{Matrix2, Matrix3};
use unknown::Scratch;

/// One scan ready for association: checked observations, the sensor that took them, the
/// association settings and the filter's step counter.
///
/// Handed to a [`PoseRefiner`](super::PoseRefiner), it evaluates the observation
/// likelihood of candidate poses ([`Scan::log_likelihood`]).
#[derive(Debug, Clone, Copy)]
pub struct Scan<'a> {
    observations: &'a [Observation],
    sensor: &'a Sensor,
    config: &'a AssociationConfig,
    step: u64,
}

/// What one observation does to one particle's map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Decision {
    /// EKF-update the landmark stored at `slot` with this innovation and Jacobian (w.r.t.
    /// the landmark).
    Update {
        slot: Slot,
        h: Matrix2<f64>,
        innovation: Innovation,
    },
    /// Start a landmark: with the observation's id (known association) or a fresh one.
    New { id: Option<u64> },
    /// Leave the map alone.
    Ignore,
}

/// The decisions for a whole scan (one per observation, in order) and the scan's
/// log-likelihood under the particle.
#[derive(Debug, Clone, Default)]
pub(crate) struct ScanAssociation {
    pub decisions: Vec<Decision>,
    pub log_likelihood: f64,
    /// The particle's stream for [`Assignment::Sampled`] (set by the filter for its
    /// final association; without it, sampling falls back to `greedy`).
    pub sampler: Option<SimRng>,
    scratch: Scratch,
}

/// The landmarks the scan's earlier observations were assigned to (updated, or created
/// with a known id): read from their decisions, so no list is kept beside them.
#[derive(Clone, Copy)]
struct Claimed<'d>(&'d [Decision]);

impl Claimed<'_> {
    fn contains(self, id: u64) -> bool {
        self.0.iter().any(|d| match *d {
            Decision::Update { slot, .. } => slot.id() == id,
            Decision::New { id: Some(claimed) } => claimed == id,
            Decision::New { id: None } | Decision::Ignore => false,
        })
    }
}

impl<'a> Scan<'a> {
    /// A scan of `observations` (already checked: finite, with an id under known
    /// association) taken by `sensor` at filter step `step`. The filter builds its own;
    /// this one is for evaluating likelihoods outside it (tests, tools).
    pub fn new(
        observations: &'a [Observation],
        sensor: &'a Sensor,
        config: &'a AssociationConfig,
        step: u64,
    ) -> Self {
        Self {
            observations,
            sensor,
            config,
            step,
        }
    }

    /// The scan's observations (only the well-formed ones).
    pub fn observations(&self) -> &'a [Observation] {
        self.observations
    }

    /// The association settings.
    pub fn config(&self) -> &'a AssociationConfig {
        self.config
    }

    /// The sensor that took the scan.
    pub fn sensor(&self) -> &'a Sensor {
        self.sensor
    }

    /// The filter's step counter, for seeding per-step random streams.
    pub fn step(&self) -> u64 {
        self.step
    }

    /// `log p(z₁..zₙ | pose, map)` under this module's association: the observation term of
    /// a particle at a candidate `pose` with its own `map` (docs/ALGORITHMS.md §3 fitness).
    ///
    /// # Performance
    /// O(n · (log M + k)) for n observations and k landmarks per search window.
    pub fn log_likelihood(&self, map: &LandmarkMap, pose: &Pose2) -> f64 {
        self.associate(map, pose).log_likelihood
    }

    /// The Gauss–Newton information of the scan about the pose at `pose`,
    /// `Σⱼ H_xⱼᵀ Sⱼ⁻¹ H_xⱼ` over the observations that update a landmark of `map`
    /// (`H_x` the measurement Jacobian w.r.t. the pose, `S = H_m Σ H_mᵀ + R` the
    /// innovation covariance given the pose), and whether any observation did: zero
    /// information when none does. The Laplace covariance of the corrected optimiser
    /// modes is built from it (docs/ALGORITHMS.md §3.1).
    ///
    /// # Performance
    /// One association plus O(matched) 3 × 3 products.
    pub fn pose_information(&self, map: &LandmarkMap, pose: &Pose2) -> (Matrix3<f64>, bool) {
        let association = self.associate(map, pose);
        let mut information = Matrix3::zeros();
        let mut matched = false;
        for decision in &association.decisions {
            let Decision::Update {
                slot, innovation, ..
            } = decision
            else {
                continue;
            };
            let Some(p) = map
                .at(*slot)
                .and_then(|landmark| observation::predict(pose, &landmark.mean))
            else {
                continue;
            };
            information += p.wrt_pose.transpose() * innovation.s_inv * p.wrt_pose;
            matched = true;
        }
        (0.5 * (information + information.transpose()), matched)
    }

    /// Associates every observation with `map` as seen from `pose`; see the module docs.
    pub(crate) fn associate(&self, map: &LandmarkMap, pose: &Pose2) -> ScanAssociation {
        let mut association = ScanAssociation::default();
        self.associate_into(map, pose, &mut association);
        association
    }

    /// [`associate`](Self::associate) into `out`, reusing its decision buffer: the
    /// filter's step allocates nothing here once the buffer has grown to the scan's size.
    pub(crate) fn associate_into(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        out: &mut ScanAssociation,
    ) {
        self.associate_around(map, pose, None, out);
    }

    /// [`associate`](Self::associate) at the mean of an uncertain pose: every
    /// innovation covariance also carries the pose covariance,
    /// `S = H_x P H_xᵀ + H_m Σ H_mᵀ + R`, so gates and likelihoods widen with the pose
    /// uncertainty built up since the last update (FastSLAM 2.0's association, Montemerlo
    /// et al. 2003). Known association is not affected.
    pub(crate) fn associate_uncertain(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        pose_covariance: &Matrix3<f64>,
    ) -> ScanAssociation {
        let mut association = ScanAssociation::default();
        self.associate_around(map, pose, Some(pose_covariance), &mut association);
        association
    }

    /// [`associate_into`](Self::associate_into), with a pose covariance as
    /// [`associate_uncertain`](Self::associate_uncertain) when given.
    pub(crate) fn associate_around(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        pose_covariance: Option<&Matrix3<f64>>,
        out: &mut ScanAssociation,
    ) {
        if self.config.mode == AssociationMode::Unknown {
            self.unknown_scan(map, pose, pose_covariance, out);
            return;
        }
        let noise = self.sensor.noise();
        out.decisions.clear();
        out.log_likelihood = 0.0;
        for obs in self.observations {
            // Landmarks claimed by earlier observations of this scan.
            let claimed = Claimed(&out.decisions);
            let (decision, contribution) = match obs.id {
                Some(id) => self.known(map, pose, obs, id, claimed, &noise),
                None => (Decision::Ignore, self.config.log_p_new),
            };
            out.log_likelihood += contribution;
            out.decisions.push(decision);
        }
    }

    fn known(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        obs: &Observation,
        id: u64,
        claimed: Claimed<'_>,
        noise: &Matrix2<f64>,
    ) -> (Decision, f64) {
        let log_p_new = self.config.log_p_new;
        if claimed.contains(id) {
            return (Decision::Ignore, log_p_new);
        }
        let Some((slot, landmark)) = map.locate(id) else {
            return (Decision::New { id: Some(id) }, log_p_new);
        };
        let z = obs.z();
        observation::predict(pose, &landmark.mean)
            .and_then(|p| ekf::innovate(&z, &p, &landmark.covariance, noise).map(|inn| (p, inn)))
            .map_or((Decision::Ignore, log_p_new), |(p, innovation)| {
                let contribution = innovation.log_likelihood;
                let h = p.wrt_landmark;
                (
                    Decision::Update {
                        slot,
                        h,
                        innovation,
                    },
                    contribution,
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fastslam::landmarks::Landmark;
    use nalgebra::Vector2;

    pub(super) fn map_with(points: &[(u64, f64, f64)]) -> LandmarkMap {
        let mut map = LandmarkMap::new(10.0);
        for &(id, x, y) in points {
            map.insert(Landmark {
                id,
                mean: Vector2::new(x, y),
                covariance: Matrix2::identity() * 0.01,
                hits: 3,
                chances: 0,
            });
        }
        map
    }

    pub(super) fn seen(pose: &Pose2, x: f64, y: f64, id: Option<u64>) -> Observation {
        let z = observation::measure(pose, &Vector2::new(x, y));
        Observation {
            range: z[0],
            bearing: z[1],
            id,
        }
    }

    #[test]
    fn known_association_follows_ids_without_gating() {
        let map = map_with(&[(1, 10.0, 0.0), (2, 10.0, 1.0)]);
        let pose = Pose2::default();
        let sensor = Sensor::default();
        let config = AssociationConfig {
            mode: AssociationMode::Known,
            ..AssociationConfig::default()
        };
        let obs = [
            seen(&pose, 10.0, 0.0, Some(2)),
            seen(&pose, 15.0, 4.0, Some(9)),
            seen(&pose, 10.0, 0.0, Some(2)),
        ];
        let a = Scan::new(&obs, &sensor, &config, 0).associate(&map, &pose);
        assert!(matches!(a.decisions[0], Decision::Update { slot, .. } if slot.id() == 2));
        assert_eq!(a.decisions[1], Decision::New { id: Some(9) });
        assert_eq!(
            a.decisions[2],
            Decision::Ignore,
            "id 2 already used in this scan"
        );
        assert!(!config.accepts(&seen(&pose, 1.0, 1.0, None)));
    }

    #[test]
    fn likelihood_prefers_the_true_pose() {
        let map = map_with(&[(1, 10.0, 0.0), (2, 5.0, 8.0), (3, 12.0, -6.0)]);
        let truth = Pose2::new(0.0, 0.0, 0.1);
        let obs: Vec<Observation> = [(10.0, 0.0), (5.0, 8.0), (12.0, -6.0)]
            .iter()
            .map(|&(x, y)| seen(&truth, x, y, None))
            .collect();
        let sensor = Sensor::default();
        let config = AssociationConfig::default();
        let scan = Scan::new(&obs, &sensor, &config, 0);
        let at_truth = scan.log_likelihood(&map, &truth);
        let shifted = scan.log_likelihood(&map, &Pose2::new(0.3, 0.0, 0.1));
        let turned = scan.log_likelihood(&map, &Pose2::new(0.0, 0.0, 0.15));
        assert!(at_truth > shifted && at_truth > turned);
    }
}
