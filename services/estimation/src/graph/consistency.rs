//! Whether a solved graph is consistent with its noise model, or torn (docs/ALGORITHMS.md
//! §8.3): the figures a solution carries, and the gate that keeps a torn one from being
//! published.

use super::{Graph, Linearised};

/// A solution's fit to its noise model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// `χ²` (no kernel) per degree of freedom: about 1 when the noise model and the
    /// associations are right.
    pub chi2_per_dof: f64,
    /// The robust cost per degree of freedom: near `chi2_per_dof` when few sightings are
    /// outliers; far below it when the kernel discounts many.
    pub robust_per_dof: f64,
    /// Share of the sightings whose normalised residual `rᵀ Ω r` exceeds the kernel's
    /// scale squared: the kernel treats them as outliers. About 1 % for a right noise model
    /// at a scale of 3 (the χ²₂ tail beyond 9).
    pub outlier_share: f64,
}

impl Graph {
    /// The fit at the current estimates, `robust_cost` being the solver's final cost and
    /// `scale` the kernel's scale (standard deviations).
    pub(super) fn fit(&self, robust_cost: f64, scale: f64) -> Fit {
        let dof = self.dof();
        Fit {
            chi2_per_dof: self.chi2() / dof,
            robust_per_dof: robust_cost / dof,
            outlier_share: self.outlier_share(scale),
        }
    }

    /// Degrees of freedom: residuals minus unknowns, at least 1.
    pub(crate) fn dof(&self) -> f64 {
        (self.residuals().saturating_sub(self.unknowns())).max(1) as f64
    }

    /// Share of the sightings whose normalised residual exceeds `scale²` (0 without
    /// sightings).
    fn outlier_share(&self, scale: f64) -> f64 {
        let mut beyond = 0usize;
        for s in &self.sightings {
            if let Some(Linearised::Sighting { r, .. }) =
                s.linearise(&self.poses[s.pose], &self.landmarks[s.landmark])
                && (r.transpose() * s.information * r)[0] > scale * scale
            {
                beyond += 1;
            }
        }
        beyond as f64 / self.sightings.len().max(1) as f64
    }
}

/// The limits beyond which a solution is torn (the `[smoother]` section's
/// `torn_chi2_per_dof` and `torn_outlier_share`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TornGate {
    /// Largest plain χ²/dof of a solution that is published.
    pub chi2_per_dof: f64,
    /// Largest share of sightings beyond the kernel's scale.
    pub outlier_share: f64,
}

impl TornGate {
    /// Why `fit` is torn (one phrase naming the figure and its limit), or `None` when it
    /// passes.
    pub fn verdict(&self, fit: &Fit) -> Option<String> {
        // NaN is torn: neither comparison holds for it.
        if fit.chi2_per_dof.is_nan() || fit.chi2_per_dof > self.chi2_per_dof {
            return Some(format!(
                "χ²/dof {:.3} above {}",
                fit.chi2_per_dof, self.chi2_per_dof
            ));
        }
        if fit.outlier_share.is_nan() || fit.outlier_share > self.outlier_share {
            return Some(format!(
                "{:.1} % of the sightings beyond the kernel's scale, above {:.1} %",
                100.0 * fit.outlier_share,
                100.0 * self.outlier_share
            ));
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(chi2_per_dof: f64, outlier_share: f64) -> Fit {
        Fit {
            chi2_per_dof,
            robust_per_dof: chi2_per_dof,
            outlier_share,
        }
    }

    #[test]
    fn the_gate_names_the_figure_that_tears() {
        let gate = TornGate {
            chi2_per_dof: 25.0,
            outlier_share: 0.5,
        };
        assert_eq!(gate.verdict(&fit(3.7, 0.05)), None);
        assert!(gate.verdict(&fit(444.0, 0.05)).unwrap().contains("χ²/dof"));
        assert!(gate.verdict(&fit(2.0, 0.6)).unwrap().contains("sightings"));
        assert!(gate.verdict(&fit(f64::NAN, 0.0)).is_some(), "NaN is torn");
    }
}
