//! Summaries of repeated runs (Monte Carlo tables): mean, standard deviation and the 95 %
//! confidence interval of the mean; and nearest-rank percentiles.

use serde::Serialize;

/// The `p`-th percentile (0 < p ≤ 100) of `sorted` (ascending) by the nearest-rank
/// method: the smallest sample with at least `p` % of the samples at or below it. It is
/// always an observed value (no interpolation), the usual convention for latencies.
/// NaN for no samples.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (p / 100.0 * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Mean, spread and 95 % confidence interval of the mean of a set of per-run values.
///
/// # Example
/// ```
/// use fastslam_estimation::stats::Summary;
/// let s = Summary::of(&[1.0, 2.0, 3.0, 4.0]);
/// assert_eq!(s.mean, 2.5);
/// assert!((s.std - 1.2909944).abs() < 1e-6);
/// assert!(s.ci95.0 < 2.5 && 2.5 < s.ci95.1);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Number of finite values summarised (non-finite ones are counted in `non_finite`).
    pub n: usize,
    /// Values that were NaN or infinite (a diverged run), left out of the statistics.
    pub non_finite: usize,
    /// Sample mean (NaN without values).
    pub mean: f64,
    /// Sample standard deviation (n − 1 in the denominator; 0 for one value).
    pub std: f64,
    /// 95 % confidence interval of the mean, `mean ± t₀.₉₇₅,ₙ₋₁ · std / √n` (Student's t;
    /// the mean itself for one value).
    pub ci95: (f64, f64),
    /// The largest finite value (the worst run, for errors; NaN without values).
    pub max: f64,
}

impl Summary {
    /// Summarises `values`, leaving out the non-finite ones.
    pub fn of(values: &[f64]) -> Self {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let n = finite.len();
        let mean = finite.iter().sum::<f64>() / n as f64;
        let std = if n > 1 {
            (finite.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let half = if n > 1 {
            student_t_975(n - 1) * std / (n as f64).sqrt()
        } else {
            0.0
        };
        Self {
            n,
            non_finite: values.len() - n,
            mean,
            std,
            ci95: (mean - half, mean + half),
            max: finite.iter().copied().fold(f64::NAN, f64::max),
        }
    }
}

/// The 97.5 % point of Student's t with `dof` degrees of freedom (≥ 1): exact table values
/// for 1–4, beyond them the first four terms of the Cornish–Fisher expansion around the
/// normal quantile (Abramowitz & Stegun 26.7.5; error below 0.001 from 5 on).
pub fn student_t_975(dof: usize) -> f64 {
    const SMALL: [f64; 4] = [12.706_204_736, 4.302_652_730, 3.182_446_305, 2.776_445_105];
    const Z: f64 = 1.959_963_985;
    if dof <= 4 {
        return SMALL[dof.max(1) - 1];
    }
    let v = dof as f64;
    let z = |k: i32| Z.powi(k);
    Z + (z(3) + Z) / (4.0 * v)
        + (5.0 * z(5) + 16.0 * z(3) + 3.0 * Z) / (96.0 * v.powi(2))
        + (3.0 * z(7) + 19.0 * z(5) + 17.0 * z(3) - 15.0 * Z) / (384.0 * v.powi(3))
        + (79.0 * z(9) + 776.0 * z(7) + 1482.0 * z(5) - 1920.0 * z(3) - 945.0 * Z)
            / (92_160.0 * v.powi(4))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_match_the_tables() {
        // Reference values from any t table.
        for (dof, t) in [
            (1, 12.706),
            (4, 2.776),
            (5, 2.571),
            (9, 2.262),
            (29, 2.045),
            (1000, 1.962),
        ] {
            assert!(
                (student_t_975(dof) - t).abs() < 1e-3,
                "{dof}: {}",
                student_t_975(dof)
            );
        }
    }

    #[test]
    fn non_finite_values_are_counted_and_left_out() {
        let s = Summary::of(&[1.0, f64::NAN, 3.0, f64::INFINITY]);
        assert_eq!((s.n, s.non_finite), (2, 2));
        assert_eq!(s.mean, 2.0);
        let one = Summary::of(&[5.0]);
        assert_eq!((one.std, one.ci95), (0.0, (5.0, 5.0)));
        assert!(Summary::of(&[]).mean.is_nan());
    }
}
