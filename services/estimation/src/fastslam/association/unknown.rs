//! Unknown association of a whole scan (see the parent module's documentation): every
//! pair of an observation and a landmark in its search window, gated and scored by its
//! innovation, then the assignment — greedy, joint (Hungarian) or sampled — and the
//! scan's log-likelihood.

use super::{Assignment, Decision, Scan, ScanAssociation};
use crate::fastslam::ekf::{self, Innovation};
use crate::fastslam::landmarks::{LandmarkMap, Slot};
use crate::observation::{self, Observation};
use crate::pose::Pose2;
use crate::rng::SimRng;
use nalgebra::{Matrix2, Matrix3};
use rand::RngExt;

impl Scan<'_> {
    /// Unknown association of the whole scan (see the `association` module): every pair of an
    /// observation and a landmark in its search window, the most likely landmark per
    /// observation, and a joint assignment where two observations want one landmark.
    pub(super) fn unknown_scan(
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
    use super::super::tests::{map_with, seen};
    use super::*;
    use crate::fastslam::AssociationConfig;
    use crate::observation::Sensor;

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
}
