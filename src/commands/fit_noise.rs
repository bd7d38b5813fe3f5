//! `fastslam-stack fit-noise`: the noise settings a recording with dense ground truth
//! supports (docs/REPLAYS.md, "Fitting the noise of a new robot"). Odometry: over windows
//! of `T` seconds, the spread of the travelled distance and of the heading change against
//! the truth's, scaled to the filter's per-period noise (`σ √(dt · T)`). Sensor: the
//! residuals of range and bearing against the true landmarks seen from the true pose.

use anyhow::{Context, bail};
use fastslam_client::metrics::interpolate;
use fastslam_client::recording::StampedPose;
use fastslam_estimation::Pose2;
use fastslam_estimation::observation::measure;
use fastslam_estimation::pose::wrap_angle;
use fastslam_protocol::{GroundTruth, Odometry};
use fastslam_replay::dataset::{Association, DataSet};
use fastslam_replay::registry::DataSetKind;
use fastslam_stack::offline::{self, Source};
use nalgebra::Vector2;
use std::path::PathBuf;

/// Flags of `fit-noise`.
#[derive(Debug, Clone, clap::Args)]
pub struct FitNoiseArgs {
    /// The recorded data set (it needs a dense ground truth with headings: MRCLAM).
    #[arg(long, value_parser = offline::in_process_data_sets(), default_value = "mrclam")]
    pub replay: &'static DataSetKind,
    /// Data set folder (default: data/mrclam7).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// MRCLAM robot number.
    #[arg(long, default_value_t = 1)]
    pub robot: u32,
    /// Length of the odometry windows (s).
    #[arg(long, default_value_t = 1.0)]
    pub window_s: f64,
}

/// What the recording supports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseFit {
    /// The odometry period (median, s).
    pub dt_s: f64,
    /// Windows compared.
    pub windows: usize,
    /// Mean and spread of (odometry − truth) distance over a window (m).
    pub distance_error: (f64, f64),
    /// Mean and spread of (odometry − truth) heading change over a window (rad).
    pub heading_error: (f64, f64),
    /// The per-period speed noise those spreads make (m/s).
    pub sigma_v: f64,
    /// The per-period turn-rate noise (rad/s).
    pub sigma_omega: f64,
    /// Observations compared with the true landmarks.
    pub observations: usize,
    /// Range residuals: standard deviation and robust spread (1.4826 · MAD) (m).
    pub range: (f64, f64),
    /// Bearing residuals, the same (rad).
    pub bearing: (f64, f64),
}

/// Runs `fit-noise` and prints the fit with a profile snippet.
///
/// # Errors
/// A missing data folder, a data set without dense ground truth, a bad window.
pub fn run(args: &FitNoiseArgs) -> anyhow::Result<()> {
    if !(args.window_s.is_finite() && args.window_s > 0.0) {
        bail!("--window-s must be > 0, not {}", args.window_s);
    }
    let source = Source::replay(
        args.replay,
        args.data.as_deref(),
        args.robot,
        Association::Known,
        None,
    )?;
    let Source::Replay(replay) = source else {
        unreachable!("a replay source")
    };
    let fit = fit(&replay.data, args.window_s).context(replay.name.clone())?;
    println!(
        "{}: odometry period {:.4} s, {} windows of {} s, {} observations of known landmarks",
        replay.name, fit.dt_s, fit.windows, args.window_s, fit.observations
    );
    println!(
        "  distance error over a window  mean {:+.4} m  std {:.4} m",
        fit.distance_error.0, fit.distance_error.1
    );
    println!(
        "  heading error over a window   mean {:+.4} rad  std {:.4} rad",
        fit.heading_error.0, fit.heading_error.1
    );
    println!(
        "  range residual   std {:.4} m    robust {:.4} m",
        fit.range.0, fit.range.1
    );
    println!(
        "  bearing residual std {:.4} rad  robust {:.4} rad",
        fit.bearing.0, fit.bearing.1
    );
    println!(
        "a profile's settings for this robot (zero-mean noise: a mean error is a bias the filter does not model):"
    );
    println!(
        "[service.filter.motion]\nsigma_v = {:.3}\nsigma_omega = {:.3}",
        fit.sigma_v, fit.sigma_omega
    );
    println!(
        "[service.filter.sensor]\nsigma_range = {:.3}\nsigma_bearing = {:.3}",
        fit.range.0, fit.bearing.0
    );
    Ok(())
}

/// Mean and sample standard deviation.
fn mean_std(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// Standard deviation and 1.4826 · median absolute deviation.
fn spreads(values: &mut [f64]) -> (f64, f64) {
    let (_, std) = mean_std(values);
    let median = |v: &mut [f64]| {
        v.sort_unstable_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let m = median(values);
    let mut deviations: Vec<f64> = values.iter().map(|v| (v - m).abs()).collect();
    (std, 1.4826 * median(&mut deviations))
}

/// The fit of `data` with windows of `window_s` seconds.
///
/// # Errors
/// Too little odometry or ground truth to compare.
pub fn fit(data: &DataSet, window_s: f64) -> anyhow::Result<NoiseFit> {
    let stamped = |stamp_ns, x, y, theta| StampedPose {
        stamp_ns,
        x,
        y,
        theta,
    };
    let odometry: Vec<StampedPose> = (data.odometry.iter())
        .map(|o: &Odometry| stamped(o.header.stamp_ns, o.x, o.y, o.theta))
        .collect();
    let truth: Vec<StampedPose> = (data.truth.iter())
        .map(|t: &GroundTruth| stamped(t.header.stamp_ns, t.x, t.y, t.theta))
        .collect();
    let at = |track: &[StampedPose], stamp_ns| {
        interpolate(track, stamp_ns).map(|p| Pose2::new(p.x, p.y, p.theta))
    };
    if odometry.len() < 10 || truth.len() < odometry.len() / 100 {
        bail!(
            "{} odometry records and {} ground-truth poses: the fit needs a dense ground truth with headings",
            odometry.len(),
            truth.len()
        );
    }
    let mut periods: Vec<f64> = odometry
        .windows(2)
        .map(|w| (w[1].stamp_ns - w[0].stamp_ns) as f64 * 1e-9)
        .filter(|&p| p > 0.0)
        .collect();
    periods.sort_unstable_by(f64::total_cmp);
    let dt_s = periods[periods.len() / 2];
    let window_ns = (window_s * 1e9) as u64;
    let (first, last) = (odometry[0].stamp_ns, odometry[odometry.len() - 1].stamp_ns);
    let (mut distance, mut heading) = (Vec::new(), Vec::new());
    let mut start = first;
    while start + window_ns <= last {
        let end = start + window_ns;
        let poses = (
            at(&odometry, start),
            at(&odometry, end),
            at(&truth, start),
            at(&truth, end),
        );
        if let (Some(o0), Some(o1), Some(t0), Some(t1)) = poses {
            let travelled = |a: Pose2, b: Pose2| (b.x - a.x).hypot(b.y - a.y);
            distance.push(travelled(o0, o1) - travelled(t0, t1));
            heading.push(wrap_angle(
                wrap_angle(o1.theta - o0.theta) - wrap_angle(t1.theta - t0.theta),
            ));
        }
        start = end;
    }
    if distance.len() < 2 {
        bail!("fewer than two windows of {window_s} s overlap odometry and ground truth");
    }
    let (mut range, mut bearing) = (Vec::new(), Vec::new());
    for scan in &data.scans {
        let Some(pose) = at(&truth, scan.header.header.stamp_ns) else {
            continue;
        };
        for obs in &scan.items {
            let Some(landmark) = obs
                .known_id()
                .and_then(|id| data.landmarks.iter().find(|l| l.id == id))
            else {
                continue;
            };
            let z = measure(&pose, &Vector2::new(landmark.x, landmark.y));
            range.push(obs.range - z[0]);
            bearing.push(wrap_angle(obs.bearing - z[1]));
        }
    }
    let scale = (dt_s * window_s).sqrt();
    let (distance_error, heading_error) = (mean_std(&distance), mean_std(&heading));
    let nan = (f64::NAN, f64::NAN);
    Ok(NoiseFit {
        dt_s,
        windows: distance.len(),
        distance_error,
        heading_error,
        sigma_v: distance_error.1 / scale,
        sigma_omega: heading_error.1 / scale,
        observations: range.len(),
        range: if range.len() > 1 {
            spreads(&mut range)
        } else {
            nan
        },
        bearing: if bearing.len() > 1 {
            spreads(&mut bearing)
        } else {
            nan
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_protocol::Header;
    use rand::RngExt;
    use rand_distr::StandardNormal;

    /// A unicycle at 10 ms with known per-period noise: the fit finds it back.
    #[test]
    fn the_fit_recovers_the_noise_a_recording_was_made_with() {
        let (dt, sigma_v, sigma_omega) = (0.01, 0.1, 0.5);
        let mut rng = fastslam_estimation::rng::seeded(3);
        let mut normal = move || -> f64 { rng.sample(StandardNormal) };
        let (mut truth, mut odometry) = (Pose2::default(), Pose2::default());
        let mut data = DataSet::default();
        for k in 0..60_000u64 {
            let (v, omega) = (0.3, 0.4 * (k as f64 * 0.001).sin());
            let step = |p: Pose2, v: f64, w: f64| {
                Pose2::new(
                    p.x + v * dt * p.theta.cos(),
                    p.y + v * dt * p.theta.sin(),
                    wrap_angle(p.theta + w * dt),
                )
            };
            truth = step(truth, v, omega);
            odometry = step(
                odometry,
                v + sigma_v * normal(),
                omega + sigma_omega * normal(),
            );
            let header = Header {
                stamp_ns: k * 10_000_000,
                seq: k,
            };
            data.odometry.push(Odometry {
                header,
                x: odometry.x,
                y: odometry.y,
                theta: odometry.theta,
                ..Odometry::default()
            });
            data.truth.push(GroundTruth {
                header,
                x: truth.x,
                y: truth.y,
                theta: truth.theta,
                ..GroundTruth::default()
            });
        }
        let fit = fit(&data, 1.0).unwrap();
        assert!((fit.dt_s - dt).abs() < 1e-9);
        assert!(fit.windows > 500);
        assert!((fit.sigma_omega / sigma_omega - 1.0).abs() < 0.1, "{fit:?}");
        assert!((fit.sigma_v / sigma_v - 1.0).abs() < 0.1, "{fit:?}");
        assert_eq!(fit.observations, 0);
        assert!(fit.range.0.is_nan());
    }

    #[test]
    fn sparse_ground_truth_is_refused() {
        let data = DataSet {
            odometry: (0..1000)
                .map(|k| Odometry {
                    header: Header {
                        stamp_ns: k * 10_000_000,
                        seq: k,
                    },
                    ..Odometry::default()
                })
                .collect(),
            ..DataSet::default()
        };
        let error = fit(&data, 1.0).unwrap_err().to_string();
        assert!(error.contains("dense ground truth"), "{error}");
    }
}
