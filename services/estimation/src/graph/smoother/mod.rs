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
//! then fuses the landmarks its solution says are one (`super::duplicates`). A solve is
//! a *window* solve (`super::window`: the newest [`SmootherConfig::window_poses`] poses,
//! the older ones held) unless the graph has grown by [`SmootherConfig::whole_growth`]
//! since its last *whole* solve, which then solves and fuses over everything; the end of
//! the data asks for a whole solve ([`Smoother::solve_whole`]). The decisions depend on
//! the data alone (never on the wall clock), so the same inputs give the same solves and
//! the same numbers. Each solve starts from the last one's solution (new poses chained on
//! by their odometry, new landmarks placed from their first sighting).

use super::consistency::{Fit, TornGate};
use super::duplicates::duplicates;
use super::window::Window;
use super::{Graph, Kernel, OdometryIntegrator, Prior, SolveOptions, SolveReport};
use crate::fastslam::{FastSlamConfig, PriorFloor};
use crate::motion::{Control, MotionModel};
use crate::observation::{Observation, inverse};
use crate::pose::Pose2;
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;

/// Most fuse-and-solve rounds per solve ([`Smoother::solve`]).
const FUSE_ROUNDS: usize = 10;

/// Variance (m²) published for a landmark no solve has placed and whose sightings do not
/// fix it (never in practice: a sighting fixes a landmark given its pose).
const UNSEEN_VARIANCE: f64 = 1e6;

/// Default [`SmootherConfig::torn_chi2_per_dof`]: residuals five standard deviations on
/// average. A noise model that is merely conservative or somewhat tight stays far below.
const TORN_CHI2_PER_DOF: f64 = 25.0;

/// Default [`SmootherConfig::torn_outlier_share`]: half the sightings set aside by the
/// kernel, so the solution no longer answers to the data (a right noise model gives about
/// 1 % at a scale of 3; an odometry noise 4× too tight, about 19 %).
const TORN_OUTLIER_SHARE: f64 = 0.5;

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
    /// Scans between a solve's trigger and the filter taking it over (re-anchoring, the
    /// noise fit): the back-end solves meanwhile, and the filter waits for it only if it
    /// is not done by then, so the point where the filter changes is fixed by the data
    /// (same run, same numbers).
    #[serde(alias = "reanchor_delay_scans")]
    pub handover_delay_scans: u64,
    /// Fuse the landmarks a solution says are one (a landmark mapped again after the
    /// path drifted): loop closure in the graph, for unknown association, where the
    /// keys are the filter's own ids. The service leaves it off under known association.
    pub fuse_duplicates: bool,
    /// The `d²` two landmarks' difference must stay within to be fused (χ²₂ at 99 %).
    pub fuse_gate: f64,
    /// Poses a window solve moves (the newest); 0: every solve is a whole solve.
    pub window_poses: usize,
    /// A solve is a whole solve when the graph has this many times the poses of its last
    /// whole solve (more than 1): whole solves then cost, summed over a run, a few times
    /// the last one.
    pub whole_growth: f64,
    /// Write the graph of the last whole solve here, as g2o ([`G2o::from_graph`](super::g2o::G2o::from_graph)), at the
    /// end of the data (a path relative to the service's working directory; gzipped when
    /// it ends in `.gz`).
    pub graph_out: Option<PathBuf>,
    /// A solution with a larger χ²/dof (no kernel) is torn: not published, and not used
    /// for re-anchoring (docs/ALGORITHMS.md §8.3).
    pub torn_chi2_per_dof: f64,
    /// A solution with a larger share of its sightings beyond the kernel's scale is torn.
    pub torn_outlier_share: f64,
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
            handover_delay_scans: 25,
            fuse_duplicates: true,
            fuse_gate: 9.21,
            window_poses: 300,
            whole_growth: 1.5,
            graph_out: None,
            torn_chi2_per_dof: TORN_CHI2_PER_DOF,
            torn_outlier_share: TORN_OUTLIER_SHARE,
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
        if !(self.whole_growth.is_finite() && self.whole_growth > 1.0) {
            return bad("smoother.whole_growth", "must be finite and > 1");
        }
        if let Some(path) = &self.graph_out
            && let Some(folder) = path.parent()
            && !(folder.as_os_str().is_empty() || folder.is_dir())
        {
            return bad("smoother.graph_out", "its folder does not exist");
        }
        if self.torn_chi2_per_dof.is_nan() || self.torn_chi2_per_dof <= 0.0 {
            return bad(
                "smoother.torn_chi2_per_dof",
                "must be > 0 (inf: never torn)",
            );
        }
        if !(0.0..=1.0).contains(&self.torn_outlier_share) {
            return bad(
                "smoother.torn_outlier_share",
                "must be in 0..=1 (1: never torn)",
            );
        }
        if !(1..=10_000).contains(&self.max_iterations) {
            return bad("smoother.max_iterations", "must be in 1..=10000");
        }
        Ok(())
    }

    /// The limits beyond which a solution is torn.
    pub fn torn_gate(&self) -> TornGate {
        TornGate {
            chi2_per_dof: self.torn_chi2_per_dof,
            outlier_share: self.torn_outlier_share,
        }
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
    /// The solution's fit to its noise model (χ²/dof about 1 when the noise model and
    /// the associations are right).
    pub fit: Fit,
    /// What the solver did.
    pub report: SolveReport,
    /// Solves so far, this one included.
    pub solves: u32,
    /// Whether this solve was over the whole graph (else over the newest poses' window).
    pub whole: bool,
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
    /// Poses when the last solve and the last whole solve ran, and whether a loop closed
    /// since.
    solved_at: usize,
    whole_at: usize,
    loop_pending: bool,
    /// Whether the last solve was a whole solve.
    last_whole: bool,
    solves: u32,
    fused: usize,
    /// Pairs of keys whose fusion the solution refused.
    refused: HashSet<(u64, u64)>,
    /// The window solves' sums of held sightings.
    window: Window,
    /// Each landmark's covariance from the solve that last moved it.
    covariances: Vec<Matrix2<f64>>,
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
            whole_at: 0,
            last_whole: false,
            loop_pending: false,
            solves: 0,
            fused: 0,
            refused: HashSet::new(),
            window: Window::default(),
            covariances: Vec::new(),
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

    /// The graph at its current estimates.
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// The graph at its current estimates, the smoother given up.
    pub fn into_graph(self) -> Graph {
        self.graph
    }

    /// True when the graph changed since its last whole solve.
    pub fn has_news(&self) -> bool {
        self.graph.poses.len() > self.whole_at || !self.last_whole
    }

    /// The solve that is due: a window solve, or a whole solve when the graph has grown
    /// by [`SmootherConfig::whole_growth`] since the last (or was never solved whole).
    /// Returns the solution, with the landmarks' marginal covariances.
    ///
    /// # Errors
    /// When the graph has no sighting yet, or its normal equations cannot be factorised.
    pub fn solve(&mut self) -> Result<Solution> {
        let n = self.graph.poses.len();
        let start = n.saturating_sub(self.config.window_poses);
        if self.whole_at == 0
            || self.config.window_poses == 0
            || start <= 1
            || n as f64 >= self.config.whole_growth * self.whole_at as f64
        {
            return self.solve_whole();
        }
        let options = self.config.solve_options();
        let solved =
            (self.window).solve(&mut self.graph, start, &options, self.config.kernel_scale)?;
        // A landmark mapped since the last solve and out of the window already: what the
        // held poses' sightings say about it.
        for k in self.covariances.len()..self.graph.landmarks.len() {
            let held = self.window.held_covariance(k);
            self.covariances
                .push(held.unwrap_or_else(|| Matrix2::identity() * UNSEEN_VARIANCE));
        }
        for (k, covariance) in solved.covariances {
            self.covariances[k] = covariance;
        }
        Ok(self.solution(solved.report, solved.fit, false))
    }

    /// Solves the whole graph from the last solution (fusing duplicates when configured)
    /// and returns the new one, with the landmarks' marginal covariances.
    ///
    /// # Errors
    /// When the graph has no sighting yet, or its normal equations cannot be factorised.
    pub fn solve_whole(&mut self) -> Result<Solution> {
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
        self.covariances = self.graph.landmark_covariances(options.kernel)?;
        self.window.restart();
        self.whole_at = self.graph.poses.len();
        let fit = self.graph.fit(report.final_cost, self.config.kernel_scale);
        Ok(self.solution(report, fit, true))
    }

    /// Counts a solve and returns its solution.
    fn solution(&mut self, report: SolveReport, fit: Fit, whole: bool) -> Solution {
        self.solved_at = self.graph.poses.len();
        self.last_whole = whole;
        self.loop_pending = false;
        self.solves += 1;
        Solution {
            poses: (self.stamps.iter().copied())
                .zip(self.graph.poses.iter().copied())
                .collect(),
            landmarks: (self.keys.iter().zip(&self.graph.landmarks))
                .zip(&self.covariances)
                .map(|((&key, &at), &cov)| (key, at, cov))
                .collect(),
            fit,
            report,
            solves: self.solves,
            whole,
            fused: self.fused,
        }
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
        let dof = self.graph.dof();
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
mod tests;
