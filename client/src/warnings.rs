//! The run's warnings: one line for each way its result is worse than the data supports
//! — by the stack's own measures (the noise check, torn back-end solves, inputs lost) and,
//! with ground truth, by the truth (worse than dead reckoning, an over-confident
//! covariance, landmarks mapped far beyond the true ones, a smoothed trajectory worse than
//! the filter's). Printed in the summary, logged by the client, and written to
//! `metrics.json` as `warnings`, where `--expect "warnings.count == 0"` judges them.

use crate::metrics::Metrics;
use serde::{Deserialize, Serialize};

/// Share of the steps at which a failed noise check is the model, not chance.
const NIS_HIGH_SHARE: f64 = 0.1;

/// Share of the steps inside the NEES 95 % bound below which the covariance is called
/// over-confident (a consistent filter has 95 %).
const NEES_WITHIN_SHARE: f64 = 0.5;

/// Landmarks mapped per true landmark beyond which the
/// association is mapping duplicates.
const LANDMARKS_PER_TRUE: f64 = 1.3;

/// The warnings of a run, as `metrics.json` holds them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Warnings {
    /// Number of lines.
    pub count: usize,
    /// One warning per line.
    pub lines: Vec<String>,
}

impl Warnings {
    /// The warnings `m` calls for.
    pub fn of(m: &Metrics) -> Self {
        let mut lines = m.inputs.warnings();
        let h = &m.filter;
        // The back-end's variance components name a suspect only beyond their own bound;
        // the filter's innovations, when the check failed often enough.
        let by_back_end = h.noise_fit == "smoother" && !h.nis_suspect.is_empty();
        if by_back_end || (!h.nis_suspect.is_empty() && h.nis_high_fraction >= NIS_HIGH_SHARE) {
            let odometry = h.nis_suspect == "odometry";
            let suspect = fastslam_estimation::fastslam::noise_suspect(odometry);
            let measure = if by_back_end {
                let i = if odometry { 0 } else { 2 };
                let (fitted, profile) = (&h.noise_fitted[i..i + 2], &h.noise_profile[i..i + 2]);
                let caveat = if h.unknown_association {
                    " (with unknown association, wrong matches raise this fit too)"
                } else {
                    ""
                };
                format!(
                    "the smoothing back-end's residuals put the {} noise at σ {:.3}, {:.3} \
                     against the profile's {:.3}, {:.3}{caveat}",
                    h.nis_suspect, fitted[0], fitted[1], profile[0], profile[1]
                )
            } else {
                format!(
                    "innovations larger than the noise model explains at {:.0} % of steps",
                    100.0 * h.nis_high_fraction
                )
            };
            lines.push(format!(
                "{measure}: {suspect} (docs/REPLAYS.md, fitting the noise)"
            ));
        }
        if h.smoother_torn_solves > 0 {
            let stands = if m.smoothed.is_some() {
                "smoothed/* holds the last good solution"
            } else {
                "no smoothed trajectory was published"
            };
            lines.push(format!(
                "the smoothing back-end withheld {} torn solves (χ²/dof or outliers beyond \
                 its gate; logs/service.log): {stands}",
                h.smoother_torn_solves
            ));
        }
        if m.ground_truth {
            lines.extend(truth_warnings(m));
        }
        Self {
            count: lines.len(),
            lines,
        }
    }
}

/// The warnings only ground truth can give.
fn truth_warnings(m: &Metrics) -> Vec<String> {
    let mut lines = Vec::new();
    let (ate, dead) = (m.estimate.ate_rmse_m, m.dead_reckoning.ate_rmse_m);
    if ate > dead {
        lines.push(format!(
            "the estimate (ATE {ate:.3} m) is worse than dead reckoning ({dead:.3} m)"
        ));
    }
    let c = &m.consistency;
    if c.poses + c.singular > 0 && c.nees_within_95 < NEES_WITHIN_SHARE {
        lines.push(format!(
            "the pose covariance is over-confident: NEES inside its 95 % bound at {:.0} % \
             of steps (95 % when consistent)",
            100.0 * c.nees_within_95
        ));
    }
    let map = &m.map;
    if map.truth > 0 && map.estimated as f64 > LANDMARKS_PER_TRUE * map.truth as f64 {
        lines.push(format!(
            "{} landmarks mapped for {} true ones ({} spurious): the association maps \
             landmarks again",
            map.estimated, map.truth, map.spurious
        ));
    }
    if let Some(s) = &m.smoothed
        && s.trajectory.ate_rmse_m > ate
    {
        lines.push(format!(
            "the smoothed trajectory (ATE {:.3} m) is worse than the filter's ({ate:.3} m)",
            s.trajectory.ate_rmse_m
        ));
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::{Estimate, Recording, StampedPose};
    use crate::scoring::{Alignment, ScoreAt};

    /// A run along a straight line whose estimate is `off` metres beside the truth, with a
    /// covariance of `sigma` metres, dead reckoning on the truth, and `torn` withheld solves.
    fn run(off: f64, sigma: f64, torn: u32) -> Metrics {
        let truth: Vec<StampedPose> = (0..100)
            .map(|k| StampedPose {
                stamp_ns: k * 100_000_000,
                x: 0.1 * k as f64,
                y: 0.0,
                theta: 0.0,
            })
            .collect();
        let rec = Recording {
            estimates: (truth.iter())
                .map(|p| Estimate {
                    pose: StampedPose { y: off, ..*p },
                    covariance: [
                        sigma * sigma,
                        0.0,
                        0.0,
                        0.0,
                        sigma * sigma,
                        0.0,
                        0.0,
                        0.0,
                        1e-3,
                    ],
                })
                .collect(),
            dead_reckoning: truth.clone(),
            truth,
            torn_solves: torn,
            ..Recording::default()
        };
        Metrics::compute(&rec, true, Alignment::default(), ScoreAt::default())
    }

    #[test]
    fn a_run_as_good_as_its_data_has_no_warning() {
        assert_eq!(Warnings::of(&run(0.0, 0.1, 0)), Warnings::default());
    }

    #[test]
    fn worse_than_dead_reckoning_and_over_confident_are_two_lines() {
        let w = Warnings::of(&run(1.0, 0.01, 0));
        assert_eq!(w.count, 2, "{w:?}");
        assert!(w.lines[0].contains("worse than dead reckoning"), "{w:?}");
        assert!(w.lines[1].contains("over-confident"), "{w:?}");
    }

    #[test]
    fn torn_solves_are_a_warning_without_truth_too() {
        let mut m = run(0.0, 0.1, 3);
        m.ground_truth = false;
        let w = Warnings::of(&m);
        assert_eq!(w.count, 1, "{w:?}");
        assert!(w.lines[0].contains("withheld 3 torn solves"), "{w:?}");
        assert!(w.lines[0].contains("no smoothed trajectory"), "{w:?}");
    }

    #[test]
    fn the_back_ends_suspect_is_a_warning_naming_its_fit_however_few_steps_failed() {
        let mut m = run(0.0, 0.1, 0);
        m.filter.noise_fit = "smoother".into();
        m.filter.nis_suspect = "odometry".into();
        m.filter.noise_profile = [0.1, 0.05, 0.1, 0.01];
        m.filter.noise_fitted = [0.4, 0.2, 0.1, 0.01];
        let w = Warnings::of(&m);
        assert_eq!(w.count, 1, "{w:?}");
        assert!(
            w.lines[0]
                .contains("odometry noise at σ 0.400, 0.200 against the profile's 0.100, 0.050"),
            "{w:?}"
        );
        assert!(w.lines[0].contains("sigma_v / sigma_omega"), "{w:?}");
        assert!(!w.lines[0].contains("wrong matches"), "{w:?}");
        m.filter.unknown_association = true;
        let w = Warnings::of(&m);
        assert!(
            w.lines[0].contains("with unknown association, wrong matches raise this fit too"),
            "{w:?}"
        );
        m.filter.noise_fit = "innovations".into();
        assert_eq!(
            Warnings::of(&m).count,
            0,
            "the filter's suspect needs failed steps"
        );
    }
}
