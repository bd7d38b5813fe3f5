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

use super::ekf::{self, Innovation};
use super::landmarks::{LandmarkMap, Slot};
use crate::Result;
use crate::check::{positive, require};
use crate::observation::{self, Observation, Sensor};
use crate::pose::Pose2;
use crate::rng::SimRng;
use nalgebra::{Matrix2, Matrix3};
use rand::RngExt;
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
    /// How a scan's observations share the landmarks (unknown association): `greedy`
    /// (default), `joint` or `sampled`.
    pub assignment: Assignment,
    /// Unknown association: a landmark is assignable only when its likelihood is at
    /// least a new landmark's (`log_p_new`), beside the gate. Off by default.
    pub likelihood_ratio: bool,
    /// FastSLAM 2.0: associate at the motion prior's mean with its covariance in every
    /// innovation covariance, so gates widen with the drift since the last update
    /// (`Scan::associate_uncertain`). Off by default.
    pub pose_uncertainty: bool,
    /// Unknown association: after a scan's updates, a landmark it touched is merged
    /// with another of the same particle whose position it matches, `(μ₁ − μ₂)ᵀ (Σ₁ +
    /// Σ₂)⁻¹ (μ₁ − μ₂) < merge_gate` (χ², 2 dof), into their fused Gaussian
    /// (`merge::merge_touched`). 0 (default): never.
    pub merge_gate: f64,
    /// Unknown association: the published map — not the filter — shows, of every group of
    /// the best particle's landmarks that match within this χ² gate (2 dof), only the one
    /// seen most often (`merge::keep_best_supported`): duplicates a particle keeps apart
    /// while it is not sure are drawn once, and its hypotheses stay as they are. 0 (default): the map is
    /// published as the particle holds it.
    pub map_merge_gate: f64,
}

/// How the observations of one scan share the landmarks under unknown association
/// (each landmark takes at most one observation per scan either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Assignment {
    /// In scan order: each observation takes the most likely landmark the earlier ones
    /// left, if it passes the gate.
    #[default]
    Greedy,
    /// Each observation takes its most likely assignable landmark; where two want the
    /// same one, the scan's assignment with the largest total log-likelihood (Hungarian
    /// algorithm).
    Joint,
    /// Each particle draws its association (Montemerlo's data-association sampling): in
    /// scan order, each observation takes a landmark the earlier ones left with
    /// probability proportional to its likelihood, or starts a new one with probability
    /// proportional to `exp(log_p_new)`; the weight takes the sum of them all. Not with
    /// FastSLAM 2.0, whose weight is its proposal's marginal (there, as `greedy`).
    Sampled,
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
            assignment: Assignment::Greedy,
            likelihood_ratio: false,
            pose_uncertainty: false,
            merge_gate: 0.0,
            map_merge_gate: 0.0,
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
        for (name, gate) in [
            ("association.merge_gate", self.merge_gate),
            ("association.map_merge_gate", self.map_merge_gate),
        ] {
            require(gate.is_finite() && gate >= 0.0, name, || {
                format!("must be a finite number >= 0 (0: off), got {gate}")
            })?;
        }
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

    /// Unknown association of the whole scan (see the module docs): every pair of an
    /// observation and a landmark in its search window, the most likely landmark per
    /// observation, and a joint assignment where two observations want one landmark.
    fn unknown_scan(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        pose_covariance: Option<&Matrix3<f64>>,
        out: &mut ScanAssociation,
    ) {
        let noise = self.sensor.noise();
        let scratch = &mut out.scratch;
        scratch.pairs.clear();
        scratch.starts.clear();
        for obs in self.observations {
            scratch.starts.push(scratch.pairs.len());
            self.pairs_of(map, pose, pose_covariance, obs, &noise, &mut scratch.pairs);
        }
        scratch.starts.push(scratch.pairs.len());
        if self.config.assignment == Assignment::Sampled
            && let Some(rng) = out.sampler.as_mut()
        {
            self.sample(
                &mut out.scratch,
                rng,
                &mut out.decisions,
                &mut out.log_likelihood,
            );
            return;
        }
        self.choose(scratch);
        let log_p_new = self.config.log_p_new;
        out.decisions.clear();
        out.log_likelihood = 0.0;
        for index in 0..self.observations.len() {
            let (decision, contribution) = match out.scratch.chosen[index] {
                Some(at) => {
                    let pair = &out.scratch.pairs[at];
                    (pair.decision(), pair.innovation.log_likelihood)
                }
                None => {
                    // The landmarks the scan's other observations did not take.
                    let joint = self.config.assignment == Assignment::Joint;
                    let free = out
                        .scratch
                        .pairs_of_observation(index)
                        .iter()
                        .filter(|pair| {
                            if joint {
                                !out.scratch.taken_by_another(pair.slot, index)
                            } else {
                                !out.scratch.taken_before(pair.slot, index)
                            }
                        });
                    let (min_d2, best) =
                        free.fold((f64::INFINITY, f64::NEG_INFINITY), |(d, l), pair| {
                            (
                                d.min(pair.innovation.d2),
                                l.max(pair.innovation.log_likelihood),
                            )
                        });
                    if min_d2 > self.config.gate_new {
                        (Decision::New { id: None }, log_p_new)
                    } else {
                        (Decision::Ignore, best.max(log_p_new))
                    }
                }
            };
            out.log_likelihood += contribution;
            out.decisions.push(decision);
        }
    }

    /// Every landmark of `map` in the search window of `obs`, with its
    /// innovation (the pose covariance, when given, added to `S`), into `pairs`.
    fn pairs_of(
        &self,
        map: &LandmarkMap,
        pose: &Pose2,
        pose_covariance: Option<&Matrix3<f64>>,
        obs: &Observation,
        noise: &Matrix2<f64>,
        pairs: &mut Vec<Pair>,
    ) {
        let z = obs.z();
        let (point, _) = observation::inverse(pose, &z);
        let sigma_world = (noise[(0, 0)] + z[0] * z[0] * noise[(1, 1)]).sqrt();
        let radius = self
            .config
            .search_radius
            .max(2.0 * self.config.gate_new.sqrt() * sigma_world)
            + pose_covariance.map_or(0.0, |p| {
                2.0 * self.config.gate_new.sqrt()
                    * (p[(0, 0)] + p[(1, 1)] + z[0] * z[0] * p[(2, 2)]).sqrt()
            });
        for (slot, landmark) in map.within(point, radius) {
            let Some(p) = observation::predict(pose, &landmark.mean) else {
                continue;
            };
            let h = p.wrt_landmark;
            let mut s = h * landmark.covariance * h.transpose() + noise;
            if let Some(pose_covariance) = pose_covariance {
                s += p.wrt_pose * pose_covariance * p.wrt_pose.transpose();
            }
            if let Some(innovation) = ekf::innovate_with(&z, &p, &s) {
                pairs.push(Pair {
                    slot,
                    h,
                    innovation,
                });
            }
        }
    }

    /// True when `pair` may be assigned: inside the reject gate and more likely than a
    /// new landmark.
    fn assignable(&self, pair: &Pair) -> bool {
        pair.innovation.d2 < self.config.gate_reject
            && (!self.config.likelihood_ratio
                || pair.innovation.log_likelihood >= self.config.log_p_new)
    }

    /// [`Assignment::Sampled`]: in scan order, each observation draws a landmark the
    /// earlier ones left (probability ∝ its likelihood) or a new landmark (∝
    /// `exp(log_p_new)`) with `rng`; its contribution is the log of the sum of them all
    /// (the proposal's normaliser, so the weight stays the importance weight).
    fn sample(
        &self,
        scratch: &mut Scratch,
        rng: &mut SimRng,
        decisions: &mut Vec<Decision>,
        log_likelihood: &mut f64,
    ) {
        let log_p_new = self.config.log_p_new;
        decisions.clear();
        *log_likelihood = 0.0;
        scratch.chosen.clear();
        for index in 0..scratch.starts.len() - 1 {
            let free = || {
                (scratch.starts[index]..scratch.starts[index + 1])
                    .filter(|&at| !scratch.taken_before(scratch.pairs[at].slot, index))
            };
            let most = free()
                .map(|at| scratch.pairs[at].innovation.log_likelihood)
                .fold(log_p_new, f64::max);
            // Likelihoods relative to the largest (no overflow), a new landmark's first.
            let relative = |at: usize| (scratch.pairs[at].innovation.log_likelihood - most).exp();
            let new = (log_p_new - most).exp();
            let total = new + free().map(relative).sum::<f64>();
            let mut u = rng.random::<f64>() * total - new;
            let chosen = if u < 0.0 {
                None
            } else {
                free().find(|&at| {
                    u -= relative(at);
                    u < 0.0
                })
            };
            scratch.chosen.push(chosen);
            decisions.push(chosen.map_or(Decision::New { id: None }, |at| {
                scratch.pairs[at].decision()
            }));
            *log_likelihood += most + total.ln();
        }
    }

    /// Fills `scratch.chosen` as [`Assignment`] says: greedily in scan order, or jointly
    /// where two observations want one landmark.
    fn choose(&self, scratch: &mut Scratch) {
        let n = scratch.starts.len() - 1;
        scratch.chosen.clear();
        let most_likely = |scratch: &Scratch, index: usize, only_assignable: bool| {
            (scratch.starts[index]..scratch.starts[index + 1])
                .filter(|&at| !only_assignable || self.assignable(&scratch.pairs[at]))
                .filter(|&at| {
                    self.config.assignment == Assignment::Joint
                        || !scratch.taken_before(scratch.pairs[at].slot, index)
                })
                .max_by(|&a, &b| {
                    let (a, b) = (&scratch.pairs[a].innovation, &scratch.pairs[b].innovation);
                    a.log_likelihood.total_cmp(&b.log_likelihood)
                })
        };
        for index in 0..n {
            let best = match self.config.assignment {
                // The most likely landmark the earlier observations left, if assignable.
                Assignment::Greedy | Assignment::Sampled => most_likely(scratch, index, false)
                    .filter(|&at| self.assignable(&scratch.pairs[at])),
                Assignment::Joint => most_likely(scratch, index, true),
            };
            scratch.chosen.push(best);
        }
        if self.config.assignment != Assignment::Joint {
            return;
        }
        let conflict = scratch.chosen.iter().enumerate().any(|(i, a)| {
            let Some(a) = a else { return false };
            scratch.chosen[i + 1..]
                .iter()
                .flatten()
                .any(|b| scratch.pairs[*a].slot == scratch.pairs[*b].slot)
        });
        if conflict {
            self.assign_jointly(scratch);
        }
    }

    /// The Hungarian assignment of [`choose`](Self::choose), over the observations with an
    /// assignable landmark. Log-likelihoods are compared in micro-units (integers, as the
    /// `pathfinding` crate's algorithm needs).
    fn assign_jointly(&self, scratch: &mut Scratch) {
        const FORBIDDEN: i64 = -(1 << 50);
        let units = |log_likelihood: f64| (log_likelihood * 1e6).round() as i64;
        let rows: Vec<usize> = (0..scratch.chosen.len())
            .filter(|&i| scratch.chosen[i].is_some())
            .collect();
        let mut slots: Vec<Slot> = rows
            .iter()
            .flat_map(|&i| scratch.pairs_of_observation(i))
            .filter(|pair| self.assignable(pair))
            .map(|pair| pair.slot)
            .collect();
        slots.sort_unstable();
        slots.dedup();
        let columns = slots.len() + rows.len();
        let mut weights = pathfinding::matrix::Matrix::new(rows.len(), columns, FORBIDDEN);
        for (row, &i) in rows.iter().enumerate() {
            weights[(row, slots.len() + row)] = units(self.config.log_p_new);
            for at in scratch.starts[i]..scratch.starts[i + 1] {
                let pair = &scratch.pairs[at];
                if self.assignable(pair) {
                    let column = slots.binary_search(&pair.slot).unwrap_or(0);
                    weights[(row, column)] = units(pair.innovation.log_likelihood);
                }
            }
        }
        let (_, assignment) = pathfinding::kuhn_munkres::kuhn_munkres(&weights);
        for (row, &i) in rows.iter().enumerate() {
            let column = assignment[row];
            scratch.chosen[i] = slots.get(column).and_then(|slot| {
                (scratch.starts[i]..scratch.starts[i + 1])
                    .find(|&at| scratch.pairs[at].slot == *slot)
            });
        }
    }
}

/// One observation paired with one landmark of its search window.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pair {
    slot: Slot,
    h: Matrix2<f64>,
    innovation: Innovation,
}

impl Pair {
    fn decision(&self) -> Decision {
        Decision::Update {
            slot: self.slot,
            h: self.h,
            innovation: self.innovation,
        }
    }
}

/// Working buffers of unknown association, kept between scans so a filter step allocates
/// nothing here once they have grown to the scan's size.
#[derive(Debug, Clone, Default)]
pub(crate) struct Scratch {
    /// Every pair, grouped by observation in scan order.
    pairs: Vec<Pair>,
    /// `pairs[starts[i]..starts[i + 1]]` are observation i's.
    starts: Vec<usize>,
    /// The pair each observation is assigned (an index into `pairs`), if any.
    chosen: Vec<Option<usize>>,
}

impl Scratch {
    fn pairs_of_observation(&self, index: usize) -> &[Pair] {
        &self.pairs[self.starts[index]..self.starts[index + 1]]
    }

    /// True when `slot` is assigned to an observation before `index`.
    fn taken_before(&self, slot: Slot, index: usize) -> bool {
        self.chosen[..index.min(self.chosen.len())]
            .iter()
            .any(|c| c.is_some_and(|at| self.pairs[at].slot == slot))
    }

    /// True when `slot` is assigned to an observation other than `index`.
    fn taken_by_another(&self, slot: Slot, index: usize) -> bool {
        self.chosen
            .iter()
            .enumerate()
            .any(|(i, c)| i != index && c.is_some_and(|at| self.pairs[at].slot == slot))
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
    fn sampled_association_draws_in_proportion_to_the_likelihoods_and_weighs_by_their_sum() {
        let map = map_with(&[(1, 10.0, 0.0)]);
        let pose = Pose2::default();
        let sensor = Sensor::default();
        let config = AssociationConfig {
            assignment: Assignment::Sampled,
            // A new landmark about as likely as the re-sighting below.
            log_p_new: 1.5,
            ..AssociationConfig::default()
        };
        let obs = [seen(&pose, 10.3, 0.0, None)];
        let scan = Scan::new(&obs, &sensor, &config, 0);
        let landmark = map.get(1).unwrap();
        let p = observation::predict(&pose, &landmark.mean).unwrap();
        let resighting = ekf::innovate(&obs[0].z(), &p, &landmark.covariance, &sensor.noise())
            .unwrap()
            .log_likelihood;
        let (a, b) = (resighting.exp(), config.log_p_new.exp());
        let expected = a / (a + b);
        assert!((0.2..0.8).contains(&expected), "{expected}");
        let draws = 4000;
        let mut updates = 0;
        for seed in 0..draws {
            let mut out = ScanAssociation {
                sampler: Some(crate::rng::seeded(seed)),
                ..ScanAssociation::default()
            };
            scan.associate_into(&map, &pose, &mut out);
            updates += u32::from(matches!(out.decisions[0], Decision::Update { .. }));
            assert!((out.log_likelihood - (a + b).ln()).abs() < 1e-12);
        }
        let frequency = f64::from(updates) / draws as f64;
        let sigma = (expected * (1.0 - expected) / draws as f64).sqrt();
        assert!(
            (frequency - expected).abs() < 4.0 * sigma,
            "drawn {frequency}, expected {expected}"
        );
        // Without a stream it associates as greedy does.
        let greedy = AssociationConfig {
            assignment: Assignment::Greedy,
            ..config.clone()
        };
        assert_eq!(
            scan.associate(&map, &pose).decisions,
            Scan::new(&obs, &sensor, &greedy, 0)
                .associate(&map, &pose)
                .decisions
        );
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
    fn a_scan_is_assigned_jointly_where_two_observations_want_one_landmark() {
        // Landmarks 0.5 m apart across the line of sight; the first observation lies
        // between them, a little nearer 1, the second right on 1 and out of 2's gate.
        let map = map_with(&[(1, 10.0, 0.0), (2, 10.0, 0.5)]);
        let pose = Pose2::default();
        let sensor = Sensor::default();
        let config = AssociationConfig {
            assignment: Assignment::Joint,
            ..AssociationConfig::default()
        };
        let obs = [
            seen(&pose, 10.0, 0.23, None),
            seen(&pose, 10.0, -0.02, None),
        ];
        let scan = Scan::new(&obs, &sensor, &config, 0);
        let a = scan.associate(&map, &pose);
        let id = |d: &Decision| match d {
            Decision::Update { slot, .. } => Some(slot.id()),
            _ => None,
        };
        assert_eq!(
            (id(&a.decisions[0]), id(&a.decisions[1])),
            (Some(2), Some(1)),
            "jointly, each observation gets a landmark"
        );
        // Alone, the first takes landmark 1.
        let greedy = AssociationConfig::default();
        let in_order = Scan::new(&obs, &sensor, &greedy, 0).associate(&map, &pose);
        assert_eq!(
            (id(&in_order.decisions[0]), id(&in_order.decisions[1])),
            (Some(1), None),
            "greedy in scan order"
        );
        let alone = Scan::new(&obs[..1], &sensor, &config, 0).associate(&map, &pose);
        assert_eq!(id(&alone.decisions[0]), Some(1));
    }

    #[test]
    fn the_pose_covariance_widens_the_gate() {
        let map = map_with(&[(1, 10.0, 0.0)]);
        let pose = Pose2::default();
        let sensor = Sensor::default();
        let config = AssociationConfig::default();
        // Seen 0.15 rad off: far outside the gate of a certain pose (σ_b = 1°).
        let obs = [seen(&Pose2::new(0.0, 0.0, -0.15), 10.0, 0.0, None)];
        let scan = Scan::new(&obs, &sensor, &config, 0);
        assert_eq!(
            scan.associate(&map, &pose).decisions[0],
            Decision::New { id: None }
        );
        let drifted = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.01, 0.01, 0.1f64.powi(2)));
        let a = scan.associate_uncertain(&map, &pose, &drifted);
        assert!(matches!(a.decisions[0], Decision::Update { slot, .. } if slot.id() == 1));
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
