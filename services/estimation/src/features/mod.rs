//! Landmark extraction from raw 2D scans (docs/ALGORITHMS.md §2): poles and tree trunks as
//! range–bearing observations of their centres, with their diameters.
//!
//! The pipeline, one stage per module:
//! 1. [`segment`]: cut the scan into runs of consecutive returns wherever the range
//!    jumps, and keep runs that stand in front of their background on both sides (a run
//!    next to a closer return may be a partly hidden object whose width is unknown);
//! 2. [`circle`]: fit a circle to each run — the radius from the run's angular width, then
//!    a geometric least-squares fit of the centre (and of the radius when the run has
//!    enough points);
//! 3. keep the circles of plausible pole diameter whose fit residual is small, and report
//!    each as an observation of its centre with unknown association.
//!
//! Decisions the spec leaves open: a run whose neighbour is the edge of a scan that does
//! not cover a full turn is dropped (it may be cut); on a full-turn scan the first and
//! last beam are neighbours for that check, but runs are not joined across the seam, so a
//! pole straddling it is dropped too.

pub mod circle;
pub mod segment;

use crate::Result;
use crate::check::{non_negative, positive, require};
use crate::scan::RangeScan;
use serde::{Deserialize, Serialize};

/// Extraction settings. Defaults suit a 0.25°–0.5° scanner looking at poles of 0.1–1 m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExtractorConfig {
    /// Returns farther than this are ignored (m): far poles get too few beams to be told
    /// from clutter.
    pub max_range: f64,
    /// Consecutive returns belong to one run while their ranges differ by at most
    /// `jump_abs + jump_rel · r` (m + dimensionless · m).
    pub jump_abs: f64,
    /// Relative part of the jump threshold (dimensionless).
    pub jump_rel: f64,
    /// Fewest returns a run needs to be considered.
    pub min_points: usize,
    /// Runs with more returns than this are walls or hedges, not poles.
    pub max_points: usize,
    /// Runs with at least this many returns also get their radius fitted; shorter ones
    /// keep the radius from their angular width.
    pub free_radius_points: usize,
    /// Smallest plausible pole diameter (m).
    pub min_diameter: f64,
    /// Largest plausible pole diameter (m).
    pub max_diameter: f64,
    /// Largest root-mean-square distance of a run's points from the fitted circle (m).
    pub max_rms: f64,
}

impl Default for ExtractorConfig {
    fn default() -> Self {
        Self {
            max_range: 25.0,
            jump_abs: 0.3,
            jump_rel: 0.02,
            min_points: 3,
            max_points: 200,
            free_radius_points: 8,
            min_diameter: 0.08,
            max_diameter: 1.2,
            max_rms: 0.05,
        }
    }
}

impl ExtractorConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<()> {
        positive("features.max_range", self.max_range)?;
        positive("features.jump_abs", self.jump_abs)?;
        non_negative("features.jump_rel", self.jump_rel)?;
        require(self.min_points >= 1, "features.min_points", || {
            "must be >= 1".into()
        })?;
        require(
            self.max_points >= self.min_points,
            "features.max_points",
            || "must be >= min_points".into(),
        )?;
        require(
            self.free_radius_points >= 3,
            "features.free_radius_points",
            || "must be >= 3 (three points define a circle)".into(),
        )?;
        non_negative("features.min_diameter", self.min_diameter)?;
        positive("features.max_diameter", self.max_diameter)?;
        require(
            self.max_diameter > self.min_diameter,
            "features.max_diameter",
            || "must be > min_diameter".into(),
        )?;
        positive("features.max_rms", self.max_rms)
    }
}

/// One extracted pole: its centre as range and bearing from the sensor, and its size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feature {
    /// Range to the centre (m).
    pub range: f64,
    /// Bearing of the centre (rad, sensor frame, counter-clockwise, 0 = forward).
    pub bearing: f64,
    /// Fitted diameter (m).
    pub diameter: f64,
    /// Returns in the run.
    pub points: usize,
    /// Root-mean-square distance of the returns from the circle (m).
    pub rms: f64,
}

/// Finds the poles in `scan`, in beam order.
///
/// # Performance
/// O(B) for B beams: one pass to segment, a few Gauss–Newton iterations per run.
///
/// # Example
/// ```
/// use fastslam_estimation::features::{extract, ExtractorConfig};
/// use fastslam_estimation::scan::RangeScan;
/// // A pole of radius 0.25 m, 5 m ahead, seen by 0.25° beams; nothing behind it.
/// let increment = 0.25f64.to_radians();
/// let ranges: Vec<f32> = (0..181)
///     .map(|i| {
///         let a = -0.4 + i as f64 * increment;
///         let (along, across) = (5.0 * a.cos(), 5.0 * a.sin());
///         let d2 = 0.25f64.powi(2) - across * across;
///         if d2 >= 0.0 { (along - d2.sqrt()) as f32 } else { f32::INFINITY }
///     })
///     .collect();
/// let scan = RangeScan { angle_min: -0.4, angle_increment: increment, range_min: 0.1, range_max: 30.0, ranges: &ranges };
/// let poles = extract(&scan, &ExtractorConfig::default());
/// assert_eq!(poles.len(), 1);
/// assert!((poles[0].range - 5.0).abs() < 0.01 && poles[0].bearing.abs() < 0.005);
/// assert!((poles[0].diameter - 0.5).abs() < 0.05);
/// ```
pub fn extract(scan: &RangeScan<'_>, config: &ExtractorConfig) -> Vec<Feature> {
    segment::runs(scan, config)
        .into_iter()
        // 1. Runs in front of their background, of a size a pole can have.
        .filter(|run| {
            (config.min_points..=config.max_points).contains(&run.points.len())
                && segment::stands_out(scan, run, config)
        })
        // 2. A circle through each run.
        .filter_map(|run| circle::fit(scan, &run, config.free_radius_points))
        // 3. Plausible poles only.
        .filter(|f| {
            (config.min_diameter..=config.max_diameter).contains(&f.diameter)
                && f.rms <= config.max_rms
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ray-casts a scan of `circles` (x, y, radius) and, optionally, a wall at x = `wall`.
    fn scene(circles: &[(f64, f64, f64)], wall: Option<f64>, beams: usize) -> Vec<f32> {
        let increment = std::f64::consts::PI / (beams - 1) as f64;
        (0..beams)
            .map(|i| {
                let a = -std::f64::consts::FRAC_PI_2 + i as f64 * increment;
                let (c, s) = (a.cos(), a.sin());
                let mut best = f64::INFINITY;
                for &(x, y, r) in circles {
                    let along = x * c + y * s;
                    let across2 = (x * x + y * y) - along * along;
                    if across2 <= r * r && along > 0.0 {
                        best = best.min(along - (r * r - across2).sqrt());
                    }
                }
                if let Some(w) = wall
                    && c > 1e-9
                {
                    best = best.min(w / c);
                }
                best as f32
            })
            .collect()
    }

    fn scan(ranges: &[f32]) -> RangeScan<'_> {
        RangeScan {
            angle_min: -std::f64::consts::FRAC_PI_2,
            angle_increment: std::f64::consts::PI / (ranges.len() - 1) as f64,
            range_min: 0.1,
            range_max: 30.0,
            ranges,
        }
    }

    #[test]
    fn poles_in_front_of_a_wall_are_found_and_the_wall_is_not() {
        let poles = [(6.0, 2.0, 0.2), (10.0, -3.0, 0.35), (4.0, 1.0, 0.1)];
        let ranges = scene(&poles, Some(15.0), 721);
        let found = extract(&scan(&ranges), &ExtractorConfig::default());
        assert_eq!(found.len(), 3, "{found:?}");
        for f in &found {
            let (x, y) = (f.range * f.bearing.cos(), f.range * f.bearing.sin());
            let (px, py, r) = poles
                .iter()
                .copied()
                .min_by(|a, b| {
                    let d = |p: &(f64, f64, f64)| (p.0 - x).hypot(p.1 - y);
                    d(a).total_cmp(&d(b))
                })
                .unwrap();
            assert!((px - x).hypot(py - y) < 0.03, "{f:?}");
            assert!((f.diameter - 2.0 * r).abs() < 0.06, "{f:?}");
        }
    }

    #[test]
    fn a_partly_hidden_pole_and_a_pole_at_the_scan_edge_are_dropped() {
        // The far pole is half hidden by the near one; the third sits at the right edge.
        let ranges = scene(
            &[(5.0, 0.0, 0.3), (9.0, 0.45, 0.3), (0.05, -4.0, 0.3)],
            None,
            721,
        );
        let found = extract(&scan(&ranges), &ExtractorConfig::default());
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((found[0].range - 5.0).abs() < 0.03);
    }

    #[test]
    fn a_wall_corner_and_bad_beams_give_no_pole() {
        let mut ranges = scene(&[], Some(8.0), 721);
        // A box corner (x ≥ 4, y ≥ 1) pokes out in front of the wall.
        let s = scan(&ranges);
        let corner: Vec<f32> = (0..ranges.len())
            .map(|i| {
                let a = s.angle(i);
                let (c, sn) = (a.cos(), a.sin());
                let t1 = if c > 0.0 { 4.0 / c } else { f64::INFINITY };
                let t2 = if sn > 0.0 { 1.0 / sn } else { f64::INFINITY };
                let t = t1.max(t2);
                if (c * t >= 3.999) && (sn * t >= 0.999) && t < 10.0 {
                    t as f32
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        for (r, c) in ranges.iter_mut().zip(corner) {
            *r = r.min(c);
        }
        ranges[100] = f32::NAN;
        ranges[101] = f32::NEG_INFINITY;
        let found = extract(&scan(&ranges), &ExtractorConfig::default());
        assert!(found.is_empty(), "{found:?}");
    }

    #[test]
    fn config_rejects_inconsistent_limits() {
        assert!(ExtractorConfig::default().validate().is_ok());
        let bad = ExtractorConfig {
            min_diameter: 2.0,
            ..ExtractorConfig::default()
        };
        assert!(bad.validate().is_err());
        let bad = ExtractorConfig {
            max_range: f64::NAN,
            ..ExtractorConfig::default()
        };
        assert!(bad.validate().is_err());
    }
}
