//! Window solves of the smoothing back-end (docs/ALGORITHMS.md §8.1): the newest poses
//! and the landmarks they saw, solved with every older pose held where the last solve put
//! it — the local bundle adjustment of keyframe SLAM. A solve then costs the window, not
//! the whole graph; the [`Smoother`](super::Smoother) solves the whole graph as it grows
//! by a set factor and at the end of the data.
//!
//! The window problem is the graph's own, conditioned on the held poses: the last held
//! pose enters as a variable pinned by a strong prior (the odometry factor into the window
//! starts from it), and each window landmark's sightings from held poses enter as one
//! [`LandmarkPrior`] — their Gauss–Newton information and information vector about the
//! landmark, summed once when the pose that made them leaves the window (linearised at
//! that moment's estimates, robust weights included). Summing each sighting once keeps a
//! solve's cost at the window's size; a whole-graph solve moves the held poses, so it
//! starts the sums again ([`Window::restart`]).

use super::consistency::Fit;
use super::solve::{Kernel, SolveOptions, SolveReport};
use super::{Between, Graph, LandmarkPrior, Linearised, Prior};
use crate::Result;
use nalgebra::{Matrix2, Matrix3, Vector2};

/// Information of the prior that pins the last held pose (as the first pose's).
const PINNED: f64 = 1e8;

/// The sums of the held sightings per landmark; see the module documentation.
#[derive(Debug, Clone, Default)]
pub(super) struct Window {
    /// Sightings before this index (the graph keeps them in pose order) are summed.
    summed: usize,
    /// Per landmark: `Σ Jᵀ W J` and `Σ Jᵀ W (J m₀ − r₀)` of its summed sightings.
    sums: Vec<(Matrix2<f64>, Vector2<f64>)>,
}

/// What a window solve did.
#[derive(Debug, Clone)]
pub(super) struct WindowReport {
    /// The solver's report.
    pub report: SolveReport,
    /// The window's landmarks (graph indices) and their covariances given the held poses.
    pub covariances: Vec<(usize, Matrix2<f64>)>,
    /// The window problem's fit to its noise model, its priors included.
    pub fit: Fit,
}

impl Window {
    /// Forgets the sums: the held poses moved.
    pub(super) fn restart(&mut self) {
        *self = Self::default();
    }

    /// Solves poses `start..` of `graph` and the landmarks they saw, poses before `start`
    /// held, and writes the solution into `graph`. `start` must be at least 1 and never
    /// move back between [`restart`](Self::restart)s.
    ///
    /// # Errors
    /// When the window's normal equations cannot be factorised.
    pub(super) fn solve(
        &mut self,
        graph: &mut Graph,
        start: usize,
        options: &SolveOptions,
        scale: f64,
    ) -> Result<WindowReport> {
        self.sum_held(graph, start, options.kernel);
        let held = start - 1;
        let mut local = Graph::default();
        local.poses.extend_from_slice(&graph.poses[held..]);
        local.priors.push(Prior {
            pose: 0,
            mean: graph.poses[held],
            information: Matrix3::identity() * PINNED,
        });
        let first = graph.betweens.partition_point(|b| b.from < held);
        local
            .betweens
            .extend(graph.betweens[first..].iter().map(|b| Between {
                from: b.from - held,
                to: b.to - held,
                ..*b
            }));
        let mut index = vec![usize::MAX; graph.landmarks.len()];
        let mut landmarks = Vec::new();
        for s in &graph.sightings[self.summed..] {
            if index[s.landmark] == usize::MAX {
                index[s.landmark] = landmarks.len();
                landmarks.push(s.landmark);
                local.landmarks.push(graph.landmarks[s.landmark]);
            }
            local.sightings.push(super::Sighting {
                pose: s.pose - held,
                landmark: index[s.landmark],
                ..*s
            });
        }
        for (k, &global) in landmarks.iter().enumerate() {
            let Some(&(information, vector)) = self.sums.get(global) else {
                continue;
            };
            if let Some(mean) = information.try_inverse().map(|c| c * vector) {
                local.landmark_priors.push(LandmarkPrior {
                    landmark: k,
                    mean,
                    information,
                });
            }
        }
        let report = local.solve(options)?;
        let marginals = local.landmark_covariances(options.kernel)?;
        graph.poses[start..].copy_from_slice(&local.poses[1..]);
        for (&global, at) in landmarks.iter().zip(&local.landmarks) {
            graph.landmarks[global] = *at;
        }
        Ok(WindowReport {
            fit: local.fit(report.final_cost, scale),
            report,
            covariances: landmarks.into_iter().zip(marginals).collect(),
        })
    }

    /// Landmark `k`'s covariance given the held poses' sightings of it, if they fix it.
    pub(super) fn held_covariance(&self, k: usize) -> Option<Matrix2<f64>> {
        self.sums
            .get(k)
            .and_then(|(information, _)| information.try_inverse())
    }

    /// Adds the sightings from poses before `start` not summed yet to their landmarks'
    /// sums, linearised at the current estimates.
    fn sum_held(&mut self, graph: &Graph, start: usize, kernel: Kernel) {
        self.sums
            .resize(graph.landmarks.len(), (Matrix2::zeros(), Vector2::zeros()));
        let sightings = &graph.sightings[self.summed..];
        let held = sightings.partition_point(|s| s.pose < start);
        for s in &sightings[..held] {
            let m = graph.landmarks[s.landmark];
            if let Some(Linearised::Sighting { r, j_landmark, .. }) =
                s.linearise(&graph.poses[s.pose], &m)
            {
                let w = s.information * kernel.weight((r.transpose() * s.information * r)[0]);
                let jw = j_landmark.transpose() * w;
                let (information, vector) = &mut self.sums[s.landmark];
                *information += jw * j_landmark;
                *vector += jw * (j_landmark * m - r);
            }
        }
        self.summed += held;
    }
}
