//! Trajectory scoring against ground truth: a track sampled at any stamp
//! ([`interpolate`]), the errors of a trajectory ([`trajectory`]: ATE, heading, final
//! error, RPE), the stamps it is scored at ([`ScoreAt`]) and the rigid alignment that
//! brings an estimate into the truth's frame first ([`AlignMode`], [`Alignment`]).

use crate::align::{Se2, umeyama_se2};
use crate::recording::{Estimate, Recording, StampedPose};
use crate::relations::RelationErrors;
use crate::rpe::{RPE_DELTAS_M, Rpe, rpe};
use fastslam_estimation::wrap_angle;
use serde::{Deserialize, Serialize};

/// How the estimate is brought into the truth's frame before it is scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AlignMode {
    /// No alignment: in simulation the map frame is the true frame.
    #[default]
    None,
    /// Least-squares rigid alignment (Umeyama, SE(2)) of each trajectory onto the truth,
    /// for external data whose estimate starts in a frame of its own.
    Se2,
}

/// The alignment that was applied before scoring.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Alignment {
    /// `none` or `se2`.
    pub method: AlignMode,
    /// Transform applied to the estimate (poses, covariances and map); identity for `none`.
    pub estimate: Se2,
    /// Transform applied to dead reckoning; identity for `none`.
    pub dead_reckoning: Se2,
}

impl Default for Alignment {
    fn default() -> Self {
        Self {
            method: AlignMode::None,
            estimate: Se2::IDENTITY,
            dead_reckoning: Se2::IDENTITY,
        }
    }
}

/// Where the trajectory is compared with the truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ScoreAt {
    /// At every pose estimate, the truth interpolated (dense truth: simulation, Vicon).
    #[default]
    Estimates,
    /// At every truth sample within the estimate's span, the estimate interpolated
    /// (sparse truth such as GPS fixes: no error from interpolating between far fixes).
    Truth,
}

/// The scores of one trajectory: its errors against ground truth at the scored stamps and
/// its relation errors.
///
/// The truth-based numbers (`ate_rmse_m` to `rpe`) are measured only in a run with ground
/// truth; in a run without, they are NaN (`rpe` empty) and `metrics.json` leaves them out
/// (see [`crate::Metrics::ground_truth`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryMetrics {
    /// Poses scored: with ground truth, those compared with it (at the estimate stamps, or
    /// the truth samples with [`ScoreAt::Truth`]); without, every pose of the trajectory.
    pub poses: usize,
    /// Absolute trajectory error, RMSE of the position error (m), after the alignment
    /// in [`crate::Metrics::alignment`] (none in simulation).
    pub ate_rmse_m: f64,
    /// Largest position error (m).
    pub max_error_m: f64,
    /// Position error of the last pose (m).
    pub final_error_m: f64,
    /// RMSE of the heading error (rad).
    pub heading_rmse_rad: f64,
    /// Relative pose error over each distance of [`RPE_DELTAS_M`].
    pub rpe: Vec<Rpe>,
    /// Errors against a relations file (see [`crate::relations`]); `None` without one,
    /// or when no relation had poses near both its times.
    pub relations: Option<RelationErrors>,
}

impl TrajectoryMetrics {
    /// The scores of a trajectory of `poses` poses that was not compared with any truth.
    pub fn unmeasured(poses: usize) -> Self {
        Self {
            poses,
            ate_rmse_m: f64::NAN,
            max_error_m: f64::NAN,
            final_error_m: f64::NAN,
            heading_rmse_rad: f64::NAN,
            rpe: Vec::new(),
            relations: None,
        }
    }
}

/// The recording as it is scored: `rec` itself, or for [`ScoreAt::Truth`] a copy whose
/// estimates are the estimate interpolated at the truth's stamps (each with the
/// covariance of the estimate before it).
pub fn scored_at(rec: &Recording, at: ScoreAt) -> Recording {
    let mut out = rec.clone();
    if at == ScoreAt::Truth {
        let poses: Vec<StampedPose> = rec.estimates.iter().map(|e| e.pose).collect();
        out.estimates = (rec.truth.iter())
            .filter_map(|t| {
                let pose = interpolate(&poses, t.stamp_ns)?;
                let before = poses.partition_point(|p| p.stamp_ns <= t.stamp_ns);
                let covariance = rec.estimates[before.checked_sub(1)?].covariance;
                Some(Estimate { pose, covariance })
            })
            .collect();
    }
    out
}

/// The transforms that bring `rec` into the truth's frame as `mode` says. Each
/// trajectory is fitted to the truth at its own stamps; one that cannot be fitted (fewer
/// than two poses with truth) keeps the identity.
pub fn fit_alignment(rec: &Recording, mode: AlignMode) -> Alignment {
    if mode == AlignMode::None {
        return Alignment::default();
    }
    Alignment {
        method: mode,
        estimate: fit_se2(rec.estimates.iter().map(|e| &e.pose), &rec.truth),
        dead_reckoning: fit_se2(&rec.dead_reckoning, &rec.truth),
    }
}

/// The least-squares rigid transform that brings `poses` onto `truth` (interpolated at
/// their stamps); the identity when fewer than two poses have truth.
pub fn fit_se2<'a>(poses: impl IntoIterator<Item = &'a StampedPose>, truth: &[StampedPose]) -> Se2 {
    let (est, tru): (Vec<_>, Vec<_>) = (poses.into_iter())
        .filter_map(|p| interpolate(truth, p.stamp_ns).map(|t| ((p.x, p.y), (t.x, t.y))))
        .unzip();
    umeyama_se2(&est, &tru).unwrap_or(Se2::IDENTITY)
}

impl Alignment {
    /// A copy of `rec` with the estimate (poses, covariances, map) and dead reckoning
    /// transformed into the truth's frame.
    pub fn apply(&self, rec: &Recording) -> Recording {
        let mut out = rec.clone();
        for e in &mut out.estimates {
            *e = Estimate {
                pose: self.estimate.apply_pose(&e.pose),
                covariance: self.estimate.apply_covariance(&e.covariance),
            };
        }
        for p in &mut out.dead_reckoning {
            *p = self.dead_reckoning.apply_pose(p);
        }
        for l in &mut out.map {
            *l = self.estimate.apply_landmark(l);
        }
        out
    }
}

/// The pose of `track` (sorted by stamp) at `stamp_ns`, linearly interpolated between
/// its neighbours (a sample at exactly `stamp_ns` is returned as it is); `None` outside
/// the track.
pub fn interpolate(track: &[StampedPose], stamp_ns: u64) -> Option<StampedPose> {
    let i = track.partition_point(|p| p.stamp_ns < stamp_ns);
    let after = track.get(i)?;
    if after.stamp_ns == stamp_ns {
        return Some(*after);
    }
    let before = track.get(i.checked_sub(1)?)?;
    let f = (stamp_ns - before.stamp_ns) as f64 / (after.stamp_ns - before.stamp_ns) as f64;
    Some(StampedPose {
        stamp_ns,
        x: before.x + f * (after.x - before.x),
        y: before.y + f * (after.y - before.y),
        theta: wrap_angle(before.theta + f * wrap_angle(after.theta - before.theta)),
    })
}

/// `track` sampled at each stamp of `at` that it covers ([`interpolate`]).
pub fn sampled_at(track: &[StampedPose], at: &[StampedPose]) -> Vec<StampedPose> {
    at.iter()
        .filter_map(|p| interpolate(track, p.stamp_ns))
        .collect()
}

/// Position error (m), heading error (rad) and the true pose at `p`'s stamp; `None`
/// when the truth does not cover the stamp.
pub fn error(p: &StampedPose, truth: &[StampedPose]) -> Option<(f64, f64, StampedPose)> {
    let t = interpolate(truth, p.stamp_ns)?;
    Some((
        (p.x - t.x).hypot(p.y - t.y),
        wrap_angle(p.theta - t.theta),
        t,
    ))
}

/// Position and heading errors of `poses` against `truth` at the poses' stamps.
pub fn trajectory(poses: &[StampedPose], truth: &[StampedPose]) -> TrajectoryMetrics {
    let (mut matched, mut truth_at, mut errors) = (Vec::new(), Vec::new(), Vec::new());
    for p in poses {
        if let Some((d, h, t)) = error(p, truth) {
            matched.push(*p);
            truth_at.push(t);
            errors.push((d, h));
        }
    }
    let rms = |f: &dyn Fn(&(f64, f64)) -> f64| {
        crate::stats::rms(&errors.iter().map(f).collect::<Vec<_>>())
    };
    TrajectoryMetrics {
        poses: errors.len(),
        ate_rmse_m: rms(&|e| e.0),
        max_error_m: errors.iter().map(|e| e.0).fold(f64::NAN, f64::max),
        final_error_m: errors.last().map_or(f64::NAN, |e| e.0),
        heading_rmse_rad: rms(&|e| e.1),
        rpe: RPE_DELTAS_M
            .iter()
            .map(|&d| rpe(&matched, &truth_at, d))
            .collect(),
        relations: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(t: u64, x: f64, y: f64, theta: f64) -> StampedPose {
        StampedPose {
            stamp_ns: t,
            x,
            y,
            theta,
        }
    }

    #[test]
    fn interpolation_is_linear_and_wraps_heading() {
        let track = [pose(0, 0.0, 0.0, 3.0), pose(10, 10.0, 0.0, -3.0)];
        let mid = interpolate(&track, 5).unwrap();
        assert!((mid.x - 5.0).abs() < 1e-12);
        assert!(
            (mid.theta.abs() - std::f64::consts::PI).abs() < 1e-9,
            "{}",
            mid.theta
        );
        assert_eq!(interpolate(&track, 11), None);
        assert_eq!(interpolate(&track, 10), Some(track[1]));
    }

    #[test]
    fn a_sample_at_the_stamp_is_taken_exactly() {
        // Headings near ±π and a stamp between two others: what is at the stamp is
        // returned bit for bit, not re-interpolated.
        let track = [
            pose(0, 0.1, 0.2, 3.1),
            pose(7, 1.0 / 3.0, 2.0 / 3.0, -3.1),
            pose(10, 10.0, 0.0, -3.0),
        ];
        let at = [pose(7, 0.0, 0.0, 0.0), pose(20, 0.0, 0.0, 0.0)];
        assert_eq!(sampled_at(&track, &at), [track[1]]);
    }

    #[test]
    fn ate_of_a_constant_offset_is_the_offset() {
        let truth: Vec<_> = (0..10).map(|k| pose(k, k as f64, 0.0, 0.0)).collect();
        let est: Vec<_> = (0..10).map(|k| pose(k, k as f64, 0.5, 0.1)).collect();
        let m = trajectory(&est, &truth);
        assert_eq!(m.poses, 10);
        assert!((m.ate_rmse_m - 0.5).abs() < 1e-12 && (m.final_error_m - 0.5).abs() < 1e-12);
        assert!((m.heading_rmse_rad - 0.1).abs() < 1e-12);
        assert_eq!(m.relations, None);
    }
}
