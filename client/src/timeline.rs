//! The run as a time series, one row per pose estimate: the estimate, the truth at its
//! stamp, errors, NEES, the filter's status and the latency of that step. Written as
//! `metrics.csv` and drawn in the error plot.

use crate::metrics::{error, interpolate, nees};
use crate::recording::{Recording, StampedPose};
use std::collections::HashMap;

/// One pose estimate and everything measured at its stamp. Values that are unknown for
/// this estimate (no truth, no status, no latency) are NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// The estimate (its stamp is the row's).
    pub estimate: StampedPose,
    /// Ground truth at the stamp, if known.
    pub truth: Option<StampedPose>,
    /// Position error of the estimate (m).
    pub position_error_m: f64,
    /// Heading error of the estimate (rad, wrapped).
    pub heading_error_rad: f64,
    /// Position error of dead reckoning at the same stamp (m).
    pub dead_reckoning_error_m: f64,
    /// Standard deviations of the estimate's x, y (m) and heading (rad).
    pub sigma: [f64; 3],
    /// NEES of the pose.
    pub nees: f64,
    /// Effective sample size of the step, before resampling.
    pub n_eff: f64,
    /// Distinct particles after the step.
    pub distinct: f64,
    /// 1 when the step resampled, 0 when not.
    pub resampled: f64,
    /// Landmarks in the service's best map.
    pub landmarks: f64,
    /// Filter update time the service reported (ms).
    pub step_time_ms: f64,
    /// End-to-end latency of the step (ms).
    pub latency_ms: f64,
}

/// The rows of `rec`, in the order the estimates arrived.
pub fn timeline(rec: &Recording) -> Vec<Row> {
    let status: HashMap<u64, _> = rec.status.iter().map(|s| (s.stamp_ns, s)).collect();
    let latency: HashMap<u64, f64> = rec.latencies.iter().copied().collect();
    rec.estimates
        .iter()
        .map(|e| {
            let p = e.pose;
            let err = error(&p, &rec.truth);
            let dead_reckoning_error_m = interpolate(&rec.dead_reckoning, p.stamp_ns)
                .and_then(|d| error(&d, &rec.truth))
                .map_or(f64::NAN, |d| d.0);
            let s = status.get(&p.stamp_ns);
            let field =
                |f: &dyn Fn(&crate::recording::StatusSample) -> f64| s.map_or(f64::NAN, |s| f(s));
            Row {
                estimate: p,
                truth: err.map(|e| e.2),
                position_error_m: err.map_or(f64::NAN, |e| e.0),
                heading_error_rad: err.map_or(f64::NAN, |e| e.1),
                dead_reckoning_error_m,
                sigma: [0, 4, 8].map(|i| e.covariance[i].max(0.0).sqrt()),
                nees: nees(e, &rec.truth).flatten().unwrap_or(f64::NAN),
                n_eff: field(&|s| s.n_eff),
                distinct: field(&|s| f64::from(s.distinct)),
                resampled: field(&|s| f64::from(u8::from(s.resampled))),
                landmarks: field(&|s| s.landmarks as f64),
                step_time_ms: field(&|s| s.step_time_s * 1e3),
                latency_ms: latency.get(&p.stamp_ns).map_or(f64::NAN, |l| l * 1e3),
            }
        })
        .collect()
}

/// Column names of `metrics.csv`, in order (see `METRICS.md`).
pub const CSV_COLUMNS: [&str; 20] = [
    "stamp_s",
    "x_m",
    "y_m",
    "theta_rad",
    "truth_x_m",
    "truth_y_m",
    "truth_theta_rad",
    "position_error_m",
    "heading_error_rad",
    "dead_reckoning_error_m",
    "sigma_x_m",
    "sigma_y_m",
    "sigma_theta_rad",
    "nees",
    "n_eff",
    "distinct_particles",
    "resampled",
    "landmarks",
    "step_time_ms",
    "latency_ms",
];

impl Row {
    /// The row's values in [`CSV_COLUMNS`] order.
    pub fn values(&self) -> [f64; 20] {
        let p = self.estimate;
        let t = self.truth.map_or([f64::NAN; 3], |t| [t.x, t.y, t.theta]);
        [
            p.stamp_ns as f64 * 1e-9,
            p.x,
            p.y,
            p.theta,
            t[0],
            t[1],
            t[2],
            self.position_error_m,
            self.heading_error_rad,
            self.dead_reckoning_error_m,
            self.sigma[0],
            self.sigma[1],
            self.sigma[2],
            self.nees,
            self.n_eff,
            self.distinct,
            self.resampled,
            self.landmarks,
            self.step_time_ms,
            self.latency_ms,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::{Estimate, StatusSample};

    fn pose(t: u64, x: f64) -> StampedPose {
        StampedPose {
            stamp_ns: t,
            x,
            y: 0.0,
            theta: 0.0,
        }
    }

    #[test]
    fn a_row_joins_truth_status_and_latency_by_stamp() {
        let cov = [0.25, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.01];
        let rec = Recording {
            truth: vec![pose(0, 0.0), pose(10, 10.0), pose(20, 20.0)],
            dead_reckoning: vec![pose(0, 0.0), pose(20, 23.0)],
            estimates: vec![
                Estimate {
                    pose: pose(10, 11.0),
                    covariance: cov,
                },
                Estimate {
                    pose: pose(30, 30.0),
                    covariance: cov,
                },
            ],
            status: vec![StatusSample {
                stamp_ns: 10,
                n_eff: 7.5,
                particles: 10,
                distinct: 6,
                resampled: true,
                landmarks: 4,
                step_time_s: 0.002,
                nis: 1.2,
                nis_high: false,
                nis_pose: false,
                noise_profile: [0.1, 0.5, 0.2, 0.05],
                noise_fitted: [0.4, 1.3, 0.2, 0.05],
                noise_fit: 1,
                noise_suspect: 0,
            }],
            latencies: vec![(10, 0.004)],
            ..Default::default()
        };
        let rows = timeline(&rec);
        assert_eq!(rows.len(), 2);
        let r = rows[0];
        assert_eq!(r.truth, Some(pose(10, 10.0)));
        assert!((r.position_error_m - 1.0).abs() < 1e-12);
        assert!(
            (r.dead_reckoning_error_m - 1.5).abs() < 1e-12,
            "interpolated dead reckoning"
        );
        assert_eq!(r.sigma, [0.5, 2.0, 0.1]);
        assert!((r.nees - 4.0).abs() < 1e-12);
        assert_eq!(
            (r.n_eff, r.distinct, r.resampled, r.landmarks),
            (7.5, 6.0, 1.0, 4.0)
        );
        assert!((r.latency_ms - 4.0).abs() < 1e-12 && (r.step_time_ms - 2.0).abs() < 1e-12);
        // Beyond the truth and without status: unknown, not zero.
        let late = rows[1].values();
        assert!((late[0] - 30e-9).abs() < 1e-18);
        let unknown: Vec<usize> = (0..20).filter(|&i| late[i].is_nan()).collect();
        // Truth, errors and NEES (4..=9, 13), status (14..=18) and latency (19) unknown;
        // the estimate and its own sigmas are known.
        let expected: Vec<usize> = (4..=9).chain(13..=19).collect();
        assert_eq!(unknown, expected);
    }
}
