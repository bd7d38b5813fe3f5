//! A full-SLAM graph that grows as the data arrives, solved when a loop closes
//! (docs/ALGORITHMS.md §8.1): the service's smoothing back-end, and — fed with the true
//! landmark ids and solved once — the client's achievable-accuracy reference.
//!
//! The graph has a pose at every scan with sightings (the first pose, where the data
//! starts, fixed at the origin), an odometry factor between consecutive poses (the
//! controls integrated with the filter's motion model and noise, [`OdometryIntegrator`])
//! and a range–bearing factor per sighting. A sighting names its landmark by a key: the
//! true id for the reference, the best particle's landmark id for the back-end.
//!
//! A loop closes when a landmark is seen again after more than
//! [`SmootherConfig::loop_gap_s`] without a sighting, or — with
//! [`SmootherConfig::fuse_duplicates`] — when a new key arrives, since under unknown
//! association a landmark seen again after a drift arrives under a new key; each solve
//! then fuses the landmarks its solution says are one (`super::duplicates`). The
//! decision to solve depends on the data alone (never on the wall clock), so the same
//! inputs give the same solves and the same numbers. Each solve starts from the last
//! one's solution (new poses chained on by their odometry, new landmarks placed from their
//! first sighting).

use super::duplicates::duplicates;
use super::{Graph, Kernel, OdometryIntegrator, Prior, SolveOptions, SolveReport};
use crate::fastslam::{FastSlamConfig, PriorFloor};
use crate::motion::{Control, MotionModel};
use crate::observation::{Observation, inverse};
use crate::pose::Pose2;
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};

/// Most fuse-and-solve rounds per solve ([`Smoother::solve`]).
const FUSE_ROUNDS: usize = 10;

/// The noise the graph assumes: the filter's own models.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseModel {
    /// Motion model with its control noise.
    pub motion: MotionModel,
    /// Covariance of a range–bearing observation.
    pub sensor: Matrix2<f64>,
    /// Added to every odometry factor's covariance (the filter's prior floor), so a
    /// vehicle standing still still gives an invertible factor.
    pub floor: Matrix3<f64>,
}

impl NoiseModel {
    /// The noise model of a filter configured as `config`.
    pub fn of(config: &FastSlamConfig) -> Self {
        let PriorFloor { position, heading } = config.prior_floor;
        Self {
            motion: config.motion.clone(),
            sensor: config.sensor.noise(),
            floor: Matrix3::from_diagonal(&Vector3::new(
                position * position,
                position * position,
                heading * heading,
            )),
        }
    }
}

/// The robust kernel of the sightings, as configured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelKind {
    /// Plain least squares: right for true associations.
    None,
    /// Huber: quadratic within `kernel_scale` standard deviations, linear beyond.
    Huber,
    /// Cauchy: a wrong association's pull fades as its residual grows.
    Cauchy,
}

/// When and how the smoothing back-end solves (the service's `[smoother]` section).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SmootherConfig {
    /// Run the back-end.
    pub enabled: bool,
    /// A landmark seen again after this long without a sighting (s of data time) closes
    /// a loop and asks for a solve.
    pub loop_gap_s: f64,
    /// Fewest new poses between two loop-closure solves, so that a loop seen over many
    /// scans asks for one solve, not one per scan.
    pub min_poses_between_solves: usize,
    /// Robust kernel of the sightings (associations can be wrong).
    pub kernel: KernelKind,
    /// Kernel threshold/scale in standard deviations of the normalised residual.
    pub kernel_scale: f64,
    /// Most Levenberg–Marquardt iterations per solve.
    pub max_iterations: usize,
    /// Move the filter's particles onto each loop-closure solution (re-anchoring).
    pub reanchor: bool,
    /// Scans between a loop-closure solve's trigger and its re-anchoring: the back-end
    /// solves meanwhile, and the filter waits for it only if it is not done by then, so
    /// the point where particles move is fixed by the data (same run, same numbers).
    pub reanchor_delay_scans: u64,
    /// Fuse the landmarks a solution says are one (a landmark mapped again after the
    /// path drifted): loop closure in the graph, for unknown association, where the
    /// keys are the filter's own ids. The service leaves it off under known association.
    pub fuse_duplicates: bool,
    /// The `d²` two landmarks' difference must stay within to be fused (χ²₂ at 99 %).
    pub fuse_gate: f64,
}

impl Default for SmootherConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            loop_gap_s: 30.0,
            min_poses_between_solves: 100,
            kernel: KernelKind::Cauchy,
            kernel_scale: 3.0,
            max_iterations: 50,
            reanchor: false,
            reanchor_delay_scans: 25,
            fuse_duplicates: true,
            fuse_gate: 9.21,
        }
    }
}

impl SmootherConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the first value out of range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, reason: &str| {
            Err(Error::InvalidParameter {
                name,
                reason: reason.into(),
            })
        };
        if !(self.loop_gap_s.is_finite() && self.loop_gap_s >= 0.0) {
            return bad("smoother.loop_gap_s", "must be finite and ≥ 0");
        }
        if !(self.kernel_scale.is_finite() && self.kernel_scale > 0.0) {
            return bad("smoother.kernel_scale", "must be finite and > 0");
        }
        if !(self.fuse_gate.is_finite() && self.fuse_gate > 0.0) {
            return bad("smoother.fuse_gate", "must be finite and > 0");
        }
        if !(1..=10_000).contains(&self.max_iterations) {
            return bad("smoother.max_iterations", "must be in 1..=10000");
        }
        Ok(())
    }

    /// The solver settings this configuration asks for.
    pub fn solve_options(&self) -> SolveOptions {
        let kernel = match self.kernel {
            KernelKind::None => Kernel::None,
            KernelKind::Huber => Kernel::Huber(self.kernel_scale),
            KernelKind::Cauchy => Kernel::Cauchy(self.kernel_scale),
        };
        SolveOptions {
            max_iterations: self.max_iterations,
            kernel,
            ..SolveOptions::default()
        }
    }
}

/// One input of the graph, in the order the filter applied them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Feed {
    /// A control held from `from_ns` to `to_ns`.
    Control {
        /// Start of the interval (ns).
        from_ns: u64,
        /// End of the interval (ns).
        to_ns: u64,
        /// The control.
        control: Control,
    },
    /// A scan at `stamp_ns` whose sightings name their landmark in `id`.
    Scan {
        /// Stamp of the scan (ns).
        stamp_ns: u64,
        /// The sightings, each with its landmark key in `id` (observations without one
        /// are skipped).
        sightings: Vec<Observation>,
    },
}

/// A solved graph: the trajectory and the map.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The poses (stamp in ns), in time order.
    pub poses: Vec<(u64, Pose2)>,
    /// The landmarks: key, position and marginal covariance.
    pub landmarks: Vec<(u64, Vector2<f64>, Matrix2<f64>)>,
    /// χ² (no kernel) per degree of freedom at the solution: about 1 when the noise
    /// model and the associations are right.
    pub chi2_per_dof: f64,
    /// What the solver did.
    pub report: SolveReport,
    /// Solves so far, this one included.
    pub solves: u32,
    /// Landmarks fused into another so far ([`SmootherConfig::fuse_duplicates`]).
    pub fused: usize,
}

/// The growing graph; see the module documentation.
#[derive(Debug, Clone)]
pub struct Smoother {
    config: SmootherConfig,
    noise: NoiseModel,
    graph: Graph,
    odometry: OdometryIntegrator,
    /// Stamp of every pose; empty until the first control says where the data starts.
    stamps: Vec<u64>,
    /// Landmark index of each key, and each landmark's key and last sighting (ns).
    index: HashMap<u64, usize>,
    keys: Vec<u64>,
    last_seen_ns: Vec<u64>,
    /// Poses when the last solve ran, and whether a loop closed since.
    solved_at: usize,
    loop_pending: bool,
    solves: u32,
    fused: usize,
    /// Pairs of keys whose fusion the solution refused.
    refused: HashSet<(u64, u64)>,
}

impl Smoother {
    /// An empty graph with `config` and `noise`.
    ///
    /// # Errors
    /// As [`SmootherConfig::validate`].
    pub fn new(config: SmootherConfig, noise: NoiseModel) -> Result<Self> {
        config.validate()?;
        let mut graph = Graph::default();
        graph.add_pose(Pose2::default());
        graph.priors.push(Prior {
            pose: 0,
            mean: Pose2::default(),
            information: Matrix3::identity() * 1e8,
        });
        Ok(Self {
            odometry: OdometryIntegrator::new(noise.motion.clone(), noise.floor),
            config,
            noise,
            graph,
            stamps: Vec::new(),
            index: HashMap::new(),
            keys: Vec::new(),
            last_seen_ns: Vec::new(),
            solved_at: 0,
            loop_pending: false,
            solves: 0,
            fused: 0,
            refused: HashSet::new(),
        })
    }

    /// Adds one input; true when a solve is due (a loop closed, and enough poses came
    /// since the last solve).
    pub fn feed(&mut self, feed: &Feed) -> bool {
        match feed {
            Feed::Control {
                from_ns,
                to_ns,
                control,
            } => {
                if self.stamps.is_empty() {
                    self.stamps.push(*from_ns);
                }
                let dt = to_ns.saturating_sub(*from_ns) as f64 * 1e-9;
                if dt > 0.0 {
                    self.odometry.add(control, dt);
                }
                false
            }
            Feed::Scan {
                stamp_ns,
                sightings,
            } => self.scan(*stamp_ns, sightings),
        }
    }

    fn scan(&mut self, stamp_ns: u64, sightings: &[Observation]) -> bool {
        let keyed = || sightings.iter().filter(|o| o.id.is_some());
        if keyed().next().is_none() {
            return false;
        }
        if self.stamps.is_empty() {
            self.stamps.push(stamp_ns);
        }
        let pose = if self.odometry.controls() == 0 {
            self.graph.poses.len() - 1
        } else {
            let from = self.graph.poses.len() - 1;
            let Some(between) = self.odometry.take(from, from + 1) else {
                return false;
            };
            let initial = self.graph.poses[from].compose(&between.delta);
            let to = self.graph.add_pose(initial);
            self.graph.betweens.push(between);
            self.stamps.push(stamp_ns);
            to
        };
        for obs in keyed() {
            let key = obs.id.expect("keyed");
            let landmark = match self.index.get(&key) {
                Some(&k) => {
                    let gap_s = stamp_ns.saturating_sub(self.last_seen_ns[k]) as f64 * 1e-9;
                    self.loop_pending |= gap_s > self.config.loop_gap_s;
                    k
                }
                None => {
                    // Under unknown association a landmark mapped again after a drift
                    // arrives under a new key: a new key may close a loop.
                    self.loop_pending |= self.config.fuse_duplicates;
                    let at = inverse(&self.graph.poses[pose], &obs.z()).0;
                    let k = self.graph.add_landmark(at);
                    self.index.insert(key, k);
                    self.keys.push(key);
                    self.last_seen_ns.push(stamp_ns);
                    k
                }
            };
            if self
                .graph
                .add_sighting(pose, landmark, obs, &self.noise.sensor)
                .is_ok()
            {
                self.last_seen_ns[landmark] = stamp_ns;
            }
        }
        self.loop_pending
            && self.graph.poses.len() >= self.solved_at + self.config.min_poses_between_solves
    }

    /// Poses in the graph.
    pub fn poses(&self) -> usize {
        self.graph.poses.len()
    }

    /// True when poses were added since the last solve.
    pub fn has_news(&self) -> bool {
        self.graph.poses.len() > self.solved_at
    }

    /// Solves the graph from the last solution and returns the new one, with the
    /// landmarks' marginal covariances.
    ///
    /// # Errors
    /// When the graph has no sighting yet, or its normal equations cannot be factorised.
    pub fn solve(&mut self) -> Result<Solution> {
        if self.graph.sightings.is_empty() {
            return Err(Error::InvalidInput {
                what: "smoother",
                reason: "no sighting yet".into(),
            });
        }
        let options = self.config.solve_options();
        let mut report = self.graph.solve(&options)?;
        if self.config.fuse_duplicates {
            report = self.fuse_duplicates(&options, report)?;
        }
        let covariances = self.graph.landmark_covariances(options.kernel)?;
        self.solved_at = self.graph.poses.len();
        self.loop_pending = false;
        self.solves += 1;
        let dof = (self.graph.residuals().saturating_sub(self.graph.unknowns())).max(1) as f64;
        Ok(Solution {
            poses: self
                .stamps
                .iter()
                .copied()
                .zip(self.graph.poses.iter().copied())
                .collect(),
            landmarks: (self.keys.iter().zip(&self.graph.landmarks).zip(covariances))
                .map(|((&key, &at), cov)| (key, at, cov))
                .collect(),
            chi2_per_dof: self.graph.chi2() / dof,
            report,
            solves: self.solves,
            fused: self.fused,
        })
    }

    /// Fuses the landmarks the solution says are one and solves again, until no more are
    /// found (at most [`FUSE_ROUNDS`] times): each fusion shrinks the marginals around
    /// the loop it closed, which can settle a match that was ambiguous before. The
    /// groups a round finds are tried together, and one by one when together they are
    /// refused ([`try_fuse`](Self::try_fuse)); a refused group is never tried again.
    /// Returns the last solve's report.
    fn fuse_duplicates(
        &mut self,
        options: &SolveOptions,
        mut report: SolveReport,
    ) -> Result<SolveReport> {
        for _ in 0..FUSE_ROUNDS {
            let refused: HashSet<(usize, usize)> = (self.refused.iter())
                .map(|(a, b)| (self.index[a], self.index[b]))
                .map(|(a, b)| (a.min(b), a.max(b)))
                .collect();
            let groups = duplicates(&self.graph, options.kernel, self.config.fuse_gate, &refused)?;
            if groups.is_empty() {
                break;
            }
            let keyed: Vec<Vec<u64>> = (groups.iter())
                .map(|g| g.iter().map(|&k| self.keys[k]).collect())
                .collect();
            if let Some(fused) = self.try_fuse(&keyed, options, &report)? {
                report = fused;
                continue;
            }
            for group in &keyed {
                match self.try_fuse(std::slice::from_ref(group), options, &report)? {
                    Some(fused) => report = fused,
                    None => {
                        for (i, &a) in group.iter().enumerate() {
                            for &b in &group[i + 1..] {
                                self.refused.insert((a, b));
                            }
                        }
                    }
                }
            }
        }
        Ok(report)
    }

    /// Fuses `groups` (named by their landmarks' keys) and solves — first without the
    /// robust kernel, since the fused landmark's sightings from the drifted part start
    /// far off it and the kernel would discount them, then with it. Keeps the result
    /// when both the robust cost the solve minimises and the χ² (no kernel: a torn graph
    /// cannot hide its strain in the kernel's flat tails) rose by at most `fuse_gate` per
    /// landmark fused, each in units of its variance factor `max(1, value / dof)` before
    /// (the graph's own measure of how far its noise model is off); else puts the graph
    /// back and returns `None`.
    fn try_fuse(
        &mut self,
        groups: &[Vec<u64>],
        options: &SolveOptions,
        before: &SolveReport,
    ) -> Result<Option<SolveReport>> {
        let saved = (
            self.graph.clone(),
            self.index.clone(),
            self.keys.clone(),
            self.last_seen_ns.clone(),
        );
        let dof = (self.graph.residuals().saturating_sub(self.graph.unknowns())).max(1) as f64;
        let chi2 = self.graph.chi2();
        let fused: usize = groups.iter().map(|g| g.len() - 1).sum();
        let indices: Vec<Vec<usize>> = (groups.iter())
            .map(|g| {
                let mut at: Vec<usize> = g.iter().map(|k| self.index[k]).collect();
                at.sort_unstable();
                at
            })
            .collect();
        let after = self.graph.fuse_landmarks(&indices);
        self.renumber(&after);
        let plain = SolveOptions {
            kernel: Kernel::None,
            ..*options
        };
        let solved = (self.graph.solve(&plain)).and_then(|_| self.graph.solve(options));
        let allowed = |before: f64| (before / dof).max(1.0) * self.config.fuse_gate * fused as f64;
        let rise = (self.graph.chi2() - chi2, allowed(chi2));
        let within = |report: &SolveReport| {
            rise.0 <= rise.1 && report.final_cost - before.final_cost <= allowed(before.final_cost)
        };
        match solved {
            Ok(mut report) if within(&report) => {
                tracing::debug!(?groups, ?rise, "landmarks fused");
                report.seconds += before.seconds;
                self.fused += fused;
                Ok(Some(report))
            }
            outcome => {
                tracing::debug!(?groups, ?rise, ok = outcome.is_ok(), "fusion refused");
                (self.graph, self.index, self.keys, self.last_seen_ns) = saved;
                outcome.map(|_| None)
            }
        }
    }

    /// Follows [`Graph::fuse_landmarks`]: every key names its landmark's new index, and
    /// a fused landmark was last seen when the latest of its group was.
    fn renumber(&mut self, after: &[usize]) {
        for k in self.index.values_mut() {
            *k = after[*k];
        }
        let (mut keys, mut last_seen_ns) = (Vec::new(), Vec::<u64>::new());
        for (k, &to) in after.iter().enumerate() {
            if to == keys.len() {
                keys.push(self.keys[k]);
                last_seen_ns.push(self.last_seen_ns[k]);
            } else {
                last_seen_ns[to] = last_seen_ns[to].max(self.last_seen_ns[k]);
            }
        }
        (self.keys, self.last_seen_ns) = (keys, last_seen_ns);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Unicycle;
    use crate::observation::measure;

    fn noise() -> NoiseModel {
        NoiseModel {
            motion: MotionModel::Unicycle(Unicycle {
                sigma_v: 0.1,
                sigma_omega: 0.05,
            }),
            sensor: Matrix2::from_diagonal(&Vector2::new(0.1 * 0.1, 0.02 * 0.02)),
            floor: Matrix3::identity() * 1e-10,
        }
    }

    /// Keyed sightings of every landmark within 12 m of `pose`.
    fn sightings(pose: &Pose2, landmarks: &[Vector2<f64>]) -> Vec<Observation> {
        (landmarks.iter().enumerate())
            .filter_map(|(k, m)| {
                let z = measure(pose, m);
                (z[0] < 12.0).then_some(Observation {
                    range: z[0],
                    bearing: z[1],
                    id: Some(k as u64),
                })
            })
            .collect()
    }

    /// Sixteen landmarks around a circle of 18 m radius, and the control that drives it
    /// once in 100 s from the origin.
    fn circle() -> (Vec<Vector2<f64>>, Control) {
        let landmarks = (0..16)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 16.0;
                Vector2::new(18.0 * a.cos(), 15.9 + 18.0 * a.sin())
            })
            .collect();
        let control = Control {
            v: 1.0,
            omega: std::f64::consts::TAU / 100.0,
            steering: 0.0,
            ..Control::ZERO
        };
        (landmarks, control)
    }

    /// Two laps of a 100 s circle with landmarks around it, fed at 10 Hz with a scan every
    /// second. Odometry and sightings carry `noise_scale` times the model's noise (seed
    /// `seed`; 0: exact data), and the second lap's landmarks are keyed `100 + k` when
    /// `rekey` (as a filter that mapped them again after its path drifted would key
    /// them). Returns the smoother, the true poses at the scans and the feed results.
    fn laps(
        config: SmootherConfig,
        noise_scale: f64,
        rekey: bool,
        seed: u64,
    ) -> (Smoother, Vec<Pose2>, Vec<bool>) {
        use rand::RngExt;
        let mut rng = crate::rng::seeded(seed);
        let mut normal = move |sigma: f64| {
            noise_scale * sigma * rng.sample::<f64, _>(rand_distr::StandardNormal)
        };
        let model = noise();
        let (landmarks, truth_control) = circle();
        let mut smoother = Smoother::new(config, model.clone()).unwrap();
        let (mut x, mut truth, mut due) = (Pose2::default(), Vec::new(), Vec::new());
        for k in 1..=2000_u64 {
            let (from_ns, to_ns) = ((k - 1) * 100_000_000, k * 100_000_000);
            let control = Control {
                v: truth_control.v + normal(0.1),
                omega: truth_control.omega + normal(0.05),
                steering: 0.0,
                ..Control::ZERO
            };
            smoother.feed(&Feed::Control {
                from_ns,
                to_ns,
                control,
            });
            x = model.motion.propagate(&x, &truth_control, 0.1);
            if k % 10 == 0 {
                truth.push(x);
                let seen = (sightings(&x, &landmarks).into_iter())
                    .map(|o| Observation {
                        range: o.range + normal(0.1),
                        bearing: o.bearing + normal(0.02),
                        id: o.id.map(|id| if rekey && k > 1000 { 100 + id } else { id }),
                    })
                    .collect();
                due.push(smoother.feed(&Feed::Scan {
                    stamp_ns: to_ns,
                    sightings: seen,
                }));
            }
        }
        (smoother, truth, due)
    }

    /// [`laps`] with odometry and sightings as noisy as the model says, solved at the end.
    fn drifting_laps(config: SmootherConfig, rekey: bool, seed: u64) -> Solution {
        laps(config, 1.0, rekey, seed).0.solve().unwrap()
    }

    #[test]
    fn landmarks_mapped_again_after_a_drift_are_fused_and_close_the_loop() {
        let apart = |a: &Solution, b: &Solution| {
            (a.poses.iter().zip(&b.poses))
                .map(|((_, p), (_, q))| (p.x - q.x).hypot(p.y - q.y))
                .fold(0.0, f64::max)
        };
        let unfused = SmootherConfig {
            fuse_duplicates: false,
            ..SmootherConfig::default()
        };
        for seed in 1..=5 {
            let known = drifting_laps(unfused.clone(), false, seed);
            let open = drifting_laps(unfused.clone(), true, seed);
            let fused = drifting_laps(SmootherConfig::default(), true, seed);
            assert_eq!(known.landmarks.len(), 16);
            assert_eq!(open.landmarks.len(), 32);
            // Every second-lap key fused into its own first-lap landmark, none into a
            // neighbour: the graph is that of the true keys, and so is its solution.
            assert_eq!(fused.fused, 16, "seed {seed}");
            let mut keys: Vec<u64> = fused.landmarks.iter().map(|l| l.0).collect();
            keys.sort_unstable();
            assert_eq!(keys, (0..16).collect::<Vec<u64>>(), "seed {seed}");
            assert!(apart(&fused, &known) < 1e-3, "seed {seed}");
            assert!(
                apart(&open, &known) > 0.3,
                "seed {seed}: the open loop is {} m from the closed one: no drift to close",
                apart(&open, &known)
            );
        }
    }

    #[test]
    fn a_loop_asks_for_one_solve_and_exact_data_is_solved_exactly() {
        let config = SmootherConfig {
            loop_gap_s: 50.0,
            min_poses_between_solves: 30,
            kernel: KernelKind::None,
            fuse_duplicates: false,
            ..SmootherConfig::default()
        };
        let (mut smoother, truth, due) = laps(config, 0.0, false, 0);
        // A landmark is out of sight for more than 50 s only once the lap comes round
        // (one scan a second): the first re-sighting after that asks.
        let first = due.iter().position(|&d| d).expect("a loop closes");
        assert!((50..100).contains(&first), "scan {first}");
        assert!(due[..first].iter().all(|&d| !d));
        assert_eq!(smoother.poses(), truth.len() + 1);
        let solution = smoother.solve().unwrap();
        assert!(!smoother.has_news());
        let worst = (solution.poses[1..].iter().zip(&truth))
            .map(|((_, p), t)| (p.x - t.x).hypot(p.y - t.y))
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "exact data: {worst} m");
        assert!(solution.chi2_per_dof < 1e-9);
    }

    #[test]
    fn without_a_loop_no_solve_is_asked() {
        let config = SmootherConfig {
            loop_gap_s: 500.0,
            fuse_duplicates: false,
            ..SmootherConfig::default()
        };
        let (_, _, due) = laps(config, 0.0, false, 0);
        assert!(due.iter().all(|&d| !d));
    }

    #[test]
    fn a_landmark_seen_once_from_the_fixed_start_has_the_sensor_covariance() {
        let model = noise();
        let mut smoother = Smoother::new(SmootherConfig::default(), model.clone()).unwrap();
        let obs = Observation {
            range: 10.0,
            bearing: 0.5,
            id: Some(7),
        };
        smoother.feed(&Feed::Scan {
            stamp_ns: 0,
            sightings: vec![obs],
        });
        let solution = smoother.solve().unwrap();
        let (key, _, cov) = solution.landmarks[0];
        let (_, g) = inverse(&Pose2::default(), &obs.z());
        let expected = g * model.sensor * g.transpose();
        assert_eq!(key, 7);
        // The start's prior (variance 1e-8) adds about r² · 1e-8 to it.
        assert!(
            (cov - expected).norm() < 1e-4 * expected.norm(),
            "{cov} vs {expected}"
        );
    }
}
