//! Odometry from the laser alone, for a recording without wheel odometry (a hand-held or
//! backpack laser, a bag whose odometry was not recorded): every scan is matched against
//! a local map of the scans before it, and the matched poses are the odometry.
//!
//! - **Reference.** The surfaces seen by the last `reference_scans` scans inserted, in the
//!   odometry frame: each scan's end points, joined where neighbouring beams end at most
//!   `max_gap` apart (a wall seen at a grazing angle is a wall, not a row of dots that
//!   only the same beams hit again), rasterised with a Gaussian of `sigma` (the lookup
//!   table of Olson 2009, "Real-time correlative scan matching"): a cell holds
//!   `max exp(−d² / 2σ²)` over the points, `d` the distance from its centre.
//! - **Prediction.** The pose moves on at the velocity of the last `velocity_window`
//!   seconds of scans: the median of the rates between consecutive scans, so that a
//!   jittery stamp or a scan that jumps back and forth does not throw the next prediction
//!   off.
//! - **Matching.** Branch-and-bound correlative matching against the reference in a
//!   window of `±window_linear` and `±window_angular` around the prediction, each pose's
//!   score less a quadratic pull towards the prediction (`prior_*`: along a featureless
//!   corridor the scan fixes nothing and the motion goes on as it was), refined off the
//!   lattice ([`crate::loop_closure::MatchGrid::match_scan_near`]). A scan whose best pose
//!   scores below `min_score` keeps the prediction and is counted.
//! - **Insertion.** A scan joins the reference when the pose moved `insert_distance` or
//!   turned `insert_angle` since the last inserted one, so a standing robot does not pile
//!   the same scan up.
//!
//! The result is the chain of matched poses: locally as good as the matches, drifting over
//! distance like any odometry, and never closing a loop (the filter and its back-end do).
//! Deterministic: one scan after another, no threads.

use crate::loop_closure::{FULL, MatchGrid, MatchPrior, ProbabilityGrid, SearchWindow};
use crate::pose::{Pose2, wrap_angle};
use crate::scan::{Beam, RangeScan};
use std::collections::VecDeque;

/// Settings of [`LaserOdometry`]; see the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserOdometryConfig {
    /// Cell size of the reference (m).
    pub resolution: f64,
    /// Returns are used up to this range (m).
    pub max_range: f64,
    /// Scans in the reference.
    pub reference_scans: usize,
    /// The Gaussian around each reference point (m): the range noise and half a cell.
    pub sigma: f64,
    /// Neighbouring beams' end points at most this far apart are joined into a surface
    /// in the reference (m).
    pub max_gap: f64,
    /// The prediction's velocity is taken over the scans of this much time (s).
    pub velocity_window: f64,
    /// A scan is inserted once the pose moved this far since the last inserted one (m)…
    pub insert_distance: f64,
    /// …or turned this far (rad).
    pub insert_angle: f64,
    /// Half width of the search window in x and in y around the prediction (m).
    pub window_linear: f64,
    /// Half width of the search window in heading around the prediction (rad).
    pub window_angular: f64,
    /// The windows and the prior's σ grow with the time since the last scan over the scan
    /// period (after a gap in the data), the linear window up to this (m) and the angular
    /// one up to π.
    pub max_window_linear: f64,
    /// Max-pooled levels of the branch and bound.
    pub depth: usize,
    /// A match scoring below this (the mean probability under the scan's points) is not
    /// taken.
    pub min_score: f64,
    /// The pull towards the prediction: a pose this far from it (m)…
    pub prior_linear: f64,
    /// …or turned this far from it (rad)…
    pub prior_angular: f64,
    /// …scores this share of a full score less (quadratic in the distance).
    pub prior_cost: f64,
    /// Scan points matched, at most (every k-th beam's end).
    pub max_points: usize,
}

impl Default for LaserOdometryConfig {
    fn default() -> Self {
        Self {
            resolution: 0.05,
            max_range: 20.0,
            reference_scans: 20,
            max_gap: 0.5,
            velocity_window: 0.5,
            sigma: 0.05,
            insert_distance: 0.1,
            insert_angle: 5f64.to_radians(),
            window_linear: 0.5,
            window_angular: 45f64.to_radians(),
            max_window_linear: 3.0,
            depth: 5,
            min_score: 0.35,
            prior_linear: 0.1,
            prior_angular: 0.1,
            prior_cost: 0.01,
            max_points: 360,
        }
    }
}

/// Scans tracked so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TrackingCounts {
    /// Scans given.
    pub scans: usize,
    /// Scans matched (the rest kept their prediction).
    pub matched: usize,
    /// Scans inserted into the reference.
    pub inserted: usize,
}

/// Odometry from scan matching; see the module documentation.
#[derive(Debug, Clone)]
pub struct LaserOdometry {
    config: LaserOdometryConfig,
    /// The laser's pose on the base.
    mount: Pose2,
    /// The reference scans' surfaces (odometry frame), oldest first.
    reference: VecDeque<Vec<[f64; 2]>>,
    /// The reference rasterised, with its max-pooled levels.
    target: Option<MatchGrid>,
    /// The stamps (s) and poses of the scans of the last `velocity_window` seconds and the
    /// one before them, oldest first.
    recent: VecDeque<(f64, Pose2)>,
    /// The pose of the last scan inserted.
    inserted_at: Option<Pose2>,
    counts: TrackingCounts,
}

impl LaserOdometry {
    /// Odometry of a laser at `mount` (its pose on the base) with `config`.
    pub fn new(config: LaserOdometryConfig, mount: Pose2) -> Self {
        Self {
            config,
            mount,
            reference: VecDeque::new(),
            target: None,
            recent: VecDeque::new(),
            inserted_at: None,
            counts: TrackingCounts::default(),
        }
    }

    /// Scans tracked, matched and inserted so far.
    pub fn counts(&self) -> TrackingCounts {
        self.counts
    }

    /// The pose of the base when `scan` was taken at `stamp_s` (s), in the odometry frame;
    /// scans come in stamp order. The first scan is the odometry frame's origin; a scan
    /// with no pose scoring `min_score` in its window keeps the prediction (counted in
    /// [`LaserOdometry::counts`]).
    pub fn track(&mut self, stamp_s: f64, scan: &RangeScan<'_>) -> Pose2 {
        self.counts.scans += 1;
        let (predicted, periods) = self.predict(stamp_s);
        let points = self.points(scan);
        // After a gap in the scans the motion since is known that much less well.
        let widen = periods.max(1.0);
        let matched = (self.target.as_ref()).and_then(|grid| {
            let window = SearchWindow {
                linear: (self.config.window_linear * widen).min(self.config.max_window_linear),
                angular: (self.config.window_angular * widen).min(std::f64::consts::PI),
            };
            let prior = MatchPrior {
                sigma_linear: self.config.prior_linear * widen,
                sigma_angular: self.config.prior_angular * widen,
                cost: self.config.prior_cost,
            };
            let min_score = self.config.min_score;
            grid.match_scan_near(&points, &predicted, &window, min_score, Some(&prior))
        });
        let pose = match matched {
            Some(m) => {
                self.counts.matched += 1;
                m.pose
            }
            None => predicted,
        };
        self.recent.push_back((stamp_s, pose));
        while self.recent.len() > 2 && stamp_s - self.recent[1].0 >= self.config.velocity_window {
            self.recent.pop_front();
        }
        if self.due(&pose) {
            let surface = self.surface(scan);
            self.insert(&pose, &surface);
        }
        pose
    }

    /// The last pose moved on at the recent velocity to `stamp_s` (for at most two scan
    /// periods), and how many scan periods `stamp_s` is after the last scan (0 before any
    /// scan or velocity); the origin before any scan.
    fn predict(&self, stamp_s: f64) -> (Pose2, f64) {
        let Some(&(t, pose)) = self.recent.back() else {
            return (Pose2::default(), 0.0);
        };
        // The median step between consecutive scans (each of x, y, θ, and the time), so
        // that one odd scan or stamp does not set the velocity.
        let steps: Vec<[f64; 4]> = (self.recent.iter().zip(self.recent.iter().skip(1)))
            .map(|((t0, p0), (t1, p1))| {
                let d = p0.inverse().compose(p1);
                [d.x, d.y, wrap_angle(d.theta), t1 - t0]
            })
            .collect();
        if steps.is_empty() {
            return (pose, 0.0);
        }
        let median = |i: usize| {
            let mut v: Vec<f64> = steps.iter().map(|r| r[i]).collect();
            v.sort_by(f64::total_cmp);
            let n = v.len();
            if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            }
        };
        let period = median(3);
        if period <= 0.0 {
            return (pose, 0.0);
        }
        let periods = (stamp_s - t) / period;
        let k = periods.clamp(0.0, 2.0);
        let moved = Pose2::new(k * median(0), k * median(1), k * median(2));
        (pose.compose(&moved), periods)
    }

    /// The end points of `scan`'s returns within half of `max_range`, in the base frame,
    /// at most `max_points` of them: the reference holds surfaces out to `max_range`, so
    /// a point matched is one the reference has seen, however far the scan moved on.
    fn points(&self, scan: &RangeScan<'_>) -> Vec<[f64; 2]> {
        let stride = scan.len().div_ceil(self.config.max_points).max(1);
        (0..scan.len())
            .step_by(stride)
            .filter_map(|i| self.end_point(scan, i, 0.5 * self.config.max_range))
            .collect()
    }

    /// `scan`'s end points within `max_range` in the base frame, with points every eighth
    /// of a cell between neighbouring beams' ends at most `max_gap` apart.
    fn surface(&self, scan: &RangeScan<'_>) -> Vec<[f64; 2]> {
        let step = self.config.resolution / 8.0;
        let mut out = Vec::with_capacity(scan.len());
        let mut previous: Option<[f64; 2]> = None;
        for i in 0..scan.len() {
            let Some(point) = self.end_point(scan, i, self.config.max_range) else {
                previous = None;
                continue;
            };
            if let Some(p) = previous {
                let gap = (point[0] - p[0]).hypot(point[1] - p[1]);
                if gap <= self.config.max_gap {
                    let n = (gap / step).floor() as usize;
                    out.extend((1..n).map(|k| {
                        let t = k as f64 / n as f64;
                        [p[0] + t * (point[0] - p[0]), p[1] + t * (point[1] - p[1])]
                    }));
                }
            }
            out.push(point);
            previous = Some(point);
        }
        out
    }

    /// Where beam `i` of `scan` ended, in the base frame, when it returned within `reach`.
    fn end_point(&self, scan: &RangeScan<'_>, i: usize, reach: f64) -> Option<[f64; 2]> {
        match scan.beam(i) {
            Beam::Hit(r) if r <= reach => {
                let a = scan.angle(i);
                Some(self.mount.transform_point([r * a.cos(), r * a.sin()]))
            }
            _ => None,
        }
    }

    /// True when a scan at `pose` goes into the local map.
    fn due(&self, pose: &Pose2) -> bool {
        self.inserted_at.is_none_or(|at| {
            let moved = at.inverse().compose(pose);
            moved.x.hypot(moved.y) >= self.config.insert_distance
                || wrap_angle(moved.theta).abs() >= self.config.insert_angle
        })
    }

    /// Adds `points` (base frame) seen from `pose` to the reference, drops the oldest
    /// scan beyond `reference_scans`, and rasterises it anew.
    fn insert(&mut self, pose: &Pose2, points: &[[f64; 2]]) {
        self.reference
            .push_back(points.iter().map(|p| pose.transform_point(*p)).collect());
        if self.reference.len() > self.config.reference_scans {
            self.reference.pop_front();
        }
        let raster = rasterise(
            self.reference.iter().flatten(),
            self.config.resolution,
            self.config.sigma,
        );
        self.target = Some(MatchGrid::new(raster, self.config.depth));
        self.inserted_at = Some(*pose);
        self.counts.inserted += 1;
    }
}

/// Sub-cell positions a point is rounded to along each axis when rasterised (a quarter
/// of a cell: the table then errs by an eighth of a cell at most).
const SUBCELLS: usize = 4;

/// `points` as a grid of cells of side `resolution`: each cell `round(255 · max
/// exp(−d² / 2σ²))` over the points within `3σ`, `d` the distance from the cell's centre
/// to the point (rounded to a quarter of a cell, through a table of the kernel).
fn rasterise<'a>(
    points: impl Iterator<Item = &'a [f64; 2]> + Clone,
    resolution: f64,
    sigma: f64,
) -> ProbabilityGrid {
    let reach = (3.0 * sigma / resolution).ceil() as i64;
    let margin = (reach + 1) as f64 * resolution;
    let (lo, hi) = points.clone().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    if !lo[0].is_finite() {
        return ProbabilityGrid::from_cells(resolution, [0.0, 0.0], 0, 0, Vec::new());
    }
    let origin = [lo[0] - margin, lo[1] - margin];
    let width = ((hi[0] + margin - origin[0]) / resolution).ceil() as usize;
    let height = ((hi[1] + margin - origin[1]) / resolution).ceil() as usize;
    // The kernel's value along one axis, per sub-cell position and cell offset: the
    // Gaussian is a product, so a cell's value is the product of two entries.
    let side = (2 * reach + 1) as usize;
    let axis: Vec<f64> = (0..SUBCELLS * side)
        .map(|k| {
            let (sub, offset) = (k / side, (k % side) as f64 - reach as f64);
            let d = (offset + 0.5 - (sub as f64 + 0.5) / SUBCELLS as f64) * resolution;
            (-d * d / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let mut cells = vec![0u8; width * height];
    for p in points {
        let (u, v) = (
            (p[0] - origin[0]) / resolution,
            (p[1] - origin[1]) / resolution,
        );
        let (ci, cj) = (u.floor() as i64, v.floor() as i64);
        let sub = |f: f64| ((f - f.floor()) * SUBCELLS as f64).min(SUBCELLS as f64 - 1.0) as usize;
        let (row_x, row_y) = (
            &axis[sub(u) * side..][..side],
            &axis[sub(v) * side..][..side],
        );
        for (dj, wy) in row_y.iter().enumerate() {
            let j = cj + dj as i64 - reach;
            if j < 0 || j >= height as i64 {
                continue;
            }
            for (di, wx) in row_x.iter().enumerate() {
                let i = ci + di as i64 - reach;
                if i < 0 || i >= width as i64 {
                    continue;
                }
                let value = (f64::from(FULL) * wx * wy + 0.5) as u8;
                let cell = &mut cells[j as usize * width + i as usize];
                *cell = (*cell).max(value);
            }
        }
    }
    ProbabilityGrid::from_cells(resolution, origin, width, height, cells)
}
