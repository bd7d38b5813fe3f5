//! Branch-and-bound correlative scan matching over `(x, y, θ)` in a search window (Olson
//! 2009, "Real-time correlative scan matching"; Hess, Kohler, Rapp & Andor 2016,
//! "Real-time loop closure in 2D LIDAR SLAM").
//!
//! The score of a pose is the mean probability of the submap cells under the scan's
//! points. Headings are searched on a grid whose step moves the farthest point by about
//! one cell, `δθ = acos(1 − r² / 2 d²)`; for each heading the points are rotated once
//! and cast to cells, and translations are whole cells. Branch and bound starts from
//! blocks of `2^(depth−1)` translations per heading, scored on the coarsest max-pooled
//! grid (an upper bound of every translation in the block), visits them best first and
//! splits a block into its four children one level finer, depth first; a block whose
//! bound does not beat the best full-resolution score found so far (or `min_score`) is
//! cut with everything below it. The answer is the exhaustive search's best score, found
//! by scoring a small part of the window. A local refinement then moves the pose off the
//! cell lattice ([`super::refine`]).

use super::probability::{Cast, FULL};
use super::pyramid::MatchGrid;
use super::refine::{curvature, refine};
use crate::pose::Pose2;
use nalgebra::Matrix3;

/// Half widths of a search window around an initial pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchWindow {
    /// Translations within `±linear` along x and along y (m).
    pub linear: f64,
    /// Headings within `±angular` (rad).
    pub angular: f64,
}

/// A Gaussian pull towards the initial pose, for matching where the scan may not fix every
/// direction (a featureless corridor): a pose `Δ` from the initial one scores
/// `cost · ((|Δt| / sigma_linear)² + (Δθ / sigma_angular)²)` less, as a fraction of a
/// full score (every point on a cell of probability 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchPrior {
    /// The translation one unit of `cost` stands for (m).
    pub sigma_linear: f64,
    /// The rotation one unit of `cost` stands for (rad).
    pub sigma_angular: f64,
    /// The share of a full score one σ² costs.
    pub cost: f64,
}

/// The outcome of a match.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanMatch {
    /// The scan's pose in the submap's frame after the local refinement.
    pub pose: Pose2,
    /// The best pose on the search lattice.
    pub coarse: Pose2,
    /// The mean probability under the points at `coarse` (in [0, 1]).
    pub score: f64,
    /// The heading step of the search lattice (rad).
    pub angular_step: f64,
    /// The refinement cost's curvature `JᵀJ` at `pose` (variables x, y, θ): how sharply
    /// the match is held in each direction.
    pub curvature: Matrix3<f64>,
}

/// A search node: heading index, translation offset (cells) and its score or bound
/// (summed cell values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Candidate {
    angle: usize,
    dx: i32,
    dy: i32,
    score: u32,
}

/// The scan cast to cells once per heading of the search lattice.
struct Lattice {
    initial: Pose2,
    resolution: f64,
    /// Heading of each lattice step (rad, submap frame).
    headings: Vec<f64>,
    /// The points' cells at each heading, at the initial translation.
    cells: Vec<Cast>,
    /// Translations within `±reach` cells each way.
    reach: i32,
    angular_step: f64,
    /// The prior's cost (summed-score units) per squared cell of translation and per
    /// squared heading step; zero without a prior.
    cost_per_cell: f64,
    cost_per_step: f64,
}

impl Lattice {
    fn new(
        grid: &MatchGrid,
        points: &[[f64; 2]],
        initial: &Pose2,
        window: &SearchWindow,
        prior: Option<&MatchPrior>,
    ) -> Self {
        let p = grid.probabilities();
        let resolution = p.resolution();
        let farthest = points
            .iter()
            .map(|q| q[0].hypot(q[1]))
            .fold(resolution, f64::max);
        let ratio = resolution * resolution / (2.0 * farthest * farthest);
        let angular_step = (1.0 - ratio).clamp(-1.0, 1.0).acos().max(1e-4);
        let steps = (window.angular / angular_step).ceil() as i64;
        let headings: Vec<f64> = (-steps..=steps)
            .map(|k| initial.theta + k as f64 * angular_step)
            .collect();
        let cells = headings
            .iter()
            .map(|&theta| {
                let (s, c) = theta.sin_cos();
                let cells = points
                    .iter()
                    .map(|q| {
                        let (x, y) = (
                            initial.x + c * q[0] - s * q[1],
                            initial.y + s * q[0] + c * q[1],
                        );
                        let (i, j) = p.cell(x, y);
                        (clamp_i32(i), clamp_i32(j))
                    })
                    .collect();
                Cast::new(cells)
            })
            .collect();
        let full = f64::from(FULL) * points.len() as f64;
        let (cost_per_cell, cost_per_step) = prior.map_or((0.0, 0.0), |p| {
            (
                full * p.cost * (resolution / p.sigma_linear).powi(2),
                full * p.cost * (angular_step / p.sigma_angular).powi(2),
            )
        });
        Self {
            initial: *initial,
            resolution,
            headings,
            cells,
            reach: (window.linear / resolution).ceil() as i32,
            angular_step,
            cost_per_cell,
            cost_per_step,
        }
    }

    /// The node's score at `level` (a bound of the `2^level` translations from `dx`, `dy`
    /// each way): the summed cells less the prior's cost at the node's translation nearest
    /// the initial one.
    fn score(&self, grid: &MatchGrid, level: usize, angle: usize, dx: i32, dy: i32) -> Candidate {
        let sum = grid.sum(level, &self.cells[angle], (dx, dy));
        let nearest = |d: i32| f64::from(0.clamp(d, d + (1 << level) - 1));
        let steps = angle as f64 - (self.headings.len() / 2) as f64;
        let cost = self.cost_per_cell * (nearest(dx).powi(2) + nearest(dy).powi(2))
            + self.cost_per_step * steps * steps;
        Candidate {
            angle,
            dx,
            dy,
            score: sum.saturating_sub(cost.round() as u32),
        }
    }

    fn pose(&self, c: &Candidate) -> Pose2 {
        Pose2::new(
            self.initial.x + f64::from(c.dx) * self.resolution,
            self.initial.y + f64::from(c.dy) * self.resolution,
            self.headings[c.angle],
        )
    }

    /// The smallest summed score that reaches `min_score`.
    fn threshold(&self, points: usize, min_score: f64) -> u32 {
        (min_score.clamp(0.0, 1.0) * f64::from(FULL) * points as f64).ceil() as u32
    }
}

fn clamp_i32(v: i64) -> i32 {
    v.clamp(i64::from(i32::MIN / 4), i64::from(i32::MAX / 4)) as i32
}

/// Best first: higher score, then the lattice order (heading, x, y) for equal ones.
fn sort_best_first(candidates: &mut [Candidate]) {
    candidates.sort_unstable_by(|a, b| {
        (b.score.cmp(&a.score))
            .then(a.angle.cmp(&b.angle))
            .then(a.dx.cmp(&b.dx))
            .then(a.dy.cmp(&b.dy))
    });
}

impl MatchGrid {
    /// The mean probability of the cells under `points` (base frame) at `pose` (submap
    /// frame), in [0, 1]; 0 without points.
    pub fn score(&self, points: &[[f64; 2]], pose: &Pose2) -> f64 {
        if points.is_empty() {
            return 0.0;
        }
        let p = self.probabilities();
        let (s, c) = pose.theta.sin_cos();
        let sum: u32 = points
            .iter()
            .map(|q| {
                let (i, j) = p.cell(pose.x + c * q[0] - s * q[1], pose.y + s * q[0] + c * q[1]);
                u32::from(p.get(i, j))
            })
            .sum();
        f64::from(sum) / (f64::from(FULL) * points.len() as f64)
    }

    /// The best pose of `points` (base frame) in `window` around `initial` (submap
    /// frame) by branch and bound, refined off the lattice; `None` when no pose scores at
    /// least `min_score` or there are no points. See the module documentation.
    ///
    /// # Performance
    /// A few milliseconds for 180–360 points in a ±3 m, ±20° window at 5 cm cells with 7
    /// levels (measured in `tests/loop_closure.rs`); the exhaustive search of the same
    /// lattice costs `(2 reach + 1)² · headings · points` reads.
    pub fn match_scan(
        &self,
        points: &[[f64; 2]],
        initial: &Pose2,
        window: &SearchWindow,
        min_score: f64,
    ) -> Option<ScanMatch> {
        self.match_scan_near(points, initial, window, min_score, None)
    }

    /// [`match_scan`](Self::match_scan) with every pose's score less `prior`'s cost of
    /// its distance from `initial` (none without a prior); `score` is then the scored
    /// pose's, cost included. With a prior, `initial` wins ties.
    pub fn match_scan_near(
        &self,
        points: &[[f64; 2]],
        initial: &Pose2,
        window: &SearchWindow,
        min_score: f64,
        prior: Option<&MatchPrior>,
    ) -> Option<ScanMatch> {
        if points.is_empty() {
            return None;
        }
        let lattice = Lattice::new(self, points, initial, window, prior);
        let top = self.depth() - 1;
        let block = 1i32 << top;
        let reach = lattice.reach;
        let mut roots = Vec::new();
        for angle in 0..lattice.headings.len() {
            for dx in (-reach..=reach).step_by(block as usize) {
                for dy in (-reach..=reach).step_by(block as usize) {
                    roots.push(lattice.score(self, top, angle, dx, dy));
                }
            }
        }
        let threshold = lattice.threshold(points.len(), min_score);
        // With a prior the initial pose is the first to beat: a candidate must score
        // higher, which cuts most of the window early and keeps the initial pose on ties.
        let mut best = prior
            .map(|_| lattice.score(self, 0, lattice.headings.len() / 2, 0, 0))
            .filter(|c| c.score >= threshold);
        self.branch(&lattice, roots, top, threshold, &mut best);
        let best = best?;
        let coarse = lattice.pose(&best);
        let (pose, curvature) = refine(
            self.probabilities(),
            points,
            &coarse,
            lattice.resolution,
            lattice.angular_step,
        );
        Some(ScanMatch {
            pose,
            coarse,
            score: f64::from(best.score) / (f64::from(FULL) * points.len() as f64),
            angular_step: lattice.angular_step,
            curvature,
        })
    }

    /// Visits `candidates` of level `level` best first, splitting each whose bound beats
    /// both `threshold` and `best`, and leaves in `best` the best full-resolution one.
    fn branch(
        &self,
        lattice: &Lattice,
        mut candidates: Vec<Candidate>,
        level: usize,
        threshold: u32,
        best: &mut Option<Candidate>,
    ) {
        sort_best_first(&mut candidates);
        for c in candidates {
            let floor = best.map_or(threshold, |b: Candidate| b.score.saturating_add(1));
            if c.score < floor {
                break;
            }
            if level == 0 {
                // Sorted: nothing after it scores higher.
                *best = Some(c);
                break;
            }
            let half = 1i32 << (level - 1);
            let mut children = Vec::with_capacity(4);
            for (ax, ay) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let (dx, dy) = (c.dx + ax * half, c.dy + ay * half);
                if dx <= lattice.reach && dy <= lattice.reach {
                    children.push(lattice.score(self, level - 1, c.angle, dx, dy));
                }
            }
            self.branch(lattice, children, level - 1, threshold, best);
        }
    }

    /// The best pose on the same lattice as [`match_scan`](Self::match_scan), by scoring
    /// every one of its poses (no refinement: `pose` is `coarse`). For checking branch and
    /// bound, whose score it equals.
    pub fn match_exhaustive(
        &self,
        points: &[[f64; 2]],
        initial: &Pose2,
        window: &SearchWindow,
        min_score: f64,
    ) -> Option<ScanMatch> {
        if points.is_empty() {
            return None;
        }
        let lattice = Lattice::new(self, points, initial, window, None);
        let reach = lattice.reach;
        let mut best: Option<Candidate> = None;
        for angle in 0..lattice.headings.len() {
            for dx in -reach..=reach {
                for dy in -reach..=reach {
                    let c = lattice.score(self, 0, angle, dx, dy);
                    if best.is_none_or(|b| c.score > b.score) {
                        best = Some(c);
                    }
                }
            }
        }
        let best = best.filter(|b| b.score >= lattice.threshold(points.len(), min_score))?;
        let coarse = lattice.pose(&best);
        Some(ScanMatch {
            pose: coarse,
            coarse,
            score: f64::from(best.score) / (f64::from(FULL) * points.len() as f64),
            angular_step: lattice.angular_step,
            curvature: curvature(self.probabilities(), points, &coarse),
        })
    }
}
