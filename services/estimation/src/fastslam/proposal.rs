//! The proposal distribution of a particle's new pose (docs/ALGORITHMS.md §1): the motion model
//! (FastSLAM 1.0, [`Proposal::Motion`]) or FastSLAM 2.0's Gaussian that also uses the
//! current scan ([`Proposal::FastSlam2`]; Montemerlo et al. 2003, Bailey's `fastslam2`
//! simulator code).
//!
//! FastSLAM 2.0, per particle:
//! 1. start from the motion prior `N(x̂, P)` ([`MotionPrior`](super::MotionPrior));
//! 2. associate the scan at `x̂` (§1 step 3, the filter's own gates; with
//!    `association.pose_uncertainty`, with the pose uncertainty `P` in every innovation
//!    covariance, `Scan::associate_uncertain`);
//! 3. for each observation of a matched landmark, in scan order, update the Gaussian like
//!    an EKF whose state is the pose: with `H_x`, `H_m` the measurement Jacobians at the
//!    current mean, `S_m = H_m Σ H_mᵀ + R` and `S = H_x P H_xᵀ + S_m`,
//!    `K = P H_xᵀ S⁻¹`, `x̂ ← x̂ + K ν`, `P ← (I − K H_x) P (I − K H_x)ᵀ + K S_m Kᵀ`
//!    (Joseph form; Bailey writes the same update in information form);
//! 4. draw the pose from the final Gaussian.
//!
//! The weight is the likelihood of the scan with the pose integrated out under the motion
//! prior (Montemerlo et al. 2003, eq. for `w` with the combined covariance `S`): each
//! matched observation contributes `log N(ν; 0, S)` evaluated *before* it updates the
//! Gaussian — the chain rule `p(z₁..zₙ) = Π p(zⱼ | z₁..zⱼ₋₁)` of the linearised model,
//! where Bailey's `compute_weight` multiplies the n terms all taken at the prior (which
//! counts the shared pose uncertainty n times). The weight does not depend on the drawn
//! pose. Observations that are not matched contribute what the association gives them at
//! `x̂` (a new landmark: `log_p_new`). New landmarks are created from the drawn pose, as
//! in 1.0.
//!
//! Decisions taken here: the map update re-associates at the drawn pose (without the pose
//! covariance, as FastSLAM 1.0), which in borderline cases of unknown association may
//! decide differently from step 2 (the proposal moves the pose toward agreement with the
//! matched landmarks, so a match rarely gets lost). A particle without a matched landmark is not
//! drawn here: the filter defers sampling with this proposal, so the particle stays its
//! motion prior, or is drawn from it when the scan starts landmarks
//! ([`super::FastSlam`]'s deferred sampling).

use super::association::{Decision, Scan};
use super::ekf::innovate_with;
use super::particle::Particle;
use crate::check::named_choices;
use crate::observation::predict;
use crate::pose::Pose2;
use crate::rng::SimRng;
use nalgebra::{Matrix3, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// How the filter draws a particle's new pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Proposal {
    /// From the motion model alone (FastSLAM 1.0); the weight is the scan's likelihood at
    /// the drawn pose.
    #[default]
    #[serde(rename = "motion")]
    Motion,
    /// From the motion prior updated with the scan's matched landmarks (FastSLAM 2.0);
    /// the weight is the scan's likelihood with the pose integrated out.
    #[serde(rename = "fastslam2")]
    FastSlam2,
}

named_choices!(Proposal, "proposal", { Motion => "motion", FastSlam2 => "fastslam2" });

/// A pose drawn from FastSLAM 2.0's proposal with the log-weight increment of the step
/// and the Gaussian it was drawn from (the particle's component of the published
/// estimate).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Drawn {
    pub pose: Pose2,
    pub log_likelihood: f64,
    pub mean: Pose2,
    pub covariance: Matrix3<f64>,
}

/// The Gaussian of steps 1–3 of the module documentation for `particle` and `scan`, and the
/// weight: `None` when no observation is matched.
fn gaussian(scan: &Scan<'_>, particle: &Particle) -> Option<(Pose2, Matrix3<f64>, f64)> {
    let noise = scan.sensor().noise();
    let prior = particle.prior();
    let association = if scan.config().pose_uncertainty {
        scan.associate_uncertain(particle.map(), &prior.mean, &prior.covariance)
    } else {
        scan.associate(particle.map(), &prior.mean)
    };
    let (mut mean, mut cov) = (prior.mean, prior.covariance);
    let mut log_likelihood = association.log_likelihood;
    let mut matched = 0;
    for (obs, decision) in scan.observations().iter().zip(&association.decisions) {
        let Decision::Update {
            slot, innovation, ..
        } = decision
        else {
            continue;
        };
        let Some(landmark) = particle.map().at(*slot) else {
            continue;
        };
        let Some(p) = predict(&mean, &landmark.mean) else {
            continue;
        };
        let (h_m, h_x) = (p.wrt_landmark, p.wrt_pose);
        let s_landmark = h_m * landmark.covariance * h_m.transpose() + noise;
        let s = h_x * cov * h_x.transpose() + s_landmark;
        let Some(combined) = innovate_with(&obs.z(), &p, &s) else {
            continue;
        };
        log_likelihood += combined.log_likelihood - innovation.log_likelihood;
        let k = cov * h_x.transpose() * combined.s_inv;
        let step = k * combined.nu;
        mean = Pose2::new(mean.x + step[0], mean.y + step[1], mean.theta + step[2]);
        let a = Matrix3::identity() - k * h_x;
        let joseph = a * cov * a.transpose() + k * s_landmark * k.transpose();
        cov = 0.5 * (joseph + joseph.transpose());
        matched += 1;
    }
    (matched > 0).then_some((mean, cov, log_likelihood))
}

/// Draws `particle`'s pose from FastSLAM 2.0's proposal for `scan` (see the module
/// documentation), three standard normal draws from `rng`. `None` — the filter's
/// deferred-sampling rule then applies — when no observation of the scan matches a
/// landmark of the particle's map, or the proposal's covariance has lost definiteness.
///
/// # Performance
/// One association plus O(matched) 3×3 products.
pub(crate) fn fastslam2(scan: &Scan<'_>, particle: &Particle, rng: &mut SimRng) -> Option<Drawn> {
    let (mean, cov, log_likelihood) = gaussian(scan, particle)?;
    let l = cov.cholesky()?.l();
    let e = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
    let d = l * e;
    Some(Drawn {
        pose: Pose2::new(mean.x + d[0], mean.y + d[1], mean.theta + d[2]),
        log_likelihood,
        mean,
        covariance: cov,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fastslam::association::{AssociationConfig, AssociationMode};
    use crate::fastslam::landmarks::{Landmark, LandmarkMap};
    use crate::fastslam::particle::MotionPrior;
    use crate::observation::{Observation, Sensor, measure};
    use crate::rng::seeded;
    use nalgebra::{Matrix2, Vector2};

    fn particle(prior: MotionPrior, landmarks: &[(f64, f64)]) -> Particle {
        let mut map = LandmarkMap::new(10.0);
        for (id, &(x, y)) in landmarks.iter().enumerate() {
            map.insert(Landmark {
                id: id as u64,
                mean: Vector2::new(x, y),
                covariance: Matrix2::identity() * 1e-4,
                hits: 5,
                chances: 0,
            });
        }
        Particle {
            pose: prior.mean,
            log_weight: 0.0,
            map,
            trail: Default::default(),
            prior,
        }
    }

    fn known() -> AssociationConfig {
        AssociationConfig {
            mode: AssociationMode::Known,
            ..AssociationConfig::default()
        }
    }

    fn observations(truth: &Pose2, landmarks: &[(f64, f64)]) -> Vec<Observation> {
        landmarks
            .iter()
            .enumerate()
            .map(|(id, &(x, y))| {
                let z = measure(truth, &Vector2::new(x, y));
                Observation {
                    range: z[0],
                    bearing: z[1],
                    id: Some(id as u64),
                }
            })
            .collect()
    }

    #[test]
    fn names_parse_and_list_the_choices() {
        for p in Proposal::ALL {
            assert_eq!(p.to_string().parse::<Proposal>().unwrap(), p);
        }
        let err = "fastslam3".parse::<Proposal>().unwrap_err().to_string();
        assert!(err.contains("motion, fastslam2"), "{err}");
    }

    #[test]
    fn proposal_moves_a_wrong_prior_onto_the_pose_the_landmarks_say() {
        // The prior is 0.3 m off in x and 0.02 rad in heading, with a spread that allows it;
        // noise-free observations of three surveyed landmarks tell the truth.
        let landmarks = [(10.0, 3.0), (12.0, -4.0), (20.0, 1.0)];
        let truth = Pose2::new(0.0, 0.0, 0.0);
        let prior = MotionPrior {
            mean: Pose2::new(0.3, 0.0, 0.02),
            covariance: Matrix3::from_diagonal(&Vector3::new(0.25, 0.25, 0.01)),
        };
        let p = particle(prior, &landmarks);
        let obs = observations(&truth, &landmarks);
        let sensor = Sensor::default();
        let config = known();
        let scan = Scan::new(&obs, &sensor, &config, 1);
        let (mean, cov, _) = gaussian(&scan, &p).unwrap();
        assert!(
            (mean.x - truth.x).hypot(mean.y - truth.y) < 0.05,
            "{mean:?}"
        );
        assert!(mean.theta.abs() < 0.005, "{mean:?}");
        for (k, prior_variance) in [0.25, 0.25, 0.01].into_iter().enumerate() {
            assert!(cov[(k, k)] < prior_variance / 5.0, "shrunk: {cov}");
        }
        let drawn = fastslam2(&scan, &p, &mut seeded(1)).unwrap();
        assert!((drawn.pose.x - mean.x).abs() < 5.0 * cov[(0, 0)].sqrt());
    }

    #[test]
    fn weight_is_the_linear_gaussian_marginal_likelihood() {
        // One observation: the sequential weight is exactly log N(ν; 0, H_x P H_xᵀ + S_m).
        let landmarks = [(8.0, 2.0)];
        let prior = MotionPrior {
            mean: Pose2::new(0.0, 0.0, 0.1),
            covariance: Matrix3::from_diagonal(&Vector3::new(0.04, 0.01, 0.001)),
        };
        let p = particle(prior, &landmarks);
        let obs = observations(&Pose2::new(0.1, -0.05, 0.08), &landmarks);
        let sensor = Sensor::default();
        let config = known();
        let scan = Scan::new(&obs, &sensor, &config, 1);
        let (_, _, weight) = gaussian(&scan, &p).unwrap();
        let pr = predict(&prior.mean, &Vector2::new(8.0, 2.0)).unwrap();
        let s = pr.wrt_pose * prior.covariance * pr.wrt_pose.transpose()
            + pr.wrt_landmark * Matrix2::identity() * 1e-4 * pr.wrt_landmark.transpose()
            + sensor.noise();
        let nu = obs[0].z() - pr.z;
        let expected = -0.5 * (nu.transpose() * s.try_inverse().unwrap() * nu)[0]
            - (std::f64::consts::TAU).ln()
            - 0.5 * s.determinant().ln();
        assert!((weight - expected).abs() < 1e-9, "{weight} vs {expected}");
    }

    #[test]
    fn draws_follow_the_proposal_covariance() {
        let landmarks = [(10.0, 3.0), (12.0, -4.0)];
        let prior = MotionPrior {
            mean: Pose2::new(0.0, 0.0, 0.0),
            covariance: Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, 0.0004)),
        };
        let p = particle(prior, &landmarks);
        let obs = observations(&Pose2::new(0.05, 0.02, 0.01), &landmarks);
        let sensor = Sensor::default();
        let config = known();
        let scan = Scan::new(&obs, &sensor, &config, 1);
        let (mean, cov, _) = gaussian(&scan, &p).unwrap();
        let mut rng = seeded(7);
        let n = 20_000;
        let mut sample_cov = Matrix3::zeros();
        for _ in 0..n {
            let d = p
                .prior()
                .deviation(&fastslam2(&scan, &p, &mut rng).unwrap().pose)
                - p.prior().deviation(&mean);
            sample_cov += d * d.transpose() / n as f64;
        }
        for k in 0..3 {
            let ratio = sample_cov[(k, k)] / cov[(k, k)];
            assert!((ratio - 1.0).abs() < 0.05, "dimension {k}: {ratio}");
        }
    }

    #[test]
    fn no_matched_landmark_keeps_the_motion_sample() {
        let prior = MotionPrior {
            mean: Pose2::default(),
            covariance: Matrix3::identity() * 1e-4,
        };
        let p = particle(prior, &[]);
        let obs = [Observation {
            range: 5.0,
            bearing: 0.0,
            id: None,
        }];
        let sensor = Sensor::default();
        let config = AssociationConfig::default();
        let scan = Scan::new(&obs, &sensor, &config, 1);
        assert!(fastslam2(&scan, &p, &mut seeded(1)).is_none());
    }
}
