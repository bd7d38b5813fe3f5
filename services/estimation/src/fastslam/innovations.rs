//! Does the filter's noise model fit the data? The normalised innovation squared (NIS) of
//! each scan, predicted from the motion prior, summed over a sliding window and compared
//! with its χ² band (docs/ALGORITHMS.md §1 step 3, "Noise check").
//!
//! Per scan, at the noise check's motion prior `N(x̂, P)` — the best particle's pose at the
//! last update, propagated through the controls since — and with that particle's map, every
//! observation the association matches gives `d² = νᵀ S⁻¹ ν` with the full innovation
//! covariance `S = H_x P H_xᵀ + H_m Σ H_mᵀ + R`: when the motion noise, the sensor noise
//! and the landmark covariances are right, `d²` is χ² with 2 degrees of freedom. Over a
//! window of scans, `Σ d²` is χ² with `2 · matched` degrees of freedom; a sum beyond the
//! band's upper end for a whole window says the innovations are larger than the model
//! explains, and which term dominates `S` says where to look: the odometry noise
//! (`sigma_v`, `sigma_omega`) when the pose term does, else the sensor's.

use super::association::{Decision, Scan, ScanAssociation};
use super::landmarks::LandmarkMap;
use super::noise_fit::NoiseFit;
use super::particle::MotionPrior;
use crate::observation::predict;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// The innovations of one scan against one particle's prior and map.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Innovations {
    /// `Σ d²` over the matched observations.
    pub nis: f64,
    /// Degrees of freedom: 2 per matched observation.
    pub dof: u32,
    /// Mean share of the pose term `H_x P H_xᵀ` in `trace S` (0..1).
    pub motion_share: f64,
}

impl Innovations {
    /// The innovations of `scan` against `map` at the motion prior `prior`
    /// (`association` is a reused buffer), each matched observation also added to `fit`.
    ///
    /// # Performance
    /// One association plus O(matched) 2 × 2 and 2 × 3 products.
    pub(crate) fn of(
        scan: &Scan<'_>,
        map: &LandmarkMap,
        prior: &MotionPrior,
        association: &mut ScanAssociation,
        fit: &mut NoiseFit,
    ) -> Self {
        scan.associate_around(map, &prior.mean, Some(&prior.covariance), association);
        let noise = scan.sensor().noise();
        let mut out = Self::default();
        let mut share = 0.0;
        fit.start_scan();
        for (obs, decision) in scan.observations().iter().zip(&association.decisions) {
            let Decision::Update { slot, .. } = decision else {
                continue;
            };
            let Some(landmark) = map.at(*slot) else {
                continue;
            };
            let Some(p) = predict(&prior.mean, &landmark.mean) else {
                continue;
            };
            let pose_term = p.wrt_pose * prior.covariance * p.wrt_pose.transpose();
            let h = p.wrt_landmark;
            let map_term = h * landmark.covariance * h.transpose();
            let s = pose_term + map_term + noise;
            let Some(s_inv) = s.try_inverse() else {
                continue;
            };
            let nu = crate::observation::innovation(&obs.z(), &p.z);
            fit.add(&nu, &pose_term, &map_term, &noise);
            out.nis += (nu.transpose() * s_inv * nu)[0];
            out.dof += 2;
            share += pose_term.trace() / s.trace();
        }
        fit.end_scan();
        if out.dof > 0 {
            out.motion_share = share / f64::from(out.dof / 2);
        }
        out
    }
}

/// What a failed noise check points at, in words for a log or a summary: the odometry
/// noise when the pose term dominates the innovations (`pose_dominates`), else the
/// sensor's.
pub fn noise_suspect(pose_dominates: bool) -> &'static str {
    if pose_dominates {
        "odometry noise looks larger than the configuration's sigma_v / sigma_omega"
    } else {
        "sensor noise looks larger than the configuration's sigma_range / sigma_bearing"
    }
}

/// Where the windowed NIS lies against its χ² band.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NisVerdict {
    /// Too few matched observations in the window to judge.
    Unknown,
    /// Inside the two-sided 95 % band.
    Consistent,
    /// Below it: the model's noise is larger than the data's (conservative).
    Low,
    /// Above it: innovations larger than the model explains.
    High,
}

/// The NIS of the last `scans` scans, summed, with its verdict; see the module docs.
/// Plain data, so a checkpoint can carry it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NisWindow {
    scans: usize,
    window: VecDeque<Innovations>,
    nis: f64,
    dof: u64,
    share: f64,
    high_run: usize,
}

/// Scans in the sliding window of the service and the replays.
pub const NIS_WINDOW_SCANS: usize = 50;

/// Fewest degrees of freedom in a window before it is judged.
const MIN_DOF: u64 = 20;

impl NisWindow {
    /// An empty window over `scans` scans (≥ 1).
    pub fn new(scans: usize) -> Self {
        Self {
            scans: scans.max(1),
            window: VecDeque::with_capacity(scans.max(1)),
            nis: 0.0,
            dof: 0,
            share: 0.0,
            high_run: 0,
        }
    }

    /// Adds one scan's innovations, dropping the oldest beyond the window.
    pub fn push(&mut self, innovations: Innovations) {
        if self.window.len() == self.scans
            && let Some(old) = self.window.pop_front()
        {
            self.remove(&old);
        }
        self.nis += innovations.nis;
        self.dof += u64::from(innovations.dof);
        self.share += innovations.motion_share * f64::from(innovations.dof);
        self.window.push_back(innovations);
        self.high_run = match self.verdict() {
            NisVerdict::High => self.high_run + 1,
            _ => 0,
        };
    }

    fn remove(&mut self, old: &Innovations) {
        self.nis -= old.nis;
        self.dof -= u64::from(old.dof);
        self.share -= old.motion_share * f64::from(old.dof);
        if self.dof == 0 {
            (self.nis, self.share) = (0.0, 0.0);
        }
    }

    /// `Σ d² / dof` over the window (1 when consistent; NaN while empty).
    pub fn per_dof(&self) -> f64 {
        if self.dof == 0 {
            f64::NAN
        } else {
            self.nis / self.dof as f64
        }
    }

    /// Degrees of freedom in the window.
    pub fn dof(&self) -> u64 {
        self.dof
    }

    /// Mean share of the pose term in `S` over the window's matched observations.
    pub fn motion_share(&self) -> f64 {
        if self.dof == 0 {
            0.0
        } else {
            self.share / self.dof as f64
        }
    }

    /// The window's verdict against the two-sided 95 % χ² band of its degrees of freedom.
    pub fn verdict(&self) -> NisVerdict {
        if self.dof < MIN_DOF {
            return NisVerdict::Unknown;
        }
        let (low, high) = chi2_band_95(self.dof as f64);
        if self.nis > high {
            NisVerdict::High
        } else if self.nis < low {
            NisVerdict::Low
        } else {
            NisVerdict::Consistent
        }
    }

    /// True once the window has been above its band for a whole window of scans in a
    /// row: long enough to be the model, not a bad moment.
    pub fn sustained_high(&self) -> bool {
        self.high_run >= self.scans
    }
}

/// The 2.5 % and 97.5 % points of χ² with `k` degrees of freedom (Wilson–Hilferty:
/// `k (1 − 2/(9k) ± z √(2/(9k)))³`, within 1 % from k = 20 on).
fn chi2_band_95(k: f64) -> (f64, f64) {
    const Z: f64 = 1.959_963_985;
    let a = 2.0 / (9.0 * k);
    let point = |z: f64| k * (1.0 - a + z * a.sqrt()).powi(3);
    (point(-Z), point(Z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_matches_chi2_tables() {
        // χ²₀.₉₇₅ and χ²₀.₀₂₅ for 20 and 100 degrees of freedom.
        let (lo, hi) = chi2_band_95(20.0);
        assert!(
            (lo - 9.591).abs() < 0.1 && (hi - 34.170).abs() < 0.2,
            "{lo} {hi}"
        );
        let (lo, hi) = chi2_band_95(100.0);
        assert!(
            (lo - 74.222).abs() < 0.2 && (hi - 129.561).abs() < 0.3,
            "{lo} {hi}"
        );
    }

    #[test]
    fn a_window_judges_only_its_last_scans_and_needs_a_whole_window_to_sustain() {
        let scan = |nis: f64| Innovations {
            nis,
            dof: 4,
            motion_share: 0.8,
        };
        let mut window = NisWindow::new(10);
        for _ in 0..4 {
            window.push(scan(4.0));
        }
        assert_eq!(window.verdict(), NisVerdict::Unknown, "16 dof");
        for _ in 0..10 {
            window.push(scan(4.0));
        }
        assert_eq!(window.dof(), 40);
        assert!((window.per_dof() - 1.0).abs() < 1e-12);
        assert_eq!(window.verdict(), NisVerdict::Consistent);
        for i in 1..=10 {
            window.push(scan(40.0));
            assert_eq!(window.sustained_high(), i == 10, "after {i} high scans");
        }
        assert!((window.per_dof() - 10.0).abs() < 1e-9);
        assert!((window.motion_share() - 0.8).abs() < 1e-12);
        for _ in 0..10 {
            window.push(scan(0.1));
        }
        assert_eq!(window.verdict(), NisVerdict::Low);
        assert!(!window.sustained_high());
    }
}
