//! The filter's state as plain data, to write a checkpoint and to continue from one.
//!
//! A [`FilterState`] holds what the next step depends on: the step counter (every random
//! draw comes from a stream labelled by the step, so seed + step *is* the random state),
//! each particle's pose, log-weight and motion prior, and the landmark maps. Maps that
//! particles share after resampling are stored once and shared again on restore, so a
//! state costs O(distinct maps · M), not O(N · M). Pose trails (grid keyframes) are not
//! part of it: a restored filter starts new trails.

use super::landmarks::{Landmark, LandmarkMap};
use super::noise_fit::NoiseFit;
use super::particle::{MotionPrior, Particle};
use super::trail::Trail;
use super::{FastSlam, FastSlamConfig};
use crate::pose::Pose2;
use crate::weights::Weights;
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix3, Vector2};
use serde::{Deserialize, Serialize};

/// Everything a [`FastSlam`] needs to continue exactly where it was (but its config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FilterState {
    /// Steps taken (predictions and updates): labels the random streams of the next one.
    pub step: u64,
    /// The particle that weighed most at the last step ([`FastSlam::best`]).
    pub best: u32,
    /// The distinct landmark maps.
    pub maps: Vec<MapState>,
    /// The particles, in filter order.
    pub particles: Vec<ParticleState>,
    /// The noise check's motion prior: mean, and covariance row-major.
    pub check_prior: (Pose2, [f64; 9]),
    /// The noise fit, with the noise scales the filter runs on.
    pub noise: NoiseFit,
}

/// One landmark map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapState {
    /// The landmarks, in spatial-index order.
    pub landmarks: Vec<LandmarkState>,
}

/// One landmark: [`Landmark`] as plain numbers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LandmarkState {
    /// Stable id within its map.
    pub id: u64,
    /// Mean (m), world frame.
    pub mean: [f64; 2],
    /// Covariance, row-major (m²).
    pub covariance: [f64; 4],
    /// Scans that observed it.
    pub hits: u32,
    /// Scans in which it could have been seen while tentative.
    pub chances: u32,
}

/// One particle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParticleState {
    /// Pose hypothesis (m, m, rad).
    pub pose: Pose2,
    /// Normalised log-weight.
    pub log_weight: f64,
    /// Mean of the motion prior of the current step.
    pub prior_mean: Pose2,
    /// Covariance of the motion prior, row-major.
    pub prior_covariance: [f64; 9],
    /// Index of its map in [`FilterState::maps`].
    pub map: u32,
}

impl From<&Landmark> for LandmarkState {
    fn from(l: &Landmark) -> Self {
        let c = &l.covariance;
        Self {
            id: l.id,
            mean: [l.mean.x, l.mean.y],
            covariance: [c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]],
            hits: l.hits,
            chances: l.chances,
        }
    }
}

impl From<&LandmarkState> for Landmark {
    fn from(l: &LandmarkState) -> Self {
        Self {
            id: l.id,
            mean: Vector2::from(l.mean),
            covariance: Matrix2::from_row_slice(&l.covariance),
            hits: l.hits,
            chances: l.chances,
        }
    }
}

fn invalid(reason: String) -> Error {
    Error::InvalidInput {
        what: "filter state",
        reason,
    }
}

impl FastSlam {
    /// The filter's state (see the module documentation for what it holds).
    ///
    /// # Performance
    /// O(N² pointer comparisons + distinct maps · M) to find and copy the distinct maps.
    pub fn state(&self) -> FilterState {
        let mut maps: Vec<&LandmarkMap> = Vec::new();
        let mut stored = Vec::new();
        let particles = self
            .particles
            .iter()
            .map(|p| {
                let index = maps
                    .iter()
                    .position(|m| m.shares_storage_with(&p.map))
                    .unwrap_or_else(|| {
                        maps.push(&p.map);
                        stored.push(MapState {
                            landmarks: p.map.iter().map(LandmarkState::from).collect(),
                        });
                        maps.len() - 1
                    });
                ParticleState {
                    pose: p.pose,
                    log_weight: p.log_weight,
                    prior_mean: p.prior.mean,
                    prior_covariance: std::array::from_fn(|k| p.prior.covariance[(k / 3, k % 3)]),
                    map: index as u32,
                }
            })
            .collect();
        FilterState {
            check_prior: (
                self.check_prior.mean,
                std::array::from_fn(|k| self.check_prior.covariance[(k / 3, k % 3)]),
            ),
            step: self.step,
            best: self.best as u32,
            maps: stored,
            particles,
            noise: self.noise.clone(),
        }
    }

    /// A filter with `config` that continues from `state`, on the noise the state's fit
    /// ran on (`config`'s noise is the profile).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad config; [`Error::InvalidInput`] when the
    /// state does not fit it (another particle count, a map index out of range, a
    /// non-finite pose or landmark); [`Error::DegenerateWeights`] for unusable weights.
    pub fn from_state(config: FastSlamConfig, state: &FilterState) -> Result<Self> {
        config.validate()?;
        if state.best as usize >= state.particles.len() {
            return Err(invalid(format!(
                "best particle {} of {}",
                state.best,
                state.particles.len()
            )));
        }
        if state.particles.len() != config.particles {
            return Err(invalid(format!(
                "{} particles, the config asks for {}",
                state.particles.len(),
                config.particles
            )));
        }
        let maps: Vec<LandmarkMap> = state
            .maps
            .iter()
            .map(|m| {
                let mut map = LandmarkMap::new(config.association.cell_size);
                for l in &m.landmarks {
                    if !l.mean.iter().chain(&l.covariance).all(|v| v.is_finite()) {
                        return Err(invalid(format!("landmark {} is not finite", l.id)));
                    }
                    map.insert(Landmark::from(l));
                }
                Ok(map.track_tentative(config.negative_evidence_in_effect().min_hits))
            })
            .collect::<Result<_>>()?;
        let particles: Vec<Particle> = state
            .particles
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let map = maps
                    .get(p.map as usize)
                    .ok_or_else(|| invalid(format!("particle {i}: no map {}", p.map)))?;
                if !(p.pose.is_finite() && p.prior_mean.is_finite()) {
                    return Err(invalid(format!("particle {i}: pose not finite")));
                }
                Ok(Particle {
                    pose: p.pose,
                    log_weight: p.log_weight,
                    map: map.clone(),
                    trail: Trail::default(),
                    prior: MotionPrior {
                        mean: p.prior_mean,
                        covariance: Matrix3::from_row_slice(&p.prior_covariance),
                    },
                })
            })
            .collect::<Result<_>>()?;
        let log_weights: Vec<f64> = particles.iter().map(|p| p.log_weight).collect();
        if !state.check_prior.0.is_finite() {
            return Err(invalid("the noise check's prior is not finite".into()));
        }
        let profile = (config.motion.clone(), config.sensor.clone());
        let mut config = config;
        (config.motion, config.sensor) = state.noise.apply(&profile.0, &profile.1);
        Ok(Self {
            noise: state.noise.clone(),
            profile,
            check_prior: MotionPrior {
                mean: state.check_prior.0,
                covariance: Matrix3::from_row_slice(&state.check_prior.1),
            },
            weights: Weights::from_log(&log_weights)?,
            particles,
            deferred: config.proposal == super::Proposal::FastSlam2,
            config,
            step: state.step,
            // The service drops the prior again where it is not needed (see
            // `FastSlam::without_motion_prior`); restored, it is the saved one.
            motion_prior: true,
            map_fixed: false,
            best: state.best as usize,
            scratch: super::Scratch::default(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Control;
    use crate::observation::Observation;

    fn config() -> FastSlamConfig {
        FastSlamConfig {
            particles: 30,
            ..FastSlamConfig::default()
        }
    }

    /// A few predictions and updates around two landmarks.
    fn drive(slam: &mut FastSlam, from: usize, to: usize) {
        let control = Control {
            v: 2.0,
            omega: 0.1,
            steering: 0.0,
            ..Control::ZERO
        };
        for k in from..to {
            slam.predict(&control, 0.1).unwrap();
            let a = k as f64 * 0.01;
            slam.update(&[
                Observation {
                    range: 8.0 - a,
                    bearing: 0.3 - a,
                    id: None,
                },
                Observation {
                    range: 6.0,
                    bearing: -0.5 - a,
                    id: None,
                },
            ])
            .unwrap();
        }
    }

    #[test]
    fn a_restored_filter_continues_like_the_original() {
        let mut original = FastSlam::new(config(), Pose2::default()).unwrap();
        drive(&mut original, 0, 10);
        let state = original.state();
        assert!(
            state.maps.len() < state.particles.len(),
            "shared maps are stored once: {} maps",
            state.maps.len()
        );
        let mut restored = FastSlam::from_state(config(), &state).unwrap();
        assert_eq!(restored.state(), state, "state → filter → state is exact");
        drive(&mut original, 10, 20);
        drive(&mut restored, 10, 20);
        let (a, b) = (original.estimate(), restored.estimate());
        assert!((a.mean.x - b.mean.x).abs() < 1e-9 && (a.mean.y - b.mean.y).abs() < 1e-9);
        assert_eq!(original.best_map().len(), restored.best_map().len());
    }

    #[test]
    fn a_state_of_another_particle_count_is_refused() {
        let slam = FastSlam::new(config(), Pose2::default()).unwrap();
        let fewer = FastSlamConfig {
            particles: 10,
            ..config()
        };
        let err = FastSlam::from_state(fewer, &slam.state()).unwrap_err();
        assert!(err.to_string().contains("30 particles"), "{err}");
        let mut broken = slam.state();
        broken.particles[3].map = 99;
        assert!(FastSlam::from_state(config(), &broken).is_err());
    }
}
