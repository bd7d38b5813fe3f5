//! Data association and weighting of one scan against one particle's map
//! (docs/ALGORITHMS.md §1 step 3), read-only: it decides what each observation does and what it
//! contributes to the particle's log-weight; [`Particle`](super::Particle) applies the
//! decisions afterwards.
//!
//! Decisions the spec leaves open, taken here:
//! - **One landmark per scan.** Observations are associated greedily in scan order, and a
//!   landmark already claimed by an earlier observation of the same scan (matched, or
//!   created under known association) is no candidate for later ones. Because of this,
//!   every landmark is touched at most once per scan, so associating the whole scan before
//!   updating any landmark gives exactly the decisions of updating as one goes.
//! - **Ignored observations** (ML candidate with `gate_reject ≤ d²`, but some candidate with
//!   `d² ≤ gate_new`) contribute `max(log N(ν; 0, S) of the ML candidate, log_p_new)`: the
//!   observation is that landmark or a new one, and we do not commit to either. A fixed
//!   0 would depend on the units of `S`.
//! - **Known association** updates the landmark with the observation's id without gating
//!   (the id is trusted); an id not yet in the map creates that landmark.
//! - **Search window** of unknown association: landmarks within
//!   `max(search_radius, 2 √gate_new σ_w)` metres of the observed point, where
//!   `σ_w = √(σ_r² + (r σ_b)²)` is the observation's spread in the world. A landmark
//!   farther away is taken to have `d² > gate_new`, which holds unless its own covariance
//!   is much larger than the observation's.

use super::ekf::{self, Innovation};
use super::landmarks::{LandmarkMap, Slot};
use crate::Result;
use crate::check::{positive, require};
use crate::observation::{self, Observation, Sensor};
use crate::pose::Pose2;
use nalgebra::{Matrix2, Matrix3};
use serde::{Deserialize, Serialize};

/// How observations find their landmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AssociationMode {
    /// Every observation carries the landmark's id (simulation, barcodes); observations
    /// without an id are rejected.
    Known,
    /// Maximum likelihood with gates; ids on observations are ignored.
    #[default]
    Unknown,
}

/// Association settings (docs/ALGORITHMS.md §1 step 3). Defaults: Bailey's webmap simulator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AssociationConfig {
    /// Known ids or maximum likelihood; Bailey's simulator default is unknown.
    pub mode: AssociationMode,
    /// Normalised innovation squared below which the ML landmark is updated
    /// (dimensionless, χ² with 2 dof); Bailey 4.0.
    pub gate_reject: f64,
    /// Normalised innovation squared above which, for every candidate, the observation
    /// starts a new landmark (dimensionless); Bailey 25.0. Must be ≥ `gate_reject`.
    pub gate_new: f64,
    /// Log-likelihood contributed by an observation that starts a new landmark (log of a
    /// density in m⁻¹ rad⁻¹, like `log N(ν; 0, S)`). Default `−ln(30 m · π rad) = −4.55`:
    /// a new landmark's observation is uniform over Bailey's sensor footprint.
    pub log_p_new: f64,
    /// Smallest radius (m) around an observed point searched for candidate landmarks.
    pub search_radius: f64,
    /// Side of the spatial index's square cells (m); of the order of `search_radius`.
    pub cell_size: f64,
}

impl Default for AssociationConfig {
    fn default() -> Self {
        Self {
            mode: AssociationMode::Unknown,
            gate_reject: 4.0,
            gate_new: 25.0,
            log_p_new: -(30.0 * std::f64::consts::PI).ln(),
            search_radius: 5.0,
            cell_size: 10.0,
        }
    }
}

impl AssociationConfig {
    /// Checks gates, radii and the new-landmark likelihood.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] for a non-positive or non-finite gate, radius or
    /// cell size, `gate_new < gate_reject`, or a non-finite `log_p_new`.
    pub fn validate(&self) -> Result<()> {
        positive("association.gate_reject", self.gate_reject)?;
        positive("association.gate_new", self.gate_new)?;
        require(
            self.gate_new >= self.gate_reject,
            "association.gate_new",
            || {
                format!(
                    "must be >= gate_reject ({}), got {}",
                    self.gate_reject, self.gate_new
                )
            },
        )?;
        require(self.log_p_new.is_finite(), "association.log_p_new", || {
            format!("must be finite, got {}", self.log_p_new)
        })?;
        positive("association.search_radius", self.search_radius)?;
        positive("association.cell_size", self.cell_size)
    }

    /// True when `observation` can be used under this mode (known association needs an id).
    pub(crate) fn accepts(&self, observation: &Observation) -> bool {
        self.mode == AssociationMode::Unknown || observation.id.is_some()
    }
}

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
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct ScanAssociation {
    pub decisions: Vec<Decision>,
    pub log_likelihood: f64,
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
        let noise = self.sensor.noise();
        out.decisions.clear();
        out.log_likelihood = 0.0;
        for obs in self.observations {
            // Landmarks claimed by earlier observations of this scan.
            let claimed = Claimed(&out.decisions);
            let (decision, contribution) = match (self.config.mode, obs.id) {
                (AssociationMode::Known, Some(id)) => {
                    self.known(map, pose, obs, id, claimed, &noise)
                }
                _ => self.unknown(map, pose, obs, claimed, &noise),
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

    fn unknown(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        obs: &Observation,
        claimed: Claimed<'_>,
        noise: &Matrix2<f64>,
    ) -> (Decision, f64) {
        let z = obs.z();
        let (point, _) = observation::inverse(pose, &z);
        let sigma_world = (noise[(0, 0)] + z[0] * z[0] * noise[(1, 1)]).sqrt();
        let radius = self
            .config
            .search_radius
            .max(2.0 * self.config.gate_new.sqrt() * sigma_world);
        let mut best: Option<Decision> = None;
        let mut best_log_likelihood = f64::NEG_INFINITY;
        let mut min_d2 = f64::INFINITY;
        for (slot, landmark) in map.within(point, radius) {
            if claimed.contains(slot.id()) {
                continue;
            }
            let Some(p) = observation::predict(pose, &landmark.mean) else {
                continue;
            };
            let Some(innovation) = ekf::innovate(&z, &p, &landmark.covariance, noise) else {
                continue;
            };
            min_d2 = min_d2.min(innovation.d2);
            if innovation.log_likelihood > best_log_likelihood {
                best_log_likelihood = innovation.log_likelihood;
                best = Some(Decision::Update {
                    slot,
                    h: p.wrt_landmark,
                    innovation,
                });
            }
        }
        let log_p_new = self.config.log_p_new;
        match best {
            Some(update @ Decision::Update { innovation, .. })
                if innovation.d2 < self.config.gate_reject =>
            {
                (update, best_log_likelihood)
            }
            _ if min_d2 > self.config.gate_new => (Decision::New { id: None }, log_p_new),
            _ => (Decision::Ignore, best_log_likelihood.max(log_p_new)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fastslam::landmarks::Landmark;
    use nalgebra::Vector2;

    fn map_with(points: &[(u64, f64, f64)]) -> LandmarkMap {
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

    fn seen(pose: &Pose2, x: f64, y: f64, id: Option<u64>) -> Observation {
        let z = observation::measure(pose, &Vector2::new(x, y));
        Observation {
            range: z[0],
            bearing: z[1],
            id,
        }
    }

    #[test]
    fn unknown_association_picks_the_most_likely_landmark_inside_the_gate() {
        let map = map_with(&[(1, 10.0, 0.0), (2, 10.0, 1.0), (3, 20.0, 0.0)]);
        let pose = Pose2::default();
        let sensor = Sensor::default();
        let config = AssociationConfig::default();
        let obs = [
            seen(&pose, 10.05, 0.9, None),
            seen(&pose, 10.0, 5.0, None),
            seen(&pose, 20.0, 1.15, None),
        ];
        let a = Scan::new(&obs, &sensor, &config, 0).associate(&map, &pose);
        assert!(matches!(a.decisions[0], Decision::Update { slot, .. } if slot.id() == 2));
        assert_eq!(
            a.decisions[1],
            Decision::New { id: None },
            "far from everything"
        );
        assert_eq!(
            a.decisions[2],
            Decision::Ignore,
            "between the gates of landmark 3"
        );
        let log_likelihood_of = |o: &Observation, id: u64| {
            let landmark = map.get(id).unwrap();
            let p = observation::predict(&pose, &landmark.mean).unwrap();
            ekf::innovate(&o.z(), &p, &landmark.covariance, &sensor.noise()).unwrap()
        };
        let ignored = log_likelihood_of(&obs[2], 3);
        assert!(config.gate_reject < ignored.d2 && ignored.d2 < config.gate_new);
        let expected = log_likelihood_of(&obs[0], 2).log_likelihood
            + config.log_p_new
            + ignored.log_likelihood.max(config.log_p_new);
        assert!((a.log_likelihood - expected).abs() < 1e-12);
    }

    #[test]
    fn two_observations_of_one_scan_never_claim_the_same_landmark() {
        let map = map_with(&[(1, 10.0, 0.0)]);
        let pose = Pose2::default();
        let sensor = Sensor::default();
        let config = AssociationConfig::default();
        let obs = [seen(&pose, 10.0, 0.0, None), seen(&pose, 10.0, 0.05, None)];
        let a = Scan::new(&obs, &sensor, &config, 0).associate(&map, &pose);
        assert!(matches!(a.decisions[0], Decision::Update { slot, .. } if slot.id() == 1));
        assert_eq!(a.decisions[1], Decision::New { id: None });
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

    #[test]
    fn config_rejects_bad_gates() {
        assert!(AssociationConfig::default().validate().is_ok());
        let bad = AssociationConfig {
            gate_new: 3.0,
            ..AssociationConfig::default()
        };
        assert!(bad.validate().is_err());
        let bad = AssociationConfig {
            log_p_new: f64::NAN,
            ..AssociationConfig::default()
        };
        assert!(bad.validate().is_err());
    }
}
