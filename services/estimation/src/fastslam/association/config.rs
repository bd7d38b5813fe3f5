//! The association settings: how observations find their landmarks, the gates and the
//! new-landmark likelihood, and how a scan's observations share the landmarks.

use crate::Result;
use crate::check::{positive, require};
use crate::observation::Observation;
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

#[cfg(test)]
mod tests {
    use super::*;

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
