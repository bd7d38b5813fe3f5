//! Settings of the loop-closing back-end (`[loop_closure]` of the service), with their
//! units and the reasons for their defaults (docs/ALGORITHMS.md §9.1).

use crate::Result;
use crate::check::{in_range, non_negative, positive, require};
use serde::{Deserialize, Serialize};

/// Settings of [`super::PoseGraphMapper`]; defaults suit an indoor planar laser.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoopClosureConfig {
    /// Whether the service runs the back-end behind grid FastSLAM (`[map] kind = "grid"`;
    /// the landmark filter has the smoothing back-end instead). Default false; the
    /// `planar-laser` replay profile, where it was measured, turns it on.
    pub enabled: bool,
    /// The service applies the solve that followed keyframe `k` at keyframe
    /// `k + delay_keyframes` (count): the back-end matches and solves on its own thread
    /// meanwhile, and the filter waits for it only if it is later than that. The delay is
    /// counted in keyframes, never in time, so that runs repeat bit for bit. Default 2
    /// (about 1 m of travel at 0.5 m keyframes); 0 applies each solve at once.
    pub delay_keyframes: usize,
    /// Where each solve's map frame is put (m): the rigid motion that lands the keyframes
    /// near the robot, weighted by a Gaussian of this standard deviation in their distance
    /// from it, where their poses were published ([`super::local_gauge`]). Default 3, a
    /// room or a stretch of corridor: a place revisited is published where it was the
    /// first time. 0 keeps the frame the graph's first keyframe fixes.
    pub gauge_radius: f64,
    /// Side of a submap cell (m). Default 0.05: the range noise of an indoor lidar (1–3 cm)
    /// is below it, and a ±3 m window is 121 cells wide.
    pub resolution: f64,
    /// Keyframes a submap takes before it is finished and can be matched against (count,
    /// ≥ 1). Default 30: about 15 m of travel at 0.5 m keyframes, enough for a submap to
    /// see a room or a corridor's stretch whole, short enough that the front end's drift
    /// inside it stays below a cell or two.
    pub keyframes_per_submap: usize,
    /// Beams are cut at this length when inserted into a submap, and scan points farther
    /// from the base are not matched (m). Default 20: it bounds a submap's extent, hence
    /// its memory, and far returns are the least precise in heading.
    pub max_range: f64,
    /// Log-odds added to a submap cell where a beam ended (dimensionless, > 0). Default 0.4
    /// (p 0.6).
    pub l_occupied: f64,
    /// Log-odds added to a submap cell a beam crossed (dimensionless, < 0). Default −0.1
    /// (p 0.475): four misses undo one hit, so a thin wall grazed by later beams survives.
    pub l_free: f64,
    /// A submap cell's log-odds stay within `±l_clamp` (dimensionless, > 0). Default 2.2
    /// (p within [0.1, 0.9]).
    pub l_clamp: f64,
    /// Match every `search_every`-th keyframe against the finished submaps (count, ≥ 1).
    /// Default 1.
    pub search_every: usize,
    /// When a submap is finished, up to this many earlier keyframes whose estimates lie
    /// within `max_search_distance` of its origin are matched against it, spread evenly
    /// over them (count; 0: none). Without it, of two passes through one place only the
    /// later pass's keyframes are matched, against the earlier pass's submaps. Default 30,
    /// a submap's own keyframe count: a finished submap is searched from the past about
    /// as often as its keyframes search the past.
    pub earlier_keyframes: usize,
    /// Finished submaps whose origin lies within this distance of the keyframe (graph
    /// estimates) are searched (m). Default 15: a submap reaches about its range limit
    /// around the path it was built along.
    pub max_search_distance: f64,
    /// The search window's accumulated uncertainty adds this standard deviation in
    /// quadrature to each consecutive step's front-end covariance, position (m). Default
    /// 0.02, wider than the chain's default floor (`between_floor_xy`), so that the window
    /// bounds a front end drifting more than the graph's constraints are modelled with.
    pub window_floor_xy: f64,
    /// … heading (rad). Default 0.0087 (0.5°).
    pub window_floor_theta: f64,
    /// The linear search window's half width is `3σ` of the accumulated uncertainty, but at
    /// least this (m). Default 0.3.
    pub min_linear_window: f64,
    /// … and at most this (m). Default 3.0.
    pub max_linear_window: f64,
    /// The angular window's half width is `3σ`, but at least this (rad). Default 0.0524
    /// (3°).
    pub min_angular_window: f64,
    /// … and at most this (rad). Default 0.349 (20°).
    pub max_angular_window: f64,
    /// A keyframe whose index is a multiple of this (count; 0: never), when no long loop
    /// closure in use (one tying a submap whose window uncertainty exceeds the window's
    /// clamps) was found at any of the last `wide_search_every` keyframes, also searches
    /// wide: those submaps, within `3σ` clamped to `wide_linear_window` and
    /// `wide_angular_window`, accepting `wide_min_score`, and keeping a match only when
    /// `wide_confirmations` keyframes before it agree. A loop longer than the clamps allow
    /// then still closes, at a cost paid only while no long loop closes. Default 20
    /// (about 10 m at 0.5 m keyframes).
    pub wide_search_every: usize,
    /// The wide search's linear half width is `3σ`, at most this (m, at least
    /// `max_linear_window`); it reaches submaps whose origin lies within
    /// `max_search_distance` plus the window of the keyframe. Default 10.
    pub wide_linear_window: f64,
    /// … its angular half width, at most this (rad, at least `max_angular_window`).
    /// Default 0.785 (45°).
    pub wide_angular_window: f64,
    /// A wide match is accepted at this score (in [0, 1]). Default 0.6, as `min_score`:
    /// docs/ALGORITHMS.md §9.1 ("Loops longer than the window") has what a higher one
    /// cost.
    pub wide_min_score: f64,
    /// A wide match is kept only when this many matchable keyframes before it, among its
    /// last `wide_search_every`, also match the same submap, in the smallest window around
    /// where the wide match puts them (count). Default 2.
    pub wide_confirmations: usize,
    /// Levels of the max-pooled grids for branch and bound (count, 1..=12): the coarsest
    /// pools `2^(depth−1)` cells a side. Default 7 (64 cells, 3.2 m at 5 cm).
    pub depth: usize,
    /// A match is accepted when its score, the mean probability of the submap cells under
    /// the scan's points, is at least this (in [0, 1]). Default 0.6; see
    /// docs/ALGORITHMS.md §9.1 for the scores true and false matches reach.
    pub min_score: f64,
    /// Fewest scan points a keyframe needs to be matched (count). Default 20.
    pub min_points: usize,
    /// Standard deviation added in quadrature to the front end's between-keyframe
    /// covariance, position (m). Default 0.008: the chain's noise the variance components
    /// of the three Freiburg logs' solved graphs measure (docs/ALGORITHMS.md §9.1).
    pub between_floor_xy: f64,
    /// … heading (rad). Default 0.0035 (0.2°).
    pub between_floor_theta: f64,
    /// Consecutive keyframes are also tied by the odometry's own motion between them,
    /// with the motion model's covariance, unless it disagrees with the front end's
    /// beyond `loop_chi2_gate` (docs/ALGORITHMS.md §9.1, "Odometry constraints").
    /// Default true.
    pub odometry_constraints: bool,
    /// At the end of the data, the odometry constraints are weighted by their variance
    /// factor against the other constraints' before the last solve
    /// ([`super::PoseGraphMapper::fit_odometry_weight`]; docs/ALGORITHMS.md §9.1, "The
    /// last solve"). Default true.
    pub fit_odometry_at_end: bool,
    /// A loop closure's position standard deviation in cells at score 1; it grows as
    /// `1/score` (cells). Default 1.
    pub loop_sigma_cells: f64,
    /// The least share of the best-held direction's position information a loop closure
    /// keeps in its flattest direction (the match's curvature shapes it; in (0, 1], 1:
    /// the same in every direction). Default 0.01.
    pub loop_shape_floor: f64,
    /// Scale `c` of the Cauchy weight `1 / (1 + χ²/c²)` of a loop closure between solves
    /// (χ² of its nominal information; dimensionless). Default 3.
    pub loop_kernel_scale: f64,
    /// A loop closure whose χ² exceeds this after the reweighting is left out of the
    /// solution (dimensionless). Default 16.27, χ²₃ at 99.9 %.
    pub loop_chi2_gate: f64,
    /// Most reweighting rounds per solve (count, ≥ 1). Default 8.
    pub robust_rounds: usize,
    /// Most Levenberg–Marquardt iterations per round (count, ≥ 1). Default 50.
    pub max_iterations: usize,
    /// A solve is due after this many keyframes without one, new closure or not (count,
    /// ≥ 1). Default 50.
    pub solve_every: usize,
}

impl Default for LoopClosureConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            delay_keyframes: 2,
            gauge_radius: 3.0,
            resolution: 0.05,
            keyframes_per_submap: 30,
            max_range: 20.0,
            l_occupied: 0.4,
            l_free: -0.1,
            l_clamp: 2.2,
            search_every: 1,
            earlier_keyframes: 30,
            max_search_distance: 15.0,
            min_linear_window: 0.3,
            max_linear_window: 3.0,
            min_angular_window: 3f64.to_radians(),
            max_angular_window: 20f64.to_radians(),
            wide_search_every: 20,
            wide_linear_window: 10.0,
            wide_angular_window: 45f64.to_radians(),
            wide_min_score: 0.6,
            wide_confirmations: 2,
            depth: 7,
            min_score: 0.6,
            min_points: 20,
            window_floor_xy: 0.02,
            window_floor_theta: 0.5f64.to_radians(),
            between_floor_xy: 0.008,
            between_floor_theta: 0.2f64.to_radians(),
            odometry_constraints: true,
            fit_odometry_at_end: true,
            loop_sigma_cells: 1.0,
            loop_shape_floor: 0.01,
            loop_kernel_scale: 3.0,
            loop_chi2_gate: 16.27,
            robust_rounds: 8,
            max_iterations: 50,
            solve_every: 50,
        }
    }
}

/// Largest [`LoopClosureConfig::depth`] accepted.
pub const MAX_DEPTH: usize = 12;

impl LoopClosureConfig {
    /// `(between_floor_xy, between_floor_theta)`: the floor of the graph's consecutive
    /// and odometry constraints.
    pub(crate) fn chain_floor(&self) -> (f64, f64) {
        (self.between_floor_xy, self.between_floor_theta)
    }

    /// `(window_floor_xy, window_floor_theta)`: the floor of the search window's steps.
    pub(crate) fn window_floor(&self) -> (f64, f64) {
        (self.window_floor_xy, self.window_floor_theta)
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        positive("loop_closure.resolution", self.resolution)?;
        non_negative("loop_closure.gauge_radius", self.gauge_radius)?;
        at_least_one(
            "loop_closure.keyframes_per_submap",
            self.keyframes_per_submap,
        )?;
        positive("loop_closure.max_range", self.max_range)?;
        positive("loop_closure.l_occupied", self.l_occupied)?;
        require(
            self.l_free < 0.0 && self.l_free.is_finite(),
            "loop_closure.l_free",
            || format!("must be finite and < 0, got {}", self.l_free),
        )?;
        positive("loop_closure.l_clamp", self.l_clamp)?;
        at_least_one("loop_closure.search_every", self.search_every)?;
        positive("loop_closure.max_search_distance", self.max_search_distance)?;
        positive("loop_closure.min_linear_window", self.min_linear_window)?;
        positive("loop_closure.max_linear_window", self.max_linear_window)?;
        require(
            self.min_linear_window <= self.max_linear_window,
            "loop_closure.min_linear_window",
            || "must not exceed max_linear_window".into(),
        )?;
        positive("loop_closure.min_angular_window", self.min_angular_window)?;
        in_range(
            "loop_closure.max_angular_window",
            self.max_angular_window,
            self.min_angular_window,
            std::f64::consts::PI,
        )?;
        require(
            self.wide_linear_window.is_finite()
                && self.wide_linear_window >= self.max_linear_window,
            "loop_closure.wide_linear_window",
            || "must be finite and at least max_linear_window".into(),
        )?;
        in_range(
            "loop_closure.wide_angular_window",
            self.wide_angular_window,
            self.max_angular_window,
            std::f64::consts::PI,
        )?;
        in_range("loop_closure.wide_min_score", self.wide_min_score, 0.0, 1.0)?;
        require(
            (1..=MAX_DEPTH).contains(&self.depth),
            "loop_closure.depth",
            || format!("must lie in 1..={MAX_DEPTH}, got {}", self.depth),
        )?;
        in_range("loop_closure.min_score", self.min_score, 0.0, 1.0)?;
        positive("loop_closure.window_floor_xy", self.window_floor_xy)?;
        positive("loop_closure.window_floor_theta", self.window_floor_theta)?;
        positive("loop_closure.between_floor_xy", self.between_floor_xy)?;
        positive("loop_closure.between_floor_theta", self.between_floor_theta)?;
        positive("loop_closure.loop_sigma_cells", self.loop_sigma_cells)?;
        in_range(
            "loop_closure.loop_shape_floor",
            self.loop_shape_floor,
            f64::MIN_POSITIVE,
            1.0,
        )?;
        positive("loop_closure.loop_kernel_scale", self.loop_kernel_scale)?;
        positive("loop_closure.loop_chi2_gate", self.loop_chi2_gate)?;
        at_least_one("loop_closure.robust_rounds", self.robust_rounds)?;
        at_least_one("loop_closure.max_iterations", self.max_iterations)?;
        at_least_one("loop_closure.solve_every", self.solve_every)
    }
}

/// Checks that a count is at least one.
fn at_least_one(name: &'static str, value: usize) -> Result<()> {
    require(value >= 1, name, || "must be >= 1".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Error;

    /// The name `config`'s validation refuses it for.
    fn refused(config: LoopClosureConfig) -> &'static str {
        match config.validate() {
            Err(Error::InvalidParameter { name, .. }) => name,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        LoopClosureConfig::default().validate().unwrap();
        let bad = LoopClosureConfig {
            min_linear_window: 4.0,
            ..LoopClosureConfig::default()
        };
        assert_eq!(refused(bad), "loop_closure.min_linear_window");
        let narrow = LoopClosureConfig {
            wide_linear_window: 2.0,
            ..LoopClosureConfig::default()
        };
        assert_eq!(refused(narrow), "loop_closure.wide_linear_window");
        let unbounded = LoopClosureConfig {
            window_floor_theta: 0.0,
            ..LoopClosureConfig::default()
        };
        assert_eq!(refused(unbounded), "loop_closure.window_floor_theta");
        let bad = LoopClosureConfig {
            depth: 0,
            ..LoopClosureConfig::default()
        };
        assert!(bad.validate().is_err());
        let parsed: LoopClosureConfig = toml::from_str("min_score = 0.7").unwrap();
        assert_eq!(parsed.min_score, 0.7);
        assert!(toml::from_str::<LoopClosureConfig>("min_scor = 0.7").is_err());
    }
}
