//! Which finished submaps a keyframe is matched against, and in what window.
//!
//! A finished submap is searched when its origin (its first keyframe's estimate) lies
//! within `max_search_distance` of the keyframe's estimate. The window is centred on the
//! keyframe's estimate seen from the submap's origin and spans `3σ` of the uncertainty
//! accumulated along the keyframes between the two, approximated without a marginal
//! covariance: each step is the front end's covariance plus the window's floor
//! (`window_floor_xy`, `window_floor_theta`; wider than the graph's chain floor, so that
//! the window bounds a front end drifting more than the constraints are modelled with);
//! summed along the steps, the largest position variance of each gives `σ²_xy`, the
//! heading variances give `σ²_θ`, and a heading error anywhere along the `L` metres
//! travelled moves the end by up to `L`, on average `L/√3` on a straight path, so
//! `σ²_lin = σ²_xy + σ²_θ L² / 3`. Both are clamped to the configured windows. Loop
//! closures already in the graph do not shrink the window: it is a bound the true
//! uncertainty stays below.
//!
//! When a submap is finished, earlier keyframes near its origin are matched against it
//! the same way, so that both passes through a place search the other's submaps.
//!
//! A loop whose drift exceeds the clamps cannot close in that window. So every
//! `wide_search_every`-th keyframe, when no long loop closure in use ties any of the last
//! `wide_search_every` keyframes, also searches wide: the finished submaps whose `3σ`
//! exceeds a clamp, and whose origin lies within `max_search_distance` plus the wide
//! window, in `3σ` clamped to the wide window, accepting `wide_min_score`. A wide match
//! counts only when the `wide_confirmations` keyframes before it match the same submap
//! where it puts them, in the smallest window: a wide window holds more places where a
//! similar corridor scores well, and the scans of a few metres of travel rarely agree on
//! a wrong one.

use super::mapper::{LoopClosure, Matchable, PoseGraphMapper};
use super::matcher::SearchWindow;
use crate::pose::Pose2;
use rayon::prelude::*;

/// How far a search reaches: its window's clamps and the score it accepts.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reach {
    /// The window's half widths at most (m, rad).
    most: SearchWindow,
    /// The least score accepted.
    min_score: f64,
}

impl PoseGraphMapper {
    /// `points` (base frame) as they are matched: those within `max_range` of the base
    /// and their lever; `None` when fewer than `min_points` are left.
    pub(crate) fn matchable(&self, points: &[[f64; 2]]) -> Option<Matchable> {
        let config = &self.config;
        let points: Vec<[f64; 2]> = (points.iter().copied())
            .filter(|p| p[0].hypot(p[1]) <= config.max_range)
            .collect();
        if points.len() < config.min_points.max(1) {
            return None;
        }
        let squares: f64 = points.iter().map(|p| p[0] * p[0] + p[1] * p[1]).sum();
        let lever = (squares / points.len() as f64).sqrt();
        (lever.is_finite() && lever > 0.0).then_some(Matchable { points, lever })
    }

    /// Whether finished submap `submap`'s origin lies within `max_search_distance` of
    /// keyframe `index`'s estimate.
    fn near(&self, submap: usize, index: usize) -> bool {
        self.distance(submap, index) <= self.config.max_search_distance
    }

    /// Distance from finished submap `submap`'s origin to keyframe `index`'s estimate (m).
    fn distance(&self, submap: usize, index: usize) -> f64 {
        let origin = self.graph.poses[self.submaps[submap].anchor()];
        let here = self.graph.poses[index];
        (origin.x - here.x).hypot(origin.y - here.y)
    }

    /// The regular search's reach: `max_linear_window`, `max_angular_window`, `min_score`.
    fn regular(&self) -> Reach {
        Reach {
            most: SearchWindow {
                linear: self.config.max_linear_window,
                angular: self.config.max_angular_window,
            },
            min_score: self.config.min_score,
        }
    }

    /// The wide search's reach: `wide_linear_window`, `wide_angular_window`,
    /// `wide_min_score`.
    fn wide(&self) -> Reach {
        Reach {
            most: SearchWindow {
                linear: self.config.wide_linear_window,
                angular: self.config.wide_angular_window,
            },
            min_score: self.config.wide_min_score,
        }
    }

    /// The wide window between keyframes `a` and `b` (either order) when the window's `3σ`
    /// between them exceeds a clamp of the usual window; `None` when it does not.
    fn widened(&self, a: usize, b: usize) -> Option<SearchWindow> {
        let (a, b) = (a.min(b), a.max(b));
        let wide = self.window(a, b, &self.wide());
        (wide != self.window(a, b, &self.regular())).then_some(wide)
    }

    /// Whether `closure` ties two keyframes whose window's `3σ` exceeds a clamp of the
    /// window: a long loop.
    fn closes_a_long_loop(&self, closure: &LoopClosure) -> bool {
        let anchor = self.submaps[closure.submap].anchor();
        self.widened(anchor, closure.keyframe).is_some()
    }

    /// Whether keyframe `index` searches wide: it is matchable, its index is a positive
    /// multiple of `wide_search_every` (not 0), none of its own `found` matches closes a
    /// long loop ([`Self::closes_a_long_loop`]), and no long loop closure in use (weight
    /// above 0 after the last solve, or not yet judged) was found at any of the last
    /// `wide_search_every` keyframes.
    pub(crate) fn wide_due(&self, index: usize, found: &[LoopClosure]) -> bool {
        let every = self.config.wide_search_every;
        if every == 0
            || index == 0
            || !index.is_multiple_of(every)
            || self.keyframes[index].matchable.is_none()
            || found.iter().any(|c| self.closes_a_long_loop(c))
        {
            return false;
        }
        !(self.loops.iter()).any(|e| {
            e.weight > 0.0 && e.found_at + every > index && self.closes_a_long_loop(&e.closure)
        })
    }

    /// Whether keyframe `index` is one of submap `s`'s own.
    fn within(&self, s: usize, index: usize) -> bool {
        let submap = &self.submaps[s];
        (submap.anchor()..submap.anchor() + submap.keyframes()).contains(&index)
    }

    /// Matches keyframe `index` wide (see the module documentation) against the submaps
    /// beyond the window's clamps, not its own: how many were searched, and the
    /// confirmed matches, in submap order, each followed by its confirmations.
    pub(crate) fn search_wide(&self, index: usize) -> (usize, Vec<LoopClosure>) {
        let wide = self.wide();
        let pairs: Vec<(usize, usize)> = (0..self.submaps.len())
            .filter(|&s| {
                let reach = self.config.max_search_distance;
                self.submaps[s].grid().is_some()
                    && !self.within(s, index)
                    && (self.widened(self.submaps[s].anchor(), index))
                        .is_some_and(|w| self.distance(s, index) <= reach + w.linear)
            })
            .map(|s| (s, index))
            .collect();
        let found = self.match_pairs(&pairs, &wide);
        let confirmed = found.into_iter().flat_map(|c| self.confirmed(c)).collect();
        (pairs.len(), confirmed)
    }

    /// Matches keyframe `index` against the finished submaps near it: how many were
    /// searched, and the matches that reached `min_score`, in submap order.
    pub(crate) fn search(&self, index: usize) -> (usize, Vec<LoopClosure>) {
        if self.keyframes[index].matchable.is_none() {
            return (0, Vec::new());
        }
        let pairs: Vec<(usize, usize)> = (0..self.submaps.len())
            .filter(|&s| {
                let submap = &self.submaps[s];
                submap.grid().is_some() && submap.anchor() != index && self.near(s, index)
            })
            .map(|s| (s, index))
            .collect();
        (pairs.len(), self.match_pairs(&pairs, &self.regular()))
    }

    /// Matches earlier keyframes against the just finished `submap`: of the matchable
    /// keyframes before its first one within `max_search_distance` of its origin, at most
    /// `earlier_keyframes`, spread evenly over them. How many were searched, and the
    /// matches that reached `min_score`, in keyframe order.
    pub(crate) fn search_earlier(&self, submap: usize) -> (usize, Vec<LoopClosure>) {
        let most = self.config.earlier_keyframes;
        if most == 0 {
            return (0, Vec::new());
        }
        let eligible: Vec<usize> = (0..self.submaps[submap].anchor())
            .filter(|&k| self.keyframes[k].matchable.is_some() && self.near(submap, k))
            .collect();
        if eligible.is_empty() {
            return (0, Vec::new());
        }
        let take = most.min(eligible.len());
        let pairs: Vec<(usize, usize)> = (0..take)
            .map(|i| (submap, eligible[i * eligible.len() / take]))
            .collect();
        (pairs.len(), self.match_pairs(&pairs, &self.regular()))
    }

    /// Matches each `(submap, keyframe)` pair, in parallel, one pair per task; the
    /// matches that reached `reach`'s score, in the pairs' order. The window is centred
    /// on the keyframe's estimate seen from the submap's origin.
    fn match_pairs(&self, pairs: &[(usize, usize)], reach: &Reach) -> Vec<LoopClosure> {
        let matched = |&(s, k): &(usize, usize)| -> Option<LoopClosure> {
            let anchor = self.submaps[s].anchor();
            let initial = self.graph.poses[anchor]
                .inverse()
                .compose(&self.graph.poses[k]);
            let window = self.window(anchor.min(k), anchor.max(k), reach);
            self.match_at(s, k, &initial, &window, reach.min_score)
        };
        if pairs.len() > 1 {
            pairs.par_iter().map(matched).collect::<Vec<_>>()
        } else {
            pairs.iter().map(matched).collect()
        }
        .into_iter()
        .flatten()
        .collect()
    }

    /// Matches keyframe `k`'s scan against submap `s` in `window` around `initial` (its
    /// pose in the submap's frame); the match when it reaches `min_score`.
    fn match_at(
        &self,
        s: usize,
        k: usize,
        initial: &Pose2,
        window: &SearchWindow,
        min_score: f64,
    ) -> Option<LoopClosure> {
        let scan = self.keyframes[k].matchable.as_ref()?;
        let grid = self.submaps[s].grid()?;
        let m = grid.match_scan(&scan.points, initial, window, min_score)?;
        (m.score > 0.0).then_some(LoopClosure {
            keyframe: k,
            submap: s,
            pose: m.pose,
            score: m.score,
            lever: scan.lever,
            curvature: Some(m.curvature.fixed_view::<2, 2>(0, 0).into_owned()),
        })
    }

    /// A wide match with its confirmations: each of the `wide_confirmations` matchable
    /// keyframes before `found`'s, among its last `wide_search_every` and not the
    /// submap's own, matched against the same submap in the smallest window
    /// (`min_linear_window`, `min_angular_window`) around where `found` puts it — the
    /// chain's motion between the two applied to `found.pose` — at `wide_min_score`.
    /// Empty when one of them does not match or there are too few.
    fn confirmed(&self, found: LoopClosure) -> Vec<LoopClosure> {
        let config = &self.config;
        let (k, s) = (found.keyframe, found.submap);
        let earlier: Vec<usize> = (k.saturating_sub(config.wide_search_every)..k)
            .rev()
            .filter(|&j| !self.within(s, j) && self.keyframes[j].matchable.is_some())
            .take(config.wide_confirmations)
            .collect();
        if earlier.len() < config.wide_confirmations {
            return Vec::new();
        }
        let smallest = SearchWindow {
            linear: config.min_linear_window,
            angular: config.min_angular_window,
        };
        let here = self.graph.poses[k].inverse();
        let mut all = vec![found];
        for j in earlier {
            let initial = found.pose.compose(&here.compose(&self.graph.poses[j]));
            match self.match_at(s, j, &initial, &smallest, config.wide_min_score) {
                Some(c) => all.push(c),
                None => return Vec::new(),
            }
        }
        all
    }

    /// The search window between keyframes `anchor` and `index` (the later), clamped to
    /// `reach`; see the module documentation.
    fn window(&self, anchor: usize, index: usize, reach: &Reach) -> SearchWindow {
        let (a, b) = (self.accumulated[anchor], self.accumulated[index]);
        let var_xy = (b[0] - a[0]).max(0.0);
        let var_theta = (b[1] - a[1]).max(0.0);
        let travelled = (b[2] - a[2]).max(0.0);
        let linear = (var_xy + var_theta * travelled * travelled / 3.0).sqrt();
        let config = &self.config;
        SearchWindow {
            linear: (3.0 * linear).clamp(config.min_linear_window, reach.most.linear),
            angular: (3.0 * var_theta.sqrt()).clamp(config.min_angular_window, reach.most.angular),
        }
    }
}
