//! Small summaries of samples: mean, standard deviation and nearest-rank percentiles, used
//! for latencies, step times, filter health and the comparison table.

pub use fastslam_estimation::stats::percentile;
use serde::{Deserialize, Serialize};

/// Arithmetic mean; NaN for no samples.
pub fn mean(xs: &[f64]) -> f64 {
    if xs.is_empty() {
        f64::NAN
    } else {
        xs.iter().sum::<f64>() / xs.len() as f64
    }
}

/// Sample standard deviation (n − 1 in the denominator); 0 for one sample, NaN for none.
pub fn std_dev(xs: &[f64]) -> f64 {
    match xs.len() {
        0 => f64::NAN,
        1 => 0.0,
        n => {
            let m = mean(xs);
            (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        }
    }
}

/// Root mean square; NaN for no samples.
pub fn rms(xs: &[f64]) -> f64 {
    mean(&xs.iter().map(|x| x * x).collect::<Vec<_>>()).sqrt()
}

/// Median, 99th and 99.9th percentiles and maximum of a set of durations or sizes, in the unit the
/// field names say (see `METRICS.md`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Spread {
    /// Number of samples.
    pub samples: usize,
    /// Median (nearest rank).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub median: f64,
    /// 99th percentile (nearest rank).
    #[serde(deserialize_with = "crate::json_number::number")]
    pub p99: f64,
    /// 99.9th percentile (nearest rank): the tail a real-time budget must cover.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub p999: f64,
    /// Largest sample.
    #[serde(deserialize_with = "crate::json_number::number")]
    pub max: f64,
}

impl Spread {
    /// Summarises `xs` (any order; non-finite samples are ignored).
    pub fn of(xs: impl IntoIterator<Item = f64>) -> Self {
        let mut v: Vec<f64> = xs.into_iter().filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        Self {
            samples: v.len(),
            median: percentile(&v, 50.0),
            p99: percentile(&v, 99.0),
            p999: percentile(&v, 99.9),
            max: v.last().copied().unwrap_or(f64::NAN),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles_of_one_to_a_hundred() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 50.0), 50.0);
        assert_eq!(percentile(&v, 99.0), 99.0);
        assert_eq!(percentile(&v, 100.0), 100.0);
        assert_eq!(percentile(&v, 0.1), 1.0);
    }

    #[test]
    fn spread_sorts_and_ignores_non_finite_samples() {
        let s = Spread::of([5.0, f64::NAN, 1.0, 3.0, f64::INFINITY, 2.0, 4.0]);
        assert_eq!(s.samples, 5);
        assert_eq!((s.median, s.p99, s.max), (3.0, 5.0, 5.0));
        let empty = Spread::of([]);
        assert_eq!(empty.samples, 0);
        assert!(empty.median.is_nan() && empty.max.is_nan());
    }

    #[test]
    fn spread_of_a_long_tail_reports_it_in_p99_not_in_the_median() {
        // 980 fast samples and 20 slow ones (2 %): the median stays fast, p99 sees the tail.
        let xs = (0..1000).map(|i| if i % 50 == 0 { 50.0 } else { 1.0 });
        let s = Spread::of(xs);
        assert_eq!((s.median, s.p99, s.max), (1.0, 50.0, 50.0));
    }

    #[test]
    fn p999_sees_a_tail_that_p99_misses() {
        // 1995 fast samples and 5 slow ones (0.25 %): p99 stays fast, p99.9 sees the tail.
        let xs = (0..2000).map(|i| if i % 400 == 0 { 9.0 } else { 1.0 });
        let s = Spread::of(xs);
        assert_eq!((s.median, s.p99, s.p999, s.max), (1.0, 1.0, 9.0, 9.0));
    }

    #[test]
    fn mean_std_and_rms_of_a_known_set() {
        let v = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        assert_eq!(mean(&v), 5.0);
        assert!((std_dev(&v) - (32.0_f64 / 7.0).sqrt()).abs() < 1e-12);
        assert!((rms(&[3.0, 4.0]) - 12.5_f64.sqrt()).abs() < 1e-12);
        assert!(mean(&[]).is_nan() && std_dev(&[]).is_nan());
        assert_eq!(std_dev(&[1.0]), 0.0);
    }
}
