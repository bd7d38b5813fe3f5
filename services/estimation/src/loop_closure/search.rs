//! Which finished submaps a keyframe is matched against, and in what window.
//!
//! A finished submap is searched when its origin (its first keyframe's estimate) lies
//! within `max_search_distance` of the keyframe's estimate. The window is centred on the
//! keyframe's estimate seen from the submap's origin and spans `3σ` of the uncertainty
//! the graph's chain of consecutive constraints accumulates between the two, approximated
//! without a marginal covariance: summed along the chain, the largest position variance
//! of each constraint gives `σ²_xy`, the heading variances give `σ²_θ`, and a heading
//! error anywhere along the `L` metres travelled moves the end by up to `L`, on average
//! `L/√3` on a straight path, so `σ²_lin = σ²_xy + σ²_θ L² / 3`. Both are clamped to the
//! configured windows. Loop closures already in the graph do not shrink the window: it
//! is the chain's uncertainty, a bound the true one stays below.

use super::mapper::{LoopClosure, PoseGraphMapper};
use super::matcher::{ScanMatch, SearchWindow};
use rayon::prelude::*;

impl PoseGraphMapper {
    /// Matches keyframe `index`'s `points` (base frame) against the finished submaps
    /// near it: how many were searched, and the matches that reached `min_score`, in
    /// submap order.
    pub(crate) fn search(&self, index: usize, points: &[[f64; 2]]) -> (usize, Vec<LoopClosure>) {
        let config = &self.config;
        let points: Vec<[f64; 2]> = (points.iter().copied())
            .filter(|p| p[0].hypot(p[1]) <= config.max_range)
            .collect();
        if points.len() < config.min_points.max(1) {
            return (0, Vec::new());
        }
        let lever = (points
            .iter()
            .map(|p| p[0] * p[0] + p[1] * p[1])
            .sum::<f64>()
            / points.len() as f64)
            .sqrt();
        if !(lever.is_finite() && lever > 0.0) {
            return (0, Vec::new());
        }
        let here = self.graph.poses[index];
        let candidates: Vec<usize> = (0..self.submaps.len())
            .filter(|&s| {
                let submap = &self.submaps[s];
                let origin = self.graph.poses[submap.anchor()];
                submap.grid().is_some()
                    && submap.anchor() != index
                    && (origin.x - here.x).hypot(origin.y - here.y) <= config.max_search_distance
            })
            .collect();
        let matched = |&s: &usize| -> Option<(usize, ScanMatch)> {
            let submap = &self.submaps[s];
            let anchor = submap.anchor();
            let initial = self.graph.poses[anchor].inverse().compose(&here);
            let window = self.window(anchor, index);
            let grid = submap.grid()?;
            grid.match_scan(&points, &initial, &window, config.min_score)
                .map(|m| (s, m))
        };
        let matches: Vec<Option<(usize, ScanMatch)>> = if candidates.len() > 1 {
            candidates.par_iter().map(matched).collect()
        } else {
            candidates.iter().map(matched).collect()
        };
        let closures = matches
            .into_iter()
            .flatten()
            .filter(|(_, m)| m.score > 0.0)
            .map(|(submap, m)| LoopClosure {
                keyframe: index,
                submap,
                pose: m.pose,
                score: m.score,
                lever,
            })
            .collect();
        (candidates.len(), closures)
    }

    /// The search window for keyframe `index` in the frame of keyframe `anchor` (earlier);
    /// see the module documentation.
    pub(crate) fn window(&self, anchor: usize, index: usize) -> SearchWindow {
        let (a, b) = (self.accumulated[anchor], self.accumulated[index]);
        let var_xy = (b[0] - a[0]).max(0.0);
        let var_theta = (b[1] - a[1]).max(0.0);
        let travelled = (b[2] - a[2]).max(0.0);
        let linear = (var_xy + var_theta * travelled * travelled / 3.0).sqrt();
        let config = &self.config;
        SearchWindow {
            linear: (3.0 * linear).clamp(config.min_linear_window, config.max_linear_window),
            angular: (3.0 * var_theta.sqrt())
                .clamp(config.min_angular_window, config.max_angular_window),
        }
    }
}
