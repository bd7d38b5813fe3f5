//! Solving with loop closures that may be wrong: iteratively reweighted least squares
//! outside the solver, then a χ² gate.
//!
//! Each round solves the graph (Levenberg–Marquardt, [`Graph::solve`], as for a pose
//! graph: the exponential update and Levenberg's damping) with every loop closure's
//! information scaled by its weight, then sets each weight to the Cauchy weight
//! `1 / (1 + χ²/c²)` of its χ² under its nominal information at the solution. A wrong
//! closure disagrees with the consecutive constraints and the other closures, ends with a
//! large χ², and loses its pull round by round; rounds stop when no weight moves by more
//! than [`WEIGHT_TOLERANCE`] or after `robust_rounds`. Then every closure whose χ² exceeds
//! the gate is left out (weight 0), the others get their full information back, and a
//! last solve gives the solution: least squares over the closures that fit. A left-out
//! closure stays in the graph and is judged again at the next solve, from the solution
//! without it. The next solve's rounds start from the Cauchy weights the last rounds
//! settled on (a new closure from 1), so they only have the new closures to settle; all
//! of a solve's rounds share one symbolic factorisation.

use super::config::LoopClosureConfig;
use super::mapper::LoopClosure;
use crate::Result;
use crate::graph::{Graph, SolveOptions};
use crate::pose::{Pose2, wrap_angle};
use nalgebra::{Matrix3, Vector3};

/// Rounds stop when no loop closure's weight changes by more than this.
pub const WEIGHT_TOLERANCE: f64 = 1e-3;

/// A loop closure in the graph with its state after the last solve.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopEdge {
    /// The match it came from.
    pub closure: LoopClosure,
    /// Its weight in the last solve: 1 used in full, 0 left out (a new closure starts
    /// at 1).
    pub weight: f64,
    /// Its Cauchy weight after the last reweighting round, where the next solve's rounds
    /// start (1 for a new closure).
    pub(crate) robust_weight: f64,
    /// `rᵀ Ω r` of its residual under its nominal information at the last solution (0
    /// before a solve).
    pub chi2: f64,
    /// Its index among the graph's betweens.
    pub(crate) between: usize,
    /// Its nominal information.
    pub(crate) information: Matrix3<f64>,
    /// The newest keyframe when it was added: where it was found.
    pub(crate) found_at: usize,
}

/// What [`solve`] did.
pub(crate) struct Report {
    pub(crate) rounds: usize,
    pub(crate) iterations: usize,
    pub(crate) accepted: usize,
}

/// `rᵀ Ω r` of the constraint "`to` seen from `from` is `delta`" at the two poses.
pub(crate) fn chi2(from: &Pose2, to: &Pose2, delta: &Pose2, information: &Matrix3<f64>) -> f64 {
    let (s, c) = from.theta.sin_cos();
    let (dx, dy) = (to.x - from.x, to.y - from.y);
    let r = Vector3::new(
        c * dx + s * dy - delta.x,
        -s * dx + c * dy - delta.y,
        wrap_angle(to.theta - from.theta - delta.theta),
    );
    (r.transpose() * information * r)[0]
}

/// Reweighted solves and the gate; see the module documentation.
pub(crate) fn solve(
    graph: &mut Graph,
    loops: &mut [LoopEdge],
    config: &LoopClosureConfig,
) -> Result<Report> {
    let options = SolveOptions {
        max_iterations: config.max_iterations,
        ..SolveOptions::pose_graph()
    };
    let c2 = config.loop_kernel_scale * config.loop_kernel_scale;
    let (mut rounds, mut iterations) = (0, 0);
    let mut system = None;
    if !loops.is_empty() {
        for edge in loops.iter_mut() {
            edge.weight = edge.robust_weight;
        }
        loop {
            apply_weights(graph, loops);
            iterations += graph.solve_with(&options, &mut system)?.iterations;
            rounds += 1;
            let mut change: f64 = 0.0;
            for edge in loops.iter_mut() {
                edge.chi2 = edge_chi2(graph, edge);
                let weight = 1.0 / (1.0 + edge.chi2 / c2);
                change = change.max((weight - edge.weight).abs());
                edge.weight = weight;
                edge.robust_weight = weight;
            }
            if change <= WEIGHT_TOLERANCE || rounds >= config.robust_rounds {
                break;
            }
        }
        for edge in loops.iter_mut() {
            edge.weight = if edge.chi2 <= config.loop_chi2_gate {
                1.0
            } else {
                0.0
            };
        }
    }
    apply_weights(graph, loops);
    iterations += graph.solve_with(&options, &mut system)?.iterations;
    rounds += 1;
    for edge in loops.iter_mut() {
        edge.chi2 = edge_chi2(graph, edge);
    }
    Ok(Report {
        rounds,
        iterations,
        accepted: loops.iter().filter(|e| e.weight > 0.0).count(),
    })
}

/// Sets every loop closure's information in the graph to its weight times its nominal.
fn apply_weights(graph: &mut Graph, loops: &[LoopEdge]) {
    for edge in loops {
        graph.betweens[edge.between].information = edge.information * edge.weight;
    }
}

/// A loop closure's χ² under its nominal information at the graph's estimates.
fn edge_chi2(graph: &Graph, edge: &LoopEdge) -> f64 {
    let b = &graph.betweens[edge.between];
    chi2(
        &graph.poses[b.from],
        &graph.poses[b.to],
        &b.delta,
        &edge.information,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_is_zero_on_the_constraint_and_grows_off_it() {
        let from = Pose2::new(1.0, 2.0, 0.5);
        let delta = Pose2::new(0.3, -0.2, 0.1);
        let to = from.compose(&delta);
        let info = Matrix3::identity() * 100.0;
        assert!(chi2(&from, &to, &delta, &info) < 1e-20);
        let off = Pose2::new(to.x + 0.1, to.y, to.theta);
        assert!((chi2(&from, &off, &delta, &info) - 1.0).abs() < 1e-9);
    }
}
