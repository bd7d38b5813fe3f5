//! Compact progress lines the client prints on its stdout while it records, so a launcher
//! can show a live view (simulated time, live ATE) without adding a subscriber that could
//! slow the stack. One line per update, e.g.
//! `progress sim_s=12.300 ate_m=0.5321 poses=61`.

use std::fmt;

/// How far a run has come, as the client sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Stamp of the newest pose estimate (s of simulated time).
    pub sim_s: f64,
    /// ATE RMSE over the estimates so far (m); NaN before the first one.
    pub ate_m: f64,
    /// Pose estimates received so far.
    pub poses: usize,
}

/// The word that starts every progress line.
const TAG: &str = "progress";

impl fmt::Display for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{TAG} sim_s={:.3} ate_m={:.4} poses={}",
            self.sim_s, self.ate_m, self.poses
        )
    }
}

impl Progress {
    /// Reads a progress line; `None` for any other line (log output, say).
    pub fn parse(line: &str) -> Option<Self> {
        let mut words = line.split_whitespace();
        if words.next()? != TAG {
            return None;
        }
        let mut value = |key: &str| words.next()?.strip_prefix(key)?.strip_prefix('=');
        Some(Self {
            sim_s: value("sim_s")?.parse().ok()?,
            ate_m: value("ate_m")?.parse().ok()?,
            poses: value("poses")?.parse().ok()?,
        })
    }
}

/// ATE RMSE accumulated one estimate at a time, for the live view.
#[derive(Debug, Clone, Copy, Default)]
pub struct LiveAte {
    sum_sq: f64,
    n: usize,
}

impl LiveAte {
    /// Adds one position error (m).
    pub fn add(&mut self, error_m: f64) {
        self.sum_sq += error_m * error_m;
        self.n += 1;
    }

    /// The RMSE so far (m); NaN before the first error.
    pub fn rmse(&self) -> f64 {
        if self.n == 0 {
            f64::NAN
        } else {
            (self.sum_sq / self.n as f64).sqrt()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_lines_round_trip_and_other_lines_are_ignored() {
        let p = Progress {
            sim_s: 12.3,
            ate_m: 0.5321,
            poses: 61,
        };
        let line = p.to_string();
        assert_eq!(line, "progress sim_s=12.300 ate_m=0.5321 poses=61");
        assert_eq!(Progress::parse(&line), Some(p));
        let nan = Progress::parse("progress sim_s=0.000 ate_m=NaN poses=0").unwrap();
        assert!(nan.ate_m.is_nan());
        assert_eq!(Progress::parse("2024 INFO client: recording"), None);
        assert_eq!(Progress::parse("progress sim_s=1 poses=2"), None);
    }

    #[test]
    fn live_ate_is_the_rmse_so_far() {
        let mut a = LiveAte::default();
        assert!(a.rmse().is_nan());
        a.add(3.0);
        a.add(4.0);
        assert!((a.rmse() - 12.5_f64.sqrt()).abs() < 1e-12);
    }
}
