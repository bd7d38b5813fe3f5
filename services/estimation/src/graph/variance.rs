//! Variance components of a solved graph: the factor by which each kind of factor's
//! noise exceeds the noise model, estimated from the whole solution's residuals
//! (docs/ALGORITHMS.md §8.4) — the smoothing back-end's noise fit, and the noise check's
//! suspect where there is a back-end (§1, "Noise fit").
//!
//! Two groups are fitted: the odometry factors ([`Between`](super::Between)) and the
//! landmark observations ([`Sighting`](super::Sighting), [`Offset`](super::Offset)); the
//! priors only anchor the graph and are taken as right. In a pose graph the two groups are
//! betweens: the consecutive constraints and the loop closures
//! ([`Graph::between_components`]). Solved by least squares with the
//! model's weights, group `k`'s weighted residual sum `Ω_k = Σ rᵀ Ω r` has, for a linear
//! model, the expectation (Helmert)
//! `E[Ω_k] = θ_k (n_k − 2 tr(N⁻¹N_k)) + Σ_j θ_j tr(N⁻¹N_k N⁻¹N_j)`, with `N_k = Σ Jᵀ Ω J`
//! over the group's factors, `N = Σ_k N_k`, `n_k` the group's residuals and `θ_k` the
//! factor by which its true variances exceed the model's. Setting each `Ω_k` to its
//! expectation gives two linear equations in `(θ_odometry, θ_landmarks)`: unbiased whatever
//! the weights. The graph is then re-weighted by the estimate, solved again and
//! estimated again, until a round moves neither factor by more than [`SETTLED`]; at that
//! fixed point `θ_k = Ω_k / red_k` with the redundancy `red_k = n_k − tr(N⁻¹N_k)`
//! (Förstner's form).
//!
//! The traces come from Hutchinson's estimator with [`PROBES`] fixed Rademacher probes
//! `z` in the whitened residuals of each group: `b_k = J̃_kᵀ z_k` (`J̃ = Lᵀ J`, `Ω = L Lᵀ`)
//! has covariance `N_k`, so with `y_k = N⁻¹ b_k`, `b_kᵀ y_k` estimates `tr(N⁻¹N_k)` and
//! `y_kᵀ N_j y_k` estimates `tr(N⁻¹N_k N⁻¹N_j)` — both quadratic forms of matrices with
//! eigenvalues in `[0, 1]`, whose estimates have a standard deviation of at most
//! `√(2 tr / PROBES)`. One sparse factorisation and `2 × PROBES` solves per round.
//! Fixed probes: the same graph gives the same numbers.
//!
//! The solves here use no robust kernel, as the χ²/dof of [`Fit`](super::Fit) does: a
//! wrong association counts as sensor noise.

use super::solve::{Kernel, PoseUpdate, SolveOptions};
use super::system::System;
use super::{Between, Graph, Linearised};
use crate::fastslam::noise_fit::{MAX_SCALE, MIN_SCALE};
use crate::{Error, Result};
use faer::Mat;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use rand::RngExt;

/// Hutchinson probes per round.
pub const PROBES: usize = 16;
/// A round that changes both factors by less than this fraction ends the iteration.
pub const SETTLED: f64 = 0.05;
/// Most rounds (re-weighted solves).
const ROUNDS: usize = 5;
/// Seed of the probes.
const PROBE_SEED: u64 = 0x005e_ed0f_7ace;
/// A group's variance factor at or above this blames it (σ 41 % above the model's).
pub const SUSPECT_SCALE: f64 = 2.0;
/// Fewest redundant residuals a group needs for a verdict.
pub const MIN_REDUNDANCY: f64 = 30.0;

/// One group's variance component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Component {
    /// Residuals in the group (3 per odometry factor, 2 per observation).
    pub residuals: usize,
    /// The group's redundancy `n_k − tr(N⁻¹N_k)` at the fitted weights: how many of its
    /// residuals the rest of the graph checks.
    pub redundancy: f64,
    /// The factor by which the group's variances exceed the noise model's (σ: its square
    /// root), within `[MIN_SCALE, MAX_SCALE]` of the noise fit.
    pub scale: f64,
}

impl Component {
    /// Whether the group is a suspect: its factor at least [`SUSPECT_SCALE`] with a
    /// redundancy of at least [`MIN_REDUNDANCY`].
    pub fn is_suspect(&self) -> bool {
        self.scale >= SUSPECT_SCALE && self.redundancy >= MIN_REDUNDANCY
    }
}

/// The variance components of a solved graph; see the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VarianceComponents {
    /// The odometry factors'.
    pub odometry: Component,
    /// The landmark observations' (the sensor's).
    pub landmarks: Component,
    /// Rounds run (solves with re-weighting).
    pub rounds: usize,
}

impl VarianceComponents {
    /// The source the components blame: the odometry (`true`) or the sensor (`false`),
    /// whichever has the larger factor when that reaches [`SUSPECT_SCALE`] and its
    /// redundancy [`MIN_REDUNDANCY`]; `None` when neither does.
    pub fn blames_odometry(&self) -> Option<bool> {
        let odometry = self.odometry.scale >= self.landmarks.scale;
        let worse = if odometry {
            &self.odometry
        } else {
            &self.landmarks
        };
        worse.is_suspect().then_some(odometry)
    }

    /// The factors `(odometry, sensor)`.
    pub fn scales(&self) -> [f64; 2] {
        [self.odometry.scale, self.landmarks.scale]
    }

    /// The variance scales `(odometry, sensor)` a filter on the noise model's noise
    /// should run on: a group's factor where it is a suspect on its own
    /// ([`Component::is_suspect`]), else 1. The
    /// model is a floor: a factor below 1 says the model is cautious, which it may be
    /// for what the fit cannot see (a lag, landmarks in clusters), and is not followed.
    pub fn scales_to_run_on(&self) -> [f64; 2] {
        let of = |c: &Component| if c.is_suspect() { c.scale } else { 1.0 };
        [of(&self.odometry), of(&self.landmarks)]
    }
}

/// A factor's group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Group {
    /// Priors, taken as right.
    Anchor = 0,
    /// The first fitted group.
    First = 1,
    /// The second fitted group.
    Second = 2,
}

/// Which factors form the two fitted groups.
#[derive(Clone, Copy)]
enum Split<'a> {
    /// The odometry factors (betweens), and the landmark observations.
    OdometryAndSensor,
    /// The betweens `picks` does not pick, and those it picks (a graph of betweens).
    Betweens(&'a dyn Fn(usize, &Between) -> bool),
}

impl Split<'_> {
    /// The group of between `b`, the graph's `index`-th.
    fn of(&self, index: usize, b: &Between) -> Group {
        match self {
            Self::Betweens(picks) if picks(index, b) => Group::Second,
            _ => Group::First,
        }
    }
}

/// One factor linearised at the estimates and whitened: `Lᵀ J` and `Lᵀ r` for its
/// information `Ω = L Lᵀ`, padded to 3 rows and 6 columns.
#[derive(Debug, Clone, Copy)]
struct Whitened {
    group: Group,
    rows: usize,
    /// Each variable's first unknown and dimension (an unused one has dimension 0).
    vars: [(usize, usize); 2],
    j: SMatrix<f64, 3, 6>,
    r: Vector3<f64>,
}

impl Whitened {
    /// Whitens residual `r` with Jacobian `j` over `vars` and information `omega`;
    /// `None` when `omega` is not positive definite.
    fn new<const R: usize, const C: usize>(
        group: Group,
        vars: [(usize, usize); 2],
        (r, j): (&SVector<f64, R>, &SMatrix<f64, R, C>),
        omega: &SMatrix<f64, R, R>,
    ) -> Option<Self> {
        let lt = omega.cholesky()?.l().transpose();
        let mut out = Self {
            group,
            rows: R,
            vars,
            j: SMatrix::zeros(),
            r: Vector3::zeros(),
        };
        out.j.fixed_view_mut::<R, C>(0, 0).copy_from(&(lt * j));
        out.r.fixed_rows_mut::<R>(0).copy_from(&(lt * r));
        Some(out)
    }

    /// `J̃ v`, `v` over all unknowns.
    fn apply(&self, v: impl Fn(usize) -> f64) -> Vector3<f64> {
        let mut out = Vector3::zeros();
        let mut col = 0;
        for &(start, dim) in &self.vars {
            for d in 0..dim {
                out += self.j.column(col + d) * v(start + d);
            }
            col += dim;
        }
        out
    }

    /// Adds `J̃ᵀ z` to `b`.
    fn add_transposed(&self, z: &Vector3<f64>, mut b: impl FnMut(usize, f64)) {
        let mut col = 0;
        for &(start, dim) in &self.vars {
            for d in 0..dim {
                b(start + d, self.j.column(col + d).dot(z));
            }
            col += dim;
        }
    }
}

/// One round's sums: `Ω_k`, `n_k`, `tr(N⁻¹N_k)` and `tr(N⁻¹N_k N⁻¹N_j)` (anchor,
/// odometry, landmarks; `k` the fitted groups).
#[derive(Debug, Default)]
struct Traces {
    chi2: [f64; 3],
    residuals: [usize; 3],
    own: [f64; 2],
    cross: [[f64; 3]; 2],
}

impl Graph {
    /// The variance components of the graph, solved from its current estimates (the
    /// estimates themselves are left as they are); see the module documentation.
    ///
    /// # Errors
    /// When the graph has no odometry factor or no landmark observation, or a solve or
    /// factorisation fails.
    ///
    /// # Performance
    /// Up to five plain solves of a copy of the graph from the estimates (a converged
    /// solution needs few iterations), each with one factorisation and 32 solves for the
    /// traces.
    pub fn variance_components(&self) -> Result<VarianceComponents> {
        if self.betweens.is_empty() || self.sightings.len() + self.offsets.len() == 0 {
            return Err(Error::InvalidInput {
                what: "variance components",
                reason: "the graph needs odometry factors and landmark observations".into(),
            });
        }
        let ([odometry, landmarks], rounds) = self.components(Split::OdometryAndSensor)?;
        Ok(VarianceComponents {
            odometry,
            landmarks,
            rounds,
        })
    }

    /// The variance components of a graph of betweens (a pose graph): `[0]` of those
    /// `picks` does not pick, `[1]` of those it picks (the consecutive constraints and
    /// the loop closures, say); `picks` is given each between's index and the between.
    /// A between with zero information (a loop closure left out) counts in neither.
    ///
    /// # Errors
    /// When the graph holds landmark observations, either group is empty, or a solve or
    /// factorisation fails.
    ///
    /// # Performance
    /// As [`Graph::variance_components`].
    pub fn between_components(
        &self,
        picks: &dyn Fn(usize, &Between) -> bool,
    ) -> Result<[Component; 2]> {
        let picked = (self.betweens.iter().enumerate())
            .filter(|(i, b)| picks(*i, b))
            .count();
        if self.sightings.len() + self.offsets.len() > 0
            || picked == 0
            || picked == self.betweens.len()
        {
            return Err(Error::InvalidInput {
                what: "variance components",
                reason: "a graph of betweens only, with betweens in both groups".into(),
            });
        }
        self.components(Split::Betweens(picks))
            .map(|(components, _)| components)
    }

    /// The two groups' components of `split`, and the rounds run.
    fn components(&self, split: Split<'_>) -> Result<([Component; 2], usize)> {
        let mut graph = self.clone();
        // A graph of betweens is solved as a pose graph (a long chain converges slowly
        // under Marquardt's damping).
        let plain = SolveOptions {
            kernel: Kernel::None,
            ..match split {
                Split::OdometryAndSensor => SolveOptions::default(),
                Split::Betweens(_) => SolveOptions::pose_graph(),
            }
        };
        let mut scales = [1.0; 2];
        let mut rounds = 0;
        loop {
            graph.solve(&plain)?;
            rounds += 1;
            let traces = graph.traces(split)?;
            let step = traces.helmert(&scales);
            let settled = step.iter().all(|s| (s - 1.0).abs() < SETTLED);
            if settled || rounds == ROUNDS {
                let component = |k: usize| Component {
                    residuals: traces.residuals[k + 1],
                    redundancy: traces.residuals[k + 1] as f64 - traces.own[k],
                    scale: scales[k] * step[k],
                };
                return Ok(([component(0), component(1)], rounds));
            }
            graph.reweight(split, &step);
            scales = [0, 1].map(|k| scales[k] * step[k]);
        }
    }

    /// Divides the first group's information by `step[0]` and the second's by
    /// `step[1]`.
    fn reweight(&mut self, split: Split<'_>, step: &[f64; 2]) {
        for (i, b) in self.betweens.iter_mut().enumerate() {
            b.information /= step[split.of(i, b) as usize - 1];
        }
        for s in &mut self.sightings {
            s.information /= step[1];
        }
        for o in &mut self.offsets {
            o.information /= step[1];
        }
    }

    /// Every factor linearised at the estimates and whitened (a sighting of a landmark on
    /// its pose, which has no bearing, left out).
    fn whitened(&self, split: Split<'_>) -> Vec<Whitened> {
        let np = self.poses.len();
        let pose = |i: usize| (3 * i, 3);
        let landmark = |k: usize| (3 * np + 2 * k, 2);
        let none = (0, 0);
        let mut out = Vec::new();
        for p in &self.priors {
            if let Linearised::Prior { r, j } = p.linearise(&self.poses[p.pose]) {
                let vars = [pose(p.pose), none];
                out.extend(Whitened::new(Group::Anchor, vars, (&r, &j), &p.information));
            }
        }
        for p in &self.landmark_priors {
            let r = self.landmarks[p.landmark] - p.mean;
            let (vars, j) = ([landmark(p.landmark), none], nalgebra::Matrix2::identity());
            out.extend(Whitened::new(Group::Anchor, vars, (&r, &j), &p.information));
        }
        for (i, b) in self.betweens.iter().enumerate() {
            let (r, j_from, j_to) = b.jacobians(&self.poses[b.from], &self.poses[b.to]);
            let factor = if b.from == b.to {
                let j: Matrix3<f64> = j_from + j_to;
                Whitened::new(
                    split.of(i, b),
                    [pose(b.from), none],
                    (&r, &j),
                    &b.information,
                )
            } else {
                let j: SMatrix<f64, 3, 6> = side_by_side(&j_from, &j_to);
                let vars = [pose(b.from), pose(b.to)];
                Whitened::new(split.of(i, b), vars, (&r, &j), &b.information)
            };
            out.extend(factor);
        }
        for s in &self.sightings {
            let (p, m) = (&self.poses[s.pose], &self.landmarks[s.landmark]);
            if let Some(Linearised::Sighting {
                r,
                j_pose,
                j_landmark,
            }) = s.linearise(p, m)
            {
                let j: SMatrix<f64, 2, 5> = side_by_side(&j_pose, &j_landmark);
                let vars = [pose(s.pose), landmark(s.landmark)];
                out.extend(Whitened::new(Group::Second, vars, (&r, &j), &s.information));
            }
        }
        for o in &self.offsets {
            let (p, m) = (&self.poses[o.pose], &self.landmarks[o.landmark]);
            let (r, j_pose, j_landmark) = o.jacobians(p, m);
            let j: SMatrix<f64, 2, 5> = side_by_side(&j_pose, &j_landmark);
            let vars = [pose(o.pose), landmark(o.landmark)];
            out.extend(Whitened::new(Group::Second, vars, (&r, &j), &o.information));
        }
        out
    }

    /// The sums of one round at the current estimates and weights.
    fn traces(&self, split: Split<'_>) -> Result<Traces> {
        let factors = self.whitened(split);
        let mut system = System::new(self)?;
        system.linearise(self, Kernel::None, PoseUpdate::Additive);
        system.factorise()?;
        let n = self.unknowns();
        let mut rng = crate::rng::seeded(PROBE_SEED);
        // Columns 2p and 2p + 1: probe p's b for the odometry and for the landmarks.
        let mut b = Mat::<f64>::zeros(n, 2 * PROBES);
        let mut traces = Traces::default();
        for f in &factors {
            traces.chi2[f.group as usize] += f.r.norm_squared();
            traces.residuals[f.group as usize] += f.rows;
        }
        for p in 0..PROBES {
            for f in &factors {
                let z = Vector3::from_fn(|i, _| match (i < f.rows, rng.random::<bool>()) {
                    (false, _) => 0.0,
                    (true, true) => 1.0,
                    (true, false) => -1.0,
                });
                if let Some(k) = (f.group as usize).checked_sub(1) {
                    f.add_transposed(&z, |i, v| b[(i, 2 * p + k)] += v);
                }
            }
        }
        let mut y = b.clone();
        system.solve_in_place(y.as_mut());
        for p in 0..PROBES {
            for k in 0..2 {
                let c = 2 * p + k;
                traces.own[k] += (0..n).map(|i| b[(i, c)] * y[(i, c)]).sum::<f64>();
                for f in &factors {
                    traces.cross[k][f.group as usize] += f.apply(|i| y[(i, c)]).norm_squared();
                }
            }
        }
        let probes = PROBES as f64;
        traces.own = traces.own.map(|t| t / probes);
        traces.cross = traces.cross.map(|row| row.map(|t| t / probes));
        Ok(traces)
    }
}

impl Traces {
    /// Helmert's estimate of the factors against the current weights (the odometry's
    /// and the landmarks'), each kept so that `scales × step` stays within the noise
    /// fit's bounds.
    fn helmert(&self, scales: &[f64; 2]) -> [f64; 2] {
        // E[Ω_k] − anchor's share = Σ_j a_kj θ_j, with the cross terms made symmetric.
        let cross = 0.5 * (self.cross[0][2] + self.cross[1][1]);
        let diagonal =
            |k: usize| self.residuals[k + 1] as f64 - 2.0 * self.own[k] + self.cross[k][k + 1];
        let (a, d) = ((diagonal(0), cross), (cross, diagonal(1)));
        let rhs = [0, 1].map(|k| self.chi2[k + 1] - self.cross[k][0]);
        let det = a.0 * d.1 - a.1 * d.0;
        let theta = if det > 0.0 && det.is_finite() {
            [
                (d.1 * rhs[0] - a.1 * rhs[1]) / det,
                (a.0 * rhs[1] - d.0 * rhs[0]) / det,
            ]
        } else {
            // Degenerate: each group alone, without the other's share.
            [rhs[0] / a.0, rhs[1] / d.1]
        };
        [0, 1].map(|k| {
            let step = if theta[k].is_finite() { theta[k] } else { 1.0 };
            (scales[k] * step).clamp(MIN_SCALE, MAX_SCALE) / scales[k]
        })
    }
}

/// The columns of `a` followed by those of `b` (`C` = `A` + `B`).
fn side_by_side<const R: usize, const A: usize, const B: usize, const C: usize>(
    a: &SMatrix<f64, R, A>,
    b: &SMatrix<f64, R, B>,
) -> SMatrix<f64, R, C> {
    const { assert!(A + B == C) };
    SMatrix::from_fn(|i, c| if c < A { a[(i, c)] } else { b[(i, c - A)] })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::{OdometryIntegrator, Prior};
    use crate::motion::{Control, MotionModel, Unicycle};
    use crate::observation::{Observation, measure};
    use crate::pose::Pose2;
    use nalgebra::{Matrix2, Vector2};
    use rand_distr::{Distribution, StandardNormal};

    /// A unicycle on a circle among twelve landmarks, its controls and observations drawn
    /// with σ's `odometry` and `sensor` times the model's, solved from dead reckoning.
    fn solved(odometry: f64, sensor: f64, seed: u64) -> Graph {
        let mut rng = crate::rng::seeded(seed);
        let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
        let motion = MotionModel::Unicycle(Unicycle {
            sigma_v: 0.1,
            sigma_omega: 0.05,
        });
        let (sr, sb) = (0.1, 0.02);
        let noise = Matrix2::from_diagonal(&Vector2::new(sr * sr, sb * sb));
        let mut graph = Graph::default();
        for k in 0..12 {
            let a = f64::from(k) * std::f64::consts::TAU / 12.0;
            graph.add_landmark(Vector2::new(14.0 * a.cos(), 10.0 + 14.0 * a.sin()));
        }
        let landmarks = graph.landmarks.clone();
        graph.add_pose(Pose2::default());
        graph.priors.push(Prior {
            pose: 0,
            mean: Pose2::default(),
            information: Matrix3::identity() * 1e8,
        });
        let mut integrator = OdometryIntegrator::new(motion.clone(), Matrix3::identity() * 1e-10);
        let (mut truth, mut dead) = (Pose2::default(), Pose2::default());
        let control = Control {
            v: 1.0,
            omega: 0.1,
            ..Control::ZERO
        };
        for scan in 1..=300 {
            for _ in 0..5 {
                truth = motion.propagate(&truth, &control, 0.1);
                let measured = Control {
                    v: control.v + odometry * 0.1 * normal(),
                    omega: control.omega + odometry * 0.05 * normal(),
                    ..Control::ZERO
                };
                integrator.add(&measured, 0.1);
                dead = motion.propagate(&dead, &measured, 0.1);
            }
            let i = graph.add_pose(dead);
            graph
                .betweens
                .push(integrator.take(scan - 1, scan).unwrap());
            for (k, m) in landmarks.iter().enumerate() {
                let z = measure(&truth, m);
                if z[0] < 12.0 {
                    let obs = Observation {
                        range: z[0] + sensor * sr * normal(),
                        bearing: z[1] + sensor * sb * normal(),
                        id: None,
                    };
                    graph.add_sighting(i, k, &obs, &noise).unwrap();
                }
            }
        }
        graph.solve(&SolveOptions::default()).unwrap();
        graph
    }

    /// Whether `fitted` (a variance factor) is within 30 % of `truth` in σ.
    fn within_30_percent(fitted: f64, truth: f64) -> bool {
        ((fitted / truth).sqrt() - 1.0).abs() < 0.3
    }

    #[test]
    fn the_components_find_the_source_whose_noise_is_too_small() {
        for (odometry, sensor, blames_odometry) in [
            (1.0, 1.0, None),
            (4.0, 1.0, Some(true)),
            (1.0, 4.0, Some(false)),
        ] {
            let graph = solved(odometry, sensor, 5);
            let fit = graph.variance_components().unwrap();
            let truth = [odometry * odometry, sensor * sensor];
            assert!(
                (fit.scales().iter().zip(truth)).all(|(&f, t)| within_30_percent(f, t)),
                "{odometry} {sensor}: {fit:?}"
            );
            assert_eq!(fit.blames_odometry(), blames_odometry, "{fit:?}");
            assert!(fit.odometry.redundancy > MIN_REDUNDANCY, "{fit:?}");
            assert_eq!(
                graph.variance_components().unwrap(),
                fit,
                "same graph, same fit"
            );
        }
    }

    /// A pose graph: 200 poses round a circle, each tied to the next by its relative
    /// motion with σ's `chain` times the model's, and every fourth to the pose 50 on by
    /// a loop closure with σ's `loops` times the model's; solved from the chain. The
    /// heading noise (0.002 rad a step, 0.014 across a loop closure at 10 m) keeps the
    /// residuals nearly linear in the noise, as Helmert's expectation assumes: at 0.01
    /// rad a step with 5 cm in position, the loop closures' factor comes out 1.7–1.9 for
    /// a true 1.
    fn pose_graph(chain: f64, loops: f64, seed: u64) -> Graph {
        let mut rng = crate::rng::seeded(seed);
        let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
        let (sxy, st) = (0.1, 0.002);
        let information = Matrix3::from_diagonal(&Vector3::new(
            1.0 / (sxy * sxy),
            1.0 / (sxy * sxy),
            1.0 / (st * st),
        ));
        let truth: Vec<Pose2> = (0..200)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 200.0;
                Pose2::new(10.0 * a.sin(), 10.0 - 10.0 * a.cos(), a)
            })
            .collect();
        let mut noisy = |from: usize, to: usize, k: f64| {
            let d = truth[from].inverse().compose(&truth[to]);
            let delta = Pose2::new(
                d.x + k * sxy * normal(),
                d.y + k * sxy * normal(),
                d.theta + k * st * normal(),
            );
            Between {
                from,
                to,
                delta,
                information,
                residual: crate::graph::PoseResidual::Componentwise,
            }
        };
        let mut graph = Graph::default();
        graph.add_pose(truth[0]);
        graph.priors.push(Prior {
            pose: 0,
            mean: truth[0],
            information: Matrix3::identity() * 1e8,
        });
        for i in 1..200 {
            let b = noisy(i - 1, i, chain);
            let start = graph.poses[i - 1].compose(&b.delta);
            graph.add_pose(start);
            graph.betweens.push(b);
        }
        for i in (0..150).step_by(4) {
            let b = noisy(i, i + 50, loops);
            graph.betweens.push(b);
        }
        graph.solve(&SolveOptions::pose_graph()).unwrap();
        graph
    }

    #[test]
    fn the_components_of_a_pose_graph_tell_the_chain_from_the_loop_closures() {
        let is_loop = |_: usize, b: &Between| b.to != b.from + 1;
        for (chain, loops) in [(1.0, 1.0), (2.0, 1.0), (1.0, 2.0)] {
            // Three seeds' residuals pooled: one seed's loop group has a redundancy of
            // about 60 of its 114 residuals, a factor's σ then spreads by ±13 %.
            let fits: Vec<[Component; 2]> = (1..=3)
                .map(|seed| (pose_graph(chain, loops, seed).between_components(&is_loop)).unwrap())
                .collect();
            let mean = |k: usize| fits.iter().map(|f| f[k].scale).sum::<f64>() / 3.0;
            let truth = [chain * chain, loops * loops];
            assert!(
                (0..2).all(|k| within_30_percent(mean(k), truth[k])),
                "{chain} {loops}: {fits:?}"
            );
        }
        let graph = pose_graph(1.0, 1.0, 1);
        assert!(
            graph.between_components(&|_, _| false).is_err(),
            "no loop closure"
        );
        assert!(
            solved(1.0, 1.0, 1).between_components(&is_loop).is_err(),
            "observations"
        );
    }

    #[test]
    fn a_graph_without_odometry_has_no_components() {
        let mut graph = solved(1.0, 1.0, 1);
        graph.betweens.clear();
        assert!(graph.variance_components().is_err());
    }
}
