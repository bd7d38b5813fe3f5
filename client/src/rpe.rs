//! Relative pose error (RPE) over fixed travelled distances: how much the estimate's
//! motion between two poses differs from the true motion, independent of where the whole
//! trajectory sits (drift per distance rather than accumulated error).

use crate::align::Se2;
use crate::recording::StampedPose;
use crate::stats::rms;
use serde::{Deserialize, Serialize};

/// Distances over which the RPE is reported (m): a step, a stretch, a long stretch.
pub const RPE_DELTAS_M: [f64; 3] = [1.0, 10.0, 100.0];

/// RPE over one travelled distance.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Rpe {
    /// Distance travelled (along the true path) between the two poses of a pair (m).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub delta_m: f64,
    /// Pose pairs compared (one per start pose that has a pose `delta_m` further on).
    pub pairs: usize,
    /// RMSE of the translation part of the relative error (m).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub translation_rmse_m: f64,
    /// RMSE of the rotation part of the relative error (rad).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub rotation_rmse_rad: f64,
}

/// RPE of `estimate` against `truth`, matched pose by pose (same length, same stamps),
/// over the travelled distance `delta_m`.
///
/// For every start pose `i`, `j` is the first later pose at least `delta_m` further
/// along the true path; the error is `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` with `P` the
/// estimate and `Q` the truth (as `evo_rpe --delta d --delta_unit m --all_pairs`).
/// Starts without such a `j` (the last stretch) are skipped.
pub fn rpe(estimate: &[StampedPose], truth: &[StampedPose], delta_m: f64) -> Rpe {
    let n = estimate.len().min(truth.len());
    let mut along = Vec::with_capacity(n);
    let mut travelled = 0.0;
    for k in 0..n {
        if k > 0 {
            travelled += (truth[k].x - truth[k - 1].x).hypot(truth[k].y - truth[k - 1].y);
        }
        along.push(travelled);
    }
    let (mut trans, mut rot) = (Vec::new(), Vec::new());
    let mut j = 0;
    for i in 0..n {
        // `j` only moves forward as `i` does: O(n) over all starts.
        j = j.max(i + 1);
        while j < n && along[j] - along[i] < delta_m {
            j += 1;
        }
        if j >= n {
            break;
        }
        let moved = |t: &[StampedPose]| Se2::of(&t[i]).inverse().compose(&Se2::of(&t[j]));
        let e = moved(truth).inverse().compose(&moved(estimate));
        trans.push(e.x.hypot(e.y));
        rot.push(e.theta.abs());
    }
    Rpe {
        delta_m,
        pairs: trans.len(),
        translation_rmse_m: rms(&trans),
        rotation_rmse_rad: rms(&rot),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(k: u64, x: f64, y: f64, theta: f64) -> StampedPose {
        StampedPose {
            stamp_ns: k,
            x,
            y,
            theta,
        }
    }

    /// A straight drive along +x, one pose per metre.
    fn straight(n: u64) -> Vec<StampedPose> {
        (0..n).map(|k| pose(k, k as f64, 0.0, 0.0)).collect()
    }

    #[test]
    fn rpe_ignores_a_constant_offset() {
        let truth = straight(30);
        let shifted: Vec<_> = truth
            .iter()
            .map(|p| pose(p.stamp_ns, p.x + 5.0, p.y - 2.0, 0.0))
            .collect();
        let r = rpe(&shifted, &truth, 10.0);
        assert_eq!(r.pairs, 20);
        assert!(r.translation_rmse_m.abs() < 1e-12 && r.rotation_rmse_rad.abs() < 1e-12);
    }

    #[test]
    fn rpe_of_a_ten_percent_scale_error_is_ten_percent_of_the_distance() {
        let truth = straight(30);
        let stretched: Vec<_> = truth
            .iter()
            .map(|p| pose(p.stamp_ns, 1.1 * p.x, 0.0, 0.0))
            .collect();
        for delta in [1.0, 10.0] {
            let r = rpe(&stretched, &truth, delta);
            assert_eq!(r.pairs, 30 - delta as usize);
            assert!((r.translation_rmse_m - 0.1 * delta).abs() < 1e-9, "{r:?}");
            assert!(r.rotation_rmse_rad.abs() < 1e-12);
        }
    }

    #[test]
    fn rpe_of_a_heading_drift_sees_rotation_and_the_sideways_error_it_causes() {
        // The estimate turns 0.01 rad per metre while the truth drives straight: over a
        // 10 m pair, the relative heading error is 0.1 rad whatever the start.
        let truth = straight(40);
        let mut drifting = vec![pose(0, 0.0, 0.0, 0.0)];
        for k in 1..40 {
            let prev: StampedPose = drifting[k - 1];
            let step = Se2::of(&prev).compose(&Se2 {
                x: 1.0,
                y: 0.0,
                theta: 0.01,
            });
            drifting.push(pose(k as u64, step.x, step.y, step.theta));
        }
        let r = rpe(&drifting, &truth, 10.0);
        assert_eq!(r.pairs, 30);
        assert!((r.rotation_rmse_rad - 0.1).abs() < 1e-9, "{r:?}");
        // The end of a 10 m arc that turns 0.01 rad per step is about 0.45 m off the line.
        assert!((0.4..0.5).contains(&r.translation_rmse_m), "{r:?}");
    }

    #[test]
    fn rpe_without_a_long_enough_stretch_has_no_pairs() {
        let truth = straight(5);
        let r = rpe(&truth, &truth, 10.0);
        assert_eq!(r.pairs, 0);
        assert!(r.translation_rmse_m.is_nan());
    }
}
