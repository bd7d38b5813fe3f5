//! Configuration of the FastSLAM filter: one section per part, TOML-ready
//! (`#[serde(default, deny_unknown_fields)]`), defaults = Bailey's webmap simulator except
//! where noted, and one `validate` that reports the first bad value.

use super::association::{AssociationConfig, AssociationMode};
use super::evidence::NegativeEvidence;
use super::noise_fit::NoiseConfig;
use super::proposal::Proposal;
use crate::Result;
use crate::check::{positive, require};
use crate::motion::MotionModel;
use crate::observation::Sensor;
use crate::resample::ResamplingConfig;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Everything the FastSLAM filter needs to run.
///
/// # Example
/// ```
/// use fastslam_estimation::fastslam::FastSlamConfig;
/// let config: FastSlamConfig = toml::from_str(r#"
///     particles = 50
///     [motion]
///     model = "unicycle"
///     [resampling]
///     neff_ratio = 0.75
/// "#).unwrap();
/// config.validate().unwrap();
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FastSlamConfig {
    /// Number of particles `N` (≥ 1); Bailey 100, IBA paper 50.
    pub particles: usize,
    /// Seed of every random draw of the filter; a run is reproducible from (data, seed).
    pub seed: u64,
    /// How a particle's new pose is drawn: `motion` (FastSLAM 1.0) or `fastslam2`.
    pub proposal: Proposal,
    /// Motion model and its control noise.
    pub motion: MotionModel,
    /// Default sensor (noise, range, field of view); a scan may bring its own.
    pub sensor: Sensor,
    /// Data association and weighting.
    pub association: AssociationConfig,
    /// Removal of spurious landmarks.
    pub negative_evidence: NegativeEvidence,
    /// When and how to resample.
    pub resampling: ResamplingConfig,
    /// The smallest spread of a particle's motion prior.
    pub prior_floor: PriorFloor,
    /// Which fitted noise the filter runs on (`[noise] adapt`).
    pub noise: NoiseConfig,
}

/// Standard deviations the motion prior of a pose never goes below: added (in quadrature)
/// to the prior's covariance after every update, before the controls' noise accumulates.
///
/// Needed because two noisy controls drive three pose coordinates, so the control noise
/// alone has rank 2 (and is zero while the vehicle stands still), while FastSLAM 2.0 samples
/// from the prior and the optimisers' fitness inverts it. Defaults: 1 mm and 0.1 mrad, a
/// fraction of Bailey's per-scan motion noise (≈ 2 cm along the track, ≈ 3 mrad).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PriorFloor {
    /// Floor of the x and y standard deviations (m), > 0.
    pub position: f64,
    /// Floor of the heading standard deviation (rad), > 0.
    pub heading: f64,
}

impl Default for PriorFloor {
    fn default() -> Self {
        Self {
            position: 1e-3,
            heading: 1e-4,
        }
    }
}

impl PriorFloor {
    /// Checks both floors.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] for a floor that is not finite and > 0.
    pub fn validate(&self) -> Result<()> {
        positive("prior_floor.position", self.position)?;
        positive("prior_floor.heading", self.heading)
    }

    /// The floor as a covariance, `diag(σ_xy², σ_xy², σ_θ²)`.
    pub fn covariance(&self) -> Matrix3<f64> {
        let (p, h) = (self.position * self.position, self.heading * self.heading);
        Matrix3::from_diagonal(&Vector3::new(p, p, h))
    }
}

impl Default for FastSlamConfig {
    fn default() -> Self {
        Self {
            particles: 100,
            seed: 0,
            proposal: Proposal::Motion,
            motion: MotionModel::default(),
            sensor: Sensor::default(),
            association: AssociationConfig::default(),
            negative_evidence: NegativeEvidence::default(),
            resampling: ResamplingConfig::default(),
            prior_floor: PriorFloor::default(),
            noise: NoiseConfig::default(),
        }
    }
}

/// The most particles a filter accepts: a million particles with their maps take
/// gigabytes and seconds per step; a count above this is a typo, refused with its reason
/// instead of ending in a failed allocation.
pub const MAX_PARTICLES: usize = 1_000_000;

impl FastSlamConfig {
    /// Checks every section.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        require(
            (1..=MAX_PARTICLES).contains(&self.particles),
            "particles",
            || format!("must be in 1..={MAX_PARTICLES}, not {}", self.particles),
        )?;
        self.motion.validate()?;
        self.sensor.validate()?;
        self.association.validate()?;
        self.negative_evidence.validate()?;
        self.resampling.validate()?;
        self.prior_floor.validate()
    }

    /// Negative evidence as the filter applies it: only under unknown association, where
    /// a landmark must earn its place (docs/ALGORITHMS.md §1 step 4); with known ids every
    /// landmark is real and none is provisional.
    pub fn negative_evidence_in_effect(&self) -> NegativeEvidence {
        match self.association.mode {
            AssociationMode::Unknown => self.negative_evidence,
            AssociationMode::Known => NegativeEvidence {
                min_hits: 0,
                ..self.negative_evidence
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Error;

    #[test]
    fn default_config_is_valid_and_round_trips_through_toml() {
        let config = FastSlamConfig::default();
        config.validate().unwrap();
        let text = toml::to_string(&config).unwrap();
        let back: FastSlamConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, config);
        let empty: FastSlamConfig = toml::from_str("").unwrap();
        assert_eq!(empty, config);
    }

    #[test]
    fn unknown_fields_are_rejected() {
        assert!(toml::from_str::<FastSlamConfig>("particle = 3").is_err());
        assert!(toml::from_str::<FastSlamConfig>("[association]\ngate = 3.0").is_err());
        assert!(
            toml::from_str::<FastSlamConfig>("[resampling]\nscheme = \"multinomial\"").is_err()
        );
        assert!(toml::from_str::<FastSlamConfig>("proposal = \"fastslam3\"").is_err());
        let two: FastSlamConfig = toml::from_str("proposal = \"fastslam2\"").unwrap();
        assert_eq!(two.proposal, Proposal::FastSlam2);
    }

    #[test]
    fn invalid_values_are_rejected_by_name() {
        let cases: [(&str, FastSlamConfig); 7] = [
            (
                "particles",
                FastSlamConfig {
                    particles: 0,
                    ..FastSlamConfig::default()
                },
            ),
            (
                "particles",
                FastSlamConfig {
                    particles: MAX_PARTICLES + 1,
                    ..FastSlamConfig::default()
                },
            ),
            (
                "sensor.sigma_range",
                toml::from_str("[sensor]\nsigma_range = -0.1").unwrap(),
            ),
            (
                "association.gate_new",
                toml::from_str("[association]\ngate_new = 1.0").unwrap(),
            ),
            (
                "resampling.neff_ratio",
                toml::from_str("[resampling]\nneff_ratio = nan").unwrap(),
            ),
            (
                "prior_floor.heading",
                toml::from_str("[prior_floor]\nheading = 0.0").unwrap(),
            ),
            (
                "motion.wheelbase",
                toml::from_str("[motion]\nmodel = \"bicycle\"\nwheelbase = 0.0").unwrap(),
            ),
        ];
        for (expected, config) in cases {
            match config.validate() {
                Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, expected),
                other => panic!("{expected}: {other:?}"),
            }
        }
    }
}
