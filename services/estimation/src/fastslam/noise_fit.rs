//! The noise the filter is actually seeing, fitted from the noise check's innovations
//! while it runs (docs/ALGORITHMS.md §1, "Noise fit").
//!
//! A variance-component estimate with one scale per source. Each matched observation of
//! the noise check has `E[ννᵀ] = S = C + q A + r R`: `A` the pose term `H_x P H_xᵀ` at
//! the profile's motion noise (`P` is linear in `Q`), `R` the profile's sensor noise,
//! `C` the landmark term, and `q`, `r` the factors by which the odometry's and the
//! sensor's variances exceed the profile's. Over the observations of the last
//! [`WINDOW_SCANS`] scans, one Fisher-scoring step per scan (iterated MINQUE) solves
//! `Σ ½ tr(W Dᵢ W Dⱼ) θⱼ = Σ ½ tr(W Dᵢ W (ννᵀ − C))` for `θ = (q, r)`, `D = (A, R)`,
//! with `W = S⁻¹` at the current fit; at its fixed point that is the maximum-likelihood
//! fit of the two scales to the window. The geometry tells the sources apart: the
//! sensor's part is the same for every observation, the pose term changes with the
//! landmark's direction and range and with the motion since the last scan, and it
//! correlates range and bearing where the sensor's noise does not.
//!
//! The fit is bounded: it waits until the window holds [`WARM_UP_OBSERVATIONS`]
//! matched observations, and each scale stays within `[1/16, 100]` of the profile
//! (σ within `[¼, 10]` ×). It is plain numbers, so the filter's state carries it.

use crate::motion::MotionModel;
use crate::observation::Sensor;
use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// `[filter.noise]`: which fitted noise, if any, the filter runs on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseConfig {
    /// The fit the filter runs on; every fit is made and reported whatever this says.
    pub adapt: Adapt,
}

/// Which fitted noise the filter runs on (`[filter.noise] adapt`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Adapt {
    /// The profile throughout.
    Off,
    /// This module's fit of the innovations, both ways, once warmed up.
    Innovations,
    /// The smoothing back-end's variance components, handed over at points the data
    /// fixes, and only upwards: a source the back-end blames runs on its fitted noise,
    /// the other on the profile's (the default; without a back-end, the profile).
    #[default]
    Smoother,
}

/// The names `adapt` takes, as the configuration spells them.
const ADAPT_NAMES: [&str; 3] = ["off", "innovations", "smoother"];

impl<'de> Deserialize<'de> for Adapt {
    /// One of [`ADAPT_NAMES`]; anything else (a `true`/`false` switch included) is
    /// refused with the names listed.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Name;
        impl serde::de::Visitor<'_> for Name {
            type Value = Adapt;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "one of {ADAPT_NAMES:?}")
            }
            fn visit_str<E: serde::de::Error>(self, name: &str) -> Result<Adapt, E> {
                match name {
                    "off" => Ok(Adapt::Off),
                    "innovations" => Ok(Adapt::Innovations),
                    "smoother" => Ok(Adapt::Smoother),
                    _ => Err(E::unknown_variant(name, &ADAPT_NAMES)),
                }
            }
        }
        deserializer.deserialize_str(Name)
    }
}

/// Scans in the fit's window.
pub const WINDOW_SCANS: usize = 300;
/// Matched observations the window needs before the fit acts.
pub const WARM_UP_OBSERVATIONS: usize = 100;
/// The smallest variance scale of either source: σ no less than a quarter of the profile's.
pub const MIN_SCALE: f64 = 1.0 / 16.0;
/// The largest variance scale of either source: σ no more than ten times the profile's.
pub const MAX_SCALE: f64 = 100.0;
/// An innovation whose `νᵀ S⁻¹ ν` at the fit exceeds this is shortened to it (χ² with 2
/// degrees of freedom passes 50 once in 10¹¹ draws).
const OUTLIER: f64 = 50.0;

/// One matched observation in the window: innovation, and the pose, landmark and sensor
/// terms of its `S` at the profile's noise (symmetric 2 × 2 as `[xx, xy, yy]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct Sample {
    nu: [f64; 2],
    pose: [f64; 3],
    map: [f64; 3],
    noise: [f64; 3],
}

/// Packs a symmetric 2 × 2 matrix.
fn pack(m: &Matrix2<f64>) -> [f64; 3] {
    [m[(0, 0)], m[(0, 1)], m[(1, 1)]]
}

/// Unpacks a symmetric 2 × 2 matrix.
fn unpack([xx, xy, yy]: [f64; 3]) -> Matrix2<f64> {
    Matrix2::new(xx, xy, xy, yy)
}

/// The fit's running state: the window's observations and the scales fitted and in use.
/// See the module documentation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFit {
    /// The window's matched observations, oldest first.
    samples: VecDeque<Sample>,
    /// Matched observations per scan of the window, oldest first.
    scans: VecDeque<u32>,
    /// Fitted variance scales `(q, r)` of the odometry and the sensor, against the profile.
    fitted: [f64; 2],
    /// The variance scales the filter's noise runs on.
    in_use: [f64; 2],
}

impl Default for NoiseFit {
    fn default() -> Self {
        Self {
            samples: VecDeque::new(),
            scans: VecDeque::new(),
            fitted: [1.0; 2],
            in_use: [1.0; 2],
        }
    }
}

/// The noise a filter started from and the noise it fitted, as standard deviations
/// `[odometry₁, odometry₂, σ_range, σ_bearing]` (the odometry pair is the motion model's,
/// [`MotionModel::noise_sigmas`]), and the source the fit blames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseReport {
    /// The configuration's (the profile's).
    pub profile: [f64; 4],
    /// The fit's (the profile's until the fit has warmed up).
    pub fitted: [f64; 4],
    /// [`NoiseFit::blames_odometry`].
    pub blames_odometry: Option<bool>,
}

impl NoiseFit {
    /// Opens a scan: drops the oldest scan beyond the window.
    pub(crate) fn start_scan(&mut self) {
        if self.scans.len() >= WINDOW_SCANS
            && let Some(old) = self.scans.pop_front()
        {
            self.samples.drain(..old as usize);
        }
        self.scans.push_back(0);
    }

    /// Adds one matched observation of the open scan: innovation `nu`, pose term `pose`,
    /// landmark term `map` and sensor noise `noise` of its `S`, all at the noise in use.
    pub(crate) fn add(
        &mut self,
        nu: &Vector2<f64>,
        pose: &Matrix2<f64>,
        map: &Matrix2<f64>,
        noise: &Matrix2<f64>,
    ) {
        let sample = Sample {
            nu: [nu[0], nu[1]],
            pose: pack(&(pose / self.in_use[0])),
            map: pack(map),
            noise: pack(&(noise / self.in_use[1])),
        };
        let finite = (sample.nu.iter())
            .chain(&sample.pose)
            .chain(&sample.map)
            .chain(&sample.noise)
            .all(|v| v.is_finite());
        if let (true, Some(count)) = (finite, self.scans.back_mut()) {
            self.samples.push_back(sample);
            *count += 1;
        }
    }

    /// Closes the scan: one Fisher-scoring step over the window, once warmed up. A scale
    /// that leaves its bounds is held there and the other solved again with it fixed.
    pub(crate) fn end_scan(&mut self) {
        if !self.warmed_up() {
            return;
        }
        let (mut normal, mut rhs) = ([0.0; 3], [0.0; 2]);
        for sample in &self.samples {
            let (a, rho, map) = (
                unpack(sample.pose),
                unpack(sample.noise),
                unpack(sample.map),
            );
            let s = map + self.fitted[0] * a + self.fitted[1] * rho;
            let Some(w) = s.try_inverse() else {
                continue;
            };
            let nu = Vector2::from(sample.nu);
            let d2 = (nu.transpose() * w * nu)[0];
            let nu = if d2 > OUTLIER {
                nu * (OUTLIER / d2).sqrt()
            } else {
                nu
            };
            let (wa, wr) = (w * a, w * rho);
            let y = w * (nu * nu.transpose() - map);
            normal[0] += 0.5 * (wa * wa).trace();
            normal[1] += 0.5 * (wa * wr).trace();
            normal[2] += 0.5 * (wr * wr).trace();
            rhs[0] += 0.5 * (wa * y).trace();
            rhs[1] += 0.5 * (wr * y).trace();
        }
        let [aa, ar, rr] = normal;
        let [ga, gr] = rhs;
        let det = aa * rr - ar * ar;
        if !(det > 1e-9 * aa * rr && det.is_finite()) {
            return;
        }
        let bound = |s: f64| s.clamp(MIN_SCALE, MAX_SCALE);
        let (mut q, mut r) = ((rr * ga - ar * gr) / det, (aa * gr - ar * ga) / det);
        if q != bound(q) {
            q = bound(q);
            r = (gr - ar * q) / rr;
        }
        if r != bound(r) {
            r = bound(r);
            q = bound((ga - ar * r) / aa);
        }
        self.fitted = [q, r];
    }

    /// Whether the window holds enough matched observations for the fit to act.
    pub fn warmed_up(&self) -> bool {
        self.samples.len() >= WARM_UP_OBSERVATIONS
    }

    /// The fitted variance scales `(odometry, sensor)` against the profile.
    pub fn fitted(&self) -> [f64; 2] {
        self.fitted
    }

    /// The variance scales `(odometry, sensor)` the filter runs on.
    pub fn in_use(&self) -> [f64; 2] {
        self.in_use
    }

    /// Runs the filter on the fitted scales from now on.
    pub(crate) fn adopt(&mut self) {
        self.in_use = self.fitted;
    }

    /// Runs the filter on the variance scales `scales` (against the profile) from now on.
    pub(crate) fn run_on(&mut self, scales: [f64; 2]) {
        self.in_use = scales.map(|s| s.clamp(MIN_SCALE, MAX_SCALE));
    }

    /// Which source the innovations blame once warmed up: the odometry (`true`) when its
    /// fitted variance exceeds the one in use by a larger factor than the sensor's does.
    pub fn blames_odometry(&self) -> Option<bool> {
        let excess = |i: usize| self.fitted[i] / self.in_use[i];
        self.warmed_up().then(|| excess(0) > excess(1))
    }

    /// `motion` and `sensor` (the profile) with the noise scaled to the scales in use.
    pub(crate) fn apply(&self, motion: &MotionModel, sensor: &Sensor) -> (MotionModel, Sensor) {
        let s = self.in_use[1].sqrt();
        let scaled = Sensor {
            sigma_range: sensor.sigma_range * s,
            sigma_bearing: sensor.sigma_bearing * s,
            ..sensor.clone()
        };
        (motion.scaled(self.in_use[0]), scaled)
    }

    /// The profile's standard deviations beside the fitted ones, and the source blamed.
    pub fn report(&self, motion: &MotionModel, sensor: &Sensor) -> NoiseReport {
        let of = |[q, r]: [f64; 2]| {
            let [m1, m2] = motion.noise_sigmas();
            let (q, r) = (q.sqrt(), r.sqrt());
            [
                m1 * q,
                m2 * q,
                sensor.sigma_range * r,
                sensor.sigma_bearing * r,
            ]
        };
        NoiseReport {
            profile: of([1.0; 2]),
            fitted: of(self.fitted),
            blames_odometry: self.blames_odometry(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `scans` scans of five observations each, in directions that turn from one
    /// to the next, of a pose error larger along x than across, drawn with variance
    /// scales `(q, r)` against the profile.
    fn fit_to(q: f64, r: f64, scans: usize) -> NoiseFit {
        use nalgebra::{Matrix2x3, Matrix3};
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = crate::rng::seeded(7);
        let mut fit = NoiseFit::default();
        let noise = Matrix2::new(0.01, 0.0, 0.0, 3e-4);
        let map = Matrix2::new(1e-3, 0.0, 0.0, 1e-5);
        let prior = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.02, 0.002, 1e-4));
        for scan in 0..scans {
            fit.start_scan();
            for k in 0..5 {
                let (sin, cos) = ((scan * 5 + k) as f64 * 0.7).sin_cos();
                let range = 5.0 + k as f64 * 3.0;
                let h = Matrix2x3::new(cos, sin, 0.0, -sin / range, cos / range, -1.0);
                let pose = h * prior * h.transpose();
                let truth = map + q * pose + r * noise;
                let mut draw = || -> f64 { StandardNormal.sample(&mut rng) };
                let nu = truth.cholesky().unwrap().l() * Vector2::new(draw(), draw());
                fit.add(&nu, &pose, &map, &noise);
            }
            fit.end_scan();
        }
        fit
    }

    /// Whether the fitted σ's are within 30 % of the truth's, `truth` in variance scales.
    fn within_30_percent(fit: &NoiseFit, truth: [f64; 2]) -> bool {
        (fit.fitted().iter().zip(truth)).all(|(f, t)| ((f / t).sqrt() - 1.0).abs() < 0.3)
    }

    #[test]
    fn the_fit_finds_the_source_whose_noise_is_too_small() {
        for (truth, blames_odometry) in [([16.0, 1.0], true), ([1.0, 16.0], false)] {
            let fit = fit_to(truth[0], truth[1], 600);
            assert!(within_30_percent(&fit, truth), "{:?}", fit.fitted());
            assert_eq!(fit.blames_odometry(), Some(blames_odometry));
        }
    }

    #[test]
    fn adapt_takes_one_of_its_three_names_and_a_switch_is_refused_naming_them() {
        let read = |text: &str| toml::from_str::<NoiseConfig>(text).map(|c| c.adapt);
        assert_eq!(read("adapt = \"innovations\"").unwrap(), Adapt::Innovations);
        assert_eq!(read("").unwrap(), Adapt::Smoother);
        let refused = read("adapt = true").unwrap_err().to_string();
        assert!(
            refused.contains("\"off\", \"innovations\", \"smoother\""),
            "{refused}"
        );
    }

    #[test]
    fn the_fit_waits_for_its_warm_up_and_stays_in_bounds() {
        let early = fit_to(16.0, 1.0, 10);
        assert!(!early.warmed_up());
        assert_eq!((early.fitted(), early.blames_odometry()), ([1.0; 2], None));
        let wild = fit_to(1e4, 1.0, 600);
        assert_eq!(wild.fitted()[0], MAX_SCALE);
    }
}
