//! The back-end itself: keyframes in, a pose graph with loop closures, the optimised
//! poses and the map → front-end correction out.

use super::config::LoopClosureConfig;
use super::robust::{self, LoopEdge};
use super::submap::Submap;
use crate::graph::{Between, Component, Graph, MIN_REDUNDANCY, PoseResidual, Prior};
use crate::grid::KeptBeam;
use crate::pose::{Pose2, wrap_angle};
use crate::{Error, Result};
use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector2, Vector3};

/// Information of the prior that fixes the first keyframe where the front end put it.
const ANCHOR_INFORMATION: f64 = 1e8;

/// One keyframe as the front end hands it over.
#[derive(Debug, Clone, PartialEq)]
pub struct Keyframe {
    /// Time of the scan (ns); not decreasing from keyframe to keyframe.
    pub stamp_ns: u64,
    /// The front end's estimate of the base pose at the scan, in the front end's map
    /// frame (m, m, rad).
    pub pose: Pose2,
    /// The front end's covariance of the motion since the previous keyframe, on the map
    /// frame's axes (m², m·rad, rad²); ignored for the first keyframe. Grid FastSLAM's
    /// estimate covariance at a keyframe is of this kind: the particles' spread given
    /// their own maps, which does not grow along the trajectory.
    pub covariance: Matrix3<f64>,
    /// The scan's end points for matching, base frame (m): returns only, sensor mount
    /// applied.
    pub points: Vec<[f64; 2]>,
    /// The scan's beams for the grids (sensor frame), as [`crate::grid::GridConfig::kept_beams`]
    /// gives them.
    pub beams: Vec<KeptBeam>,
    /// The sensor's pose in the base frame (m, m, rad).
    pub sensor: Pose2,
    /// The odometry's account of the motion since the previous keyframe, a constraint
    /// of its own beside the front end's; `None`: none.
    pub odometry: Option<Odometry>,
}

/// The odometry's account of the motion between two keyframes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Odometry {
    /// The front end's pose of the keyframe's scan before the scan was matched: the
    /// previous keyframe's pose moved by the odometry alone (front end's map frame).
    pub predicted: Pose2,
    /// The motion model's covariance of that motion, on the map frame's axes.
    pub covariance: Matrix3<f64>,
}

/// A loop closure: keyframe `keyframe` was found at `pose` in submap `submap`'s frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopClosure {
    /// The matched keyframe's index.
    pub keyframe: usize,
    /// The submap's index.
    pub submap: usize,
    /// The keyframe's base pose in the submap's frame (m, m, rad).
    pub pose: Pose2,
    /// The match's score (mean probability under the points, in (0, 1]).
    pub score: f64,
    /// Root-mean-square distance of the matched points from the base (m): how far a
    /// heading error moves them.
    pub lever: f64,
    /// The match's curvature in position (`JᵀJ` of the refinement's cost, x and y, in
    /// the submap's frame), which shapes the constraint; `None`: held equally in every
    /// direction.
    pub curvature: Option<Matrix2<f64>>,
}

/// What adding a keyframe did.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyframeReport {
    /// The keyframe's index (its pose's index in the graph).
    pub index: usize,
    /// Matches tried: the finished submaps it was matched against, and the earlier
    /// keyframes matched against the submap it finished (a wide match's confirmations
    /// not counted).
    pub searched: usize,
    /// Of those, the finished submaps searched wide as well
    /// ([`LoopClosureConfig::wide_search_every`]).
    pub wide: usize,
    /// Of the matches, those the wide search found (with their confirmations).
    pub wide_found: usize,
    /// The matches that reached `min_score` (`wide_min_score` for a wide one), now
    /// loop-closure constraints: its own, then the earlier keyframes' in the submap it
    /// finished.
    pub closures: Vec<LoopClosure>,
    /// A solve is due ([`PoseGraphMapper::solve_due`]).
    pub solve_due: bool,
    /// Wall time of the matching (s).
    pub match_seconds: f64,
}

/// What a solve did, with its result.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Every keyframe's optimised pose, in keyframe order (map frame).
    pub poses: Vec<Pose2>,
    /// The newest keyframe's optimised pose composed with the inverse of the front end's
    /// pose of it: the map → front-end-map correction ([`PoseGraphMapper::correction`]).
    pub correction: Pose2,
    /// Loop closures in the graph.
    pub closures: usize,
    /// Of which the solution uses (the others failed the χ² gate).
    pub accepted: usize,
    /// χ² of every constraint at the solution (loop closures with their final weights)
    /// per degree of freedom: about 1 when the front end's covariances are right.
    pub chi2_per_dof: f64,
    /// Reweighting rounds run.
    pub rounds: usize,
    /// Levenberg–Marquardt iterations over every round.
    pub iterations: usize,
    /// Wall time (s).
    pub seconds: f64,
}

/// The odometry constraints' weight fitted to a solved graph
/// ([`PoseGraphMapper::fit_odometry_weight`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryWeight {
    /// The odometry constraints' variance component.
    pub odometry: Component,
    /// The other constraints' (the front end's steps, the loop closures in use).
    pub rest: Component,
    /// The factor their information was multiplied by: `rest.scale / odometry.scale`.
    pub weight: f64,
}

/// What became of the odometry constraints' weight at the end of the data
/// ([`PoseGraphMapper::finish`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OdometryFit {
    /// `fit_odometry_at_end` is off: the model's weight.
    Off,
    /// Not fitted, the model's weight: no odometry constraints or loop closures, a
    /// redundancy under [`MIN_REDUNDANCY`], or components that cannot be computed.
    Unfitted,
    /// Weighted by its fit before the last solve.
    Weighted(OdometryWeight),
}

/// What [`PoseGraphMapper::finish`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct Finished {
    /// The solves made, in order: one over the keyframes since the previous solve (when
    /// any came), then one with the odometry's fitted weight (when it was fitted).
    pub solutions: Vec<Solution>,
    /// The odometry constraints' weight.
    pub odometry: OdometryFit,
    /// The solve that failed, which ended the sequence; the solutions before it stand.
    pub failed: Option<Error>,
}

/// A keyframe as kept: what the graph, the submaps and the rendering need of it.
#[derive(Debug, Clone)]
pub(crate) struct Kept {
    pub(crate) stamp_ns: u64,
    pub(crate) front_end: Pose2,
    pub(crate) sensor: Pose2,
    pub(crate) beams: Vec<KeptBeam>,
    /// The points to match, when there are enough ([`PoseGraphMapper::matchable`]).
    pub(crate) matchable: Option<Matchable>,
}

/// A keyframe's scan as it is matched: its points within `max_range` of the base (base
/// frame) and their root-mean-square distance from it (m).
#[derive(Debug, Clone)]
pub(crate) struct Matchable {
    pub(crate) points: Vec<[f64; 2]>,
    pub(crate) lever: f64,
}

/// The loop-closing pose-graph back-end for grid SLAM; see the module documentation.
#[derive(Debug, Clone)]
pub struct PoseGraphMapper {
    pub(crate) config: LoopClosureConfig,
    pub(crate) graph: Graph,
    pub(crate) keyframes: Vec<Kept>,
    /// Per keyframe, summed from the first over each step's front-end covariance plus the
    /// search window's floor (`window_floor_xy`, `window_floor_theta`): the largest
    /// position variance (m²), the heading variance (rad²) and the travelled distance (m).
    /// The search windows are `3σ` of it.
    pub(crate) accumulated: Vec<[f64; 3]>,
    pub(crate) submaps: Vec<Submap>,
    pub(crate) loops: Vec<LoopEdge>,
    correction: Pose2,
    since_solve: usize,
    pending: usize,
    /// The odometry constraints' indices among the graph's betweens, ascending.
    odometry_edges: Vec<usize>,
}

impl PoseGraphMapper {
    /// An empty back-end.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad `config`.
    pub fn new(config: LoopClosureConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            graph: Graph::default(),
            keyframes: Vec::new(),
            accumulated: Vec::new(),
            submaps: Vec::new(),
            loops: Vec::new(),
            correction: Pose2::default(),
            since_solve: 0,
            pending: 0,
            odometry_edges: Vec::new(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &LoopClosureConfig {
        &self.config
    }

    /// Adds a keyframe: a pose in the graph tied to the previous one by the front end's
    /// relative motion, its scan inserted into the active submap, and (every
    /// `search_every`-th keyframe) its scan matched against the finished submaps nearby,
    /// and every `wide_search_every`-th while no long loop is closing, in the wide window
    /// (`search.rs`), each accepted match becoming a loop-closure constraint. Does not
    /// solve.
    ///
    /// The consecutive constraint is `prev⁻¹ ∘ pose` of the front end's poses with
    /// covariance `Rᵀ Σ R + diag(f_xy², f_xy², f_θ²)`: the front end's covariance turned
    /// onto the previous keyframe's axes plus the chain's floor (`between_floor_xy`,
    /// `between_floor_theta`), so it is never singular nor tighter than the floor. The
    /// search window accumulates the same step with its own, wider floor
    /// (`window_floor_xy`, `window_floor_theta`).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a non-finite pose, covariance, point, beam or sensor
    /// pose, or a stamp before the previous keyframe's; nothing is added then.
    ///
    /// # Performance
    /// One insertion (`O(beams · range / resolution)`), a branch-and-bound match per
    /// finished submap within `max_search_distance` (a few ms each, in parallel), one
    /// per submap beyond the window's clamps in the larger wide window when the wide
    /// search is due, and `O(cells · depth)` when the keyframe finishes its submap.
    pub fn add_keyframe(&mut self, keyframe: Keyframe) -> Result<KeyframeReport> {
        self.check(&keyframe)?;
        let index = self.keyframes.len();
        match self.keyframes.last() {
            None => {
                self.graph.add_pose(keyframe.pose);
                self.graph.priors.push(Prior {
                    pose: 0,
                    mean: keyframe.pose,
                    information: Matrix3::identity() * ANCHOR_INFORMATION,
                });
                self.accumulated.push([0.0; 3]);
            }
            Some(previous) => {
                let delta = previous.front_end.inverse().compose(&keyframe.pose);
                let theta = previous.front_end.theta;
                let covariance = floored(&keyframe.covariance, theta, self.config.chain_floor());
                let information = covariance.cholesky().map(|c| c.inverse()).ok_or_else(|| {
                    Error::InvalidInput {
                        what: "keyframe covariance",
                        reason: format!("not positive semidefinite: {:?}", keyframe.covariance),
                    }
                })?;
                let start = self.graph.poses[index - 1].compose(&delta);
                self.graph.add_pose(start);
                self.graph.betweens.push(Between {
                    from: index - 1,
                    to: index,
                    delta,
                    information,
                    residual: PoseResidual::Componentwise,
                });
                if let Some(between) = self.odometry_between(index, &delta, &covariance, &keyframe)
                {
                    self.odometry_edges.push(self.graph.betweens.len());
                    self.graph.betweens.push(between);
                }
                let window = floored(&keyframe.covariance, theta, self.config.window_floor());
                let xy = SymmetricEigen::new(window.fixed_view::<2, 2>(0, 0).into_owned());
                let before = self.accumulated[index - 1];
                self.accumulated.push([
                    before[0] + xy.eigenvalues.max(),
                    before[1] + window[(2, 2)],
                    before[2] + delta.x.hypot(delta.y),
                ]);
            }
        }
        let matchable = self.matchable(&keyframe.points);
        self.keyframes.push(Kept {
            stamp_ns: keyframe.stamp_ns,
            front_end: keyframe.pose,
            sensor: keyframe.sensor,
            beams: keyframe.beams,
            matchable,
        });
        if self.submaps.last().is_none_or(|s| s.grid().is_some()) {
            self.submaps.push(Submap::new(index));
        }
        let active = self.submaps.last_mut().expect("just ensured");
        let local = self.keyframes[active.anchor()]
            .front_end
            .inverse()
            .compose(&keyframe.pose);
        let kept = &self.keyframes[index];
        active.insert(&local, &kept.sensor, &kept.beams, &self.config);
        let started = std::time::Instant::now();
        let (mut searched, mut closures) = if index.is_multiple_of(self.config.search_every) {
            self.search(index)
        } else {
            (0, Vec::new())
        };
        let active = self.submaps.last_mut().expect("just ensured");
        if active.keyframes() >= self.config.keyframes_per_submap {
            active.finish(self.config.depth, self.config.resolution);
            let (earlier, found) = self.search_earlier(self.submaps.len() - 1);
            searched += earlier;
            closures.extend(found);
        }
        let (mut wide, mut wide_found) = (0, 0);
        if self.wide_due(index, &closures) {
            let (submaps, found) = self.search_wide(index);
            (wide, wide_found) = (submaps, found.len());
            searched += submaps;
            closures.extend(found);
        }
        let match_seconds = started.elapsed().as_secs_f64();
        for closure in &closures {
            self.add_loop_closure(*closure)?;
        }
        self.since_solve += 1;
        Ok(KeyframeReport {
            index,
            searched,
            wide,
            wide_found,
            closures,
            solve_due: self.solve_due(),
            match_seconds,
        })
    }

    /// Rejects a keyframe with a non-finite value or a stamp out of order.
    fn check(&self, keyframe: &Keyframe) -> Result<()> {
        let finite = keyframe.pose.is_finite()
            && keyframe.sensor.is_finite()
            && keyframe.covariance.iter().all(|v| v.is_finite())
            && keyframe.points.iter().flatten().all(|v| v.is_finite())
            && (keyframe.beams.iter()).all(|b| b.angle.is_finite() && b.length.is_finite());
        let ordered = self
            .keyframes
            .last()
            .is_none_or(|k| k.stamp_ns <= keyframe.stamp_ns);
        if finite && ordered {
            Ok(())
        } else {
            Err(Error::InvalidInput {
                what: "keyframe",
                reason: format!(
                    "stamp {} after {:?}, pose {:?}, sensor {:?}: a value not finite or a stamp out of order",
                    keyframe.stamp_ns,
                    self.keyframes.last().map(|k| k.stamp_ns),
                    keyframe.pose,
                    keyframe.sensor
                ),
            })
        }
    }

    /// The odometry's constraint from keyframe `index − 1` to `index`, from the
    /// keyframe's odometry ([`Keyframe::odometry`]): its motion `prev⁻¹ ∘ predicted`
    /// with the motion model's covariance turned onto the previous keyframe's axes plus
    /// the chain's floor (`between_floor_xy`, `between_floor_theta`). `None` when the
    /// keyframe has no odometry, `odometry_constraints` is off, or the odometry disagrees
    /// with the front end's motion `delta` (covariance `covariance`, the previous
    /// keyframe's axes) beyond `loop_chi2_gate` in χ² of both covariances — a lag or a
    /// glitch, where the front end believed the scan — or that χ² is not a number (a value
    /// not finite).
    fn odometry_between(
        &self,
        index: usize,
        delta: &Pose2,
        covariance: &Matrix3<f64>,
        keyframe: &Keyframe,
    ) -> Option<Between> {
        let odometry = keyframe
            .odometry
            .filter(|_| self.config.odometry_constraints)?;
        let previous = self.keyframes[index - 1].front_end;
        let moved = previous.inverse().compose(&odometry.predicted);
        let spread = floored(
            &odometry.covariance,
            previous.theta,
            self.config.chain_floor(),
        );
        let disagreement = Vector3::new(
            moved.x - delta.x,
            moved.y - delta.y,
            wrap_angle(moved.theta - delta.theta),
        );
        let chi2 = (covariance + spread)
            .cholesky()?
            .solve(&disagreement)
            .dot(&disagreement);
        let information = spread.cholesky()?.inverse();
        (chi2 <= self.config.loop_chi2_gate).then_some(Between {
            from: index - 1,
            to: index,
            delta: moved,
            information,
            residual: PoseResidual::Componentwise,
        })
    }

    /// Adds a loop-closure constraint from submap `closure.submap`'s first keyframe to
    /// keyframe `closure.keyframe`, measuring `closure.pose`, with the information
    /// `1/σ²` in position in the direction the match holds best, shaped by the match's
    /// curvature in the others (`shaped`, at least `loop_shape_floor` of it), and `1/σ_θ²`
    /// in heading: `σ = loop_sigma_cells · resolution / score`, `σ_θ = σ / max(lever,
    /// 1 m)`. The matcher adds its own; this is for others (a place recogniser, a test).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for an unknown keyframe or submap, a keyframe that is the
    /// submap's own first one, a non-finite pose, a score outside (0, 1] or a lever that
    /// is not finite and positive.
    pub fn add_loop_closure(&mut self, closure: LoopClosure) -> Result<()> {
        let anchor = self.submaps.get(closure.submap).map(Submap::anchor);
        let valid = anchor.is_some_and(|a| a != closure.keyframe)
            && closure.keyframe < self.keyframes.len()
            && closure.pose.is_finite()
            && closure.score > 0.0
            && closure.score <= 1.0
            && closure.lever.is_finite()
            && closure.lever > 0.0;
        let Some(anchor) = anchor.filter(|_| valid) else {
            return Err(Error::InvalidInput {
                what: "loop closure",
                reason: format!(
                    "{closure:?} with {} keyframes and {} submaps",
                    self.keyframes.len(),
                    self.submaps.len()
                ),
            });
        };
        let sigma = self.config.loop_sigma_cells * self.config.resolution / closure.score;
        let sigma_theta = sigma / closure.lever.max(1.0);
        let mut information =
            Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 1.0 / (sigma_theta * sigma_theta)));
        let shape = closure.curvature.map_or_else(Matrix2::identity, |c| {
            shaped(&c, self.config.loop_shape_floor)
        });
        information
            .fixed_view_mut::<2, 2>(0, 0)
            .copy_from(&(shape / (sigma * sigma)));
        self.loops.push(LoopEdge {
            closure,
            weight: 1.0,
            robust_weight: 1.0,
            chi2: 0.0,
            between: self.graph.betweens.len(),
            information,
            found_at: self.keyframes.len() - 1,
        });
        self.graph.betweens.push(Between {
            from: anchor,
            to: closure.keyframe,
            delta: closure.pose,
            information,
            residual: PoseResidual::Componentwise,
        });
        self.pending += 1;
        Ok(())
    }

    /// True when a loop closure came since the last solve, or `solve_every` keyframes did.
    pub fn solve_due(&self) -> bool {
        self.pending > 0 || self.since_solve >= self.config.solve_every
    }

    /// Optimises every keyframe pose: Levenberg–Marquardt on the graph with the loop
    /// closures reweighted between rounds (Cauchy on their χ²) and, once the weights
    /// settle, the closures whose χ² exceeds `loop_chi2_gate` left out of a last solve.
    /// Starts from the current estimates; updates the correction.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] before the first keyframe, or when the solver fails.
    ///
    /// # Performance
    /// Up to `robust_rounds + 1` sparse solves of the whole graph, warm started.
    pub fn solve(&mut self) -> Result<Solution> {
        let started = std::time::Instant::now();
        let Some(newest) = self.keyframes.last() else {
            return Err(Error::InvalidInput {
                what: "loop closure graph",
                reason: "no keyframe yet".into(),
            });
        };
        let newest = newest.front_end;
        let report = robust::solve(&mut self.graph, &mut self.loops, &self.config)?;
        let last = *self.graph.poses.last().expect("one per keyframe");
        self.correction = last.compose(&newest.inverse());
        self.since_solve = 0;
        self.pending = 0;
        Ok(Solution {
            poses: self.graph.poses.clone(),
            correction: self.correction,
            closures: self.loops.len(),
            accepted: report.accepted,
            chi2_per_dof: self.graph.chi2() / self.graph.dof(),
            rounds: report.rounds,
            iterations: report.iterations,
            seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// Weights the odometry constraints by their variance factor against the other
    /// constraints' (Helmert's variance components of the solved graph, two groups: the
    /// odometry constraints, and the front end's steps with the loop closures in use):
    /// their information is multiplied by `θ_rest / θ_odometry`, the other constraints
    /// are left as modelled. Meant for the end of the data, before the last solve; the
    /// weight stays for later solves. `None`, with nothing changed, without odometry
    /// constraints or loop closures, when either group has a redundancy under
    /// [`MIN_REDUNDANCY`], or when the components cannot be computed.
    ///
    /// # Performance
    /// Up to five solves of a copy of the graph, warm started at its solution, each with
    /// one sparse factorisation and 32 solves for the traces: about 0.05 s for two
    /// thousand keyframes.
    pub fn fit_odometry_weight(&mut self) -> Option<OdometryWeight> {
        if self.odometry_edges.is_empty() || self.loops.is_empty() {
            return None;
        }
        let edges = &self.odometry_edges;
        let picks = |i: usize, _: &Between| edges.binary_search(&i).is_ok();
        let [rest, odometry] = self.graph.between_components(&picks).ok()?;
        let weight = rest.scale / odometry.scale;
        let enough = rest.redundancy.min(odometry.redundancy) >= MIN_REDUNDANCY;
        if !(enough && weight.is_finite() && weight > 0.0) {
            return None;
        }
        for &i in &self.odometry_edges {
            self.graph.betweens[i].information *= weight;
        }
        Some(OdometryWeight {
            odometry,
            rest,
            weight,
        })
    }

    /// The end of the data: a solve over the keyframes since the previous solve (its
    /// robust rounds judge the newest closures), then, when `fit_odometry_at_end` asks
    /// for it, the odometry constraints weighted by their fit to that solution
    /// ([`fit_odometry_weight`](Self::fit_odometry_weight)) and the last solve. A solve
    /// that fails ends the sequence ([`Finished::failed`]): the solutions before it are
    /// returned, the graph keeps their poses, and a weight fitted before it stays.
    ///
    /// # Performance
    /// Up to two solves and one fit.
    pub fn finish(&mut self) -> Finished {
        let mut finished = Finished {
            solutions: Vec::new(),
            odometry: OdometryFit::Off,
            failed: None,
        };
        if self.since_solve > 0 || self.pending > 0 {
            match self.solve() {
                Ok(solution) => finished.solutions.push(solution),
                Err(e) => {
                    finished.failed = Some(e);
                    return finished;
                }
            }
        }
        if !self.config.fit_odometry_at_end {
            return finished;
        }
        let Some(fit) = self.fit_odometry_weight() else {
            finished.odometry = OdometryFit::Unfitted;
            return finished;
        };
        finished.odometry = OdometryFit::Weighted(fit);
        match self.solve() {
            Ok(solution) => finished.solutions.push(solution),
            Err(e) => finished.failed = Some(e),
        }
        finished
    }

    /// The map → front-end-map correction of the last solve (the identity before one):
    /// the real-time pose in the map frame is `correction ∘ front-end pose`.
    pub fn correction(&self) -> Pose2 {
        self.correction
    }

    /// `correction ∘ front_end`: a front-end pose in the back-end's map frame.
    pub fn corrected(&self, front_end: &Pose2) -> Pose2 {
        self.correction.compose(front_end)
    }

    /// Every keyframe's current pose estimate (map frame): the last solution, and the
    /// keyframes added since placed by their consecutive constraints.
    pub fn poses(&self) -> &[Pose2] {
        &self.graph.poses
    }

    /// Every keyframe's stamp (ns), in keyframe order.
    pub fn stamps(&self) -> Vec<u64> {
        self.keyframes.iter().map(|k| k.stamp_ns).collect()
    }

    /// Keyframes added.
    pub fn keyframes(&self) -> usize {
        self.keyframes.len()
    }

    /// The submaps, the active one last.
    pub fn submaps(&self) -> &[Submap] {
        &self.submaps
    }

    /// The loop closures with their state after the last solve.
    pub fn loop_edges(&self) -> &[LoopEdge] {
        &self.loops
    }

    /// The pose graph (keyframe poses, priors, consecutive and loop constraints with the
    /// loop constraints' current weights).
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// Bytes the submaps' grids and the kept beams and scan points take.
    pub fn bytes(&self) -> usize {
        let scans: usize = (self.keyframes.iter())
            .map(|k| {
                let points = k.matchable.as_ref().map_or(0, |m| m.points.len());
                k.beams.len() * std::mem::size_of::<KeptBeam>()
                    + points * std::mem::size_of::<[f64; 2]>()
            })
            .sum();
        self.submaps.iter().map(Submap::bytes).sum::<usize>() + scans
    }
}

/// The shape of a loop closure's position information from its match's `curvature`:
/// the curvature over its largest eigenvalue, every eigenvalue raised to at least `floor`
/// — 1 in the best-held direction, less where the match is flat (along a corridor). The
/// identity when the curvature holds nothing or is not finite, and for a floor of 1.
fn shaped(curvature: &Matrix2<f64>, floor: f64) -> Matrix2<f64> {
    if floor >= 1.0 || !curvature.iter().all(|v| v.is_finite()) {
        return Matrix2::identity();
    }
    let eigen = SymmetricEigen::new(0.5 * (curvature + curvature.transpose()));
    let largest = eigen.eigenvalues.max();
    if largest <= 0.0 {
        return Matrix2::identity();
    }
    let scaled = eigen.eigenvalues.map(|l| (l / largest).max(floor));
    eigen.eigenvectors
        * Matrix2::from_diagonal(&Vector2::new(scaled[0], scaled[1]))
        * eigen.eigenvectors.transpose()
}

/// `covariance` (map axes) turned onto the axes of a keyframe heading `theta`, made
/// symmetric, plus the floor `(σ_xy, σ_θ)` in quadrature: a consecutive constraint's
/// covariance, or a step of the search window's accumulated uncertainty.
fn floored(covariance: &Matrix3<f64>, theta: f64, (fxy, ft): (f64, f64)) -> Matrix3<f64> {
    let (s, c) = theta.sin_cos();
    // Map axes → the previous keyframe's axes.
    let r = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
    let turned = r * covariance * r.transpose();
    let symmetric = 0.5 * (turned + turned.transpose());
    symmetric + Matrix3::from_diagonal(&Vector3::new(fxy * fxy, fxy * fxy, ft * ft))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closure_keeps_its_information_where_the_match_is_held_and_loses_it_where_flat() {
        // A match held 100 times more sharply across a corridor running at 30°.
        let (s, c) = 30f64.to_radians().sin_cos();
        let along = Vector2::new(c, s);
        let across = Vector2::new(-s, c);
        let curvature = along * along.transpose() + 100.0 * across * across.transpose();
        let shape = shaped(&curvature, 0.001);
        assert!(((shape * across).norm() - 1.0).abs() < 1e-12, "{shape}");
        assert!(((shape * along).norm() - 0.01).abs() < 1e-12, "{shape}");
        // The floor bounds how loose the flat direction gets.
        let floored = shaped(&curvature, 0.1);
        assert!(((floored * along).norm() - 0.1).abs() < 1e-12, "{floored}");
        // Nothing held, nothing known, or a floor of 1: the same in every direction.
        assert_eq!(shaped(&Matrix2::zeros(), 0.01), Matrix2::identity());
        let unknown = Matrix2::new(f64::NAN, 0.0, 0.0, 1.0);
        assert_eq!(shaped(&unknown, 0.01), Matrix2::identity());
        assert_eq!(shaped(&curvature, 1.0), Matrix2::identity());
    }

    /// A keyframe at `pose` with the odometry's end of the stretch at `predicted`, both
    /// with covariance diag(σ², σ², σ²) before the floor.
    fn keyframe(stamp_ns: u64, pose: Pose2, predicted: Pose2, sigma: f64) -> Keyframe {
        let covariance = Matrix3::identity() * sigma * sigma;
        Keyframe {
            stamp_ns,
            pose,
            covariance,
            points: Vec::new(),
            beams: Vec::new(),
            sensor: Pose2::default(),
            odometry: Some(Odometry {
                predicted,
                covariance,
            }),
        }
    }

    #[test]
    fn the_odometry_ties_consecutive_keyframes_unless_it_disagrees_with_the_front_end() {
        let run = |odometry_x: f64, enabled: bool| {
            let config = LoopClosureConfig {
                odometry_constraints: enabled,
                ..LoopClosureConfig::default()
            };
            let mut mapper = PoseGraphMapper::new(config).unwrap();
            let first = Pose2::default();
            mapper
                .add_keyframe(keyframe(0, first, first, 0.05))
                .unwrap();
            let second = keyframe(
                1,
                Pose2::new(0.5, 0.0, 0.0),
                Pose2::new(odometry_x, 0.0, 0.0),
                0.05,
            );
            mapper.add_keyframe(second).unwrap();
            let solution = mapper.solve().unwrap();
            (mapper.graph().betweens.len(), solution.poses[1])
        };
        // Odometry 4 cm longer than the match, both held alike: the solution halves it.
        let (constraints, pose) = run(0.54, true);
        assert_eq!(constraints, 2);
        assert!((pose.x - 0.52).abs() < 1e-6, "{pose:?}");
        // Switched off, or a glitch of 1 m (χ² far beyond the gate): the match alone.
        for (odometry_x, enabled) in [(0.54, false), (1.5, true)] {
            let (constraints, pose) = run(odometry_x, enabled);
            assert_eq!(constraints, 1, "{odometry_x} {enabled}");
            assert!((pose.x - 0.5).abs() < 1e-6, "{pose:?}");
        }
    }
}
