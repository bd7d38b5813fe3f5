//! A simulated run in the manner of Bailey's simulator, for the FastSLAM behaviour tests:
//! a bicycle driven by true controls, odometry reporting them with Gaussian noise every
//! 25 ms, range–bearing scans of the landmarks in the front half-plane within 30 m every 8
//! control periods (0.2 s).

use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::{
    AssociationMode, FastSlam, FastSlamConfig, MapLandmark, PoseRefiner,
};
use fastslam_estimation::motion::{Control, MotionModel};
use fastslam_estimation::observation::{Observation, Sensor, measure};
use fastslam_estimation::rng::{SimRng, seeded};
use nalgebra::{Matrix2, Vector2};
use rand::RngExt;
use rand_distr::StandardNormal;

/// The control period (s).
pub const DT: f64 = 0.025;
/// Control periods between two scans.
pub const CONTROLS_PER_SCAN: usize = 8;
/// The true speed (m/s).
pub const SPEED: f64 = 3.0;

/// A simulated run: truth, odometry, scans, with a dead-reckoning reference.
pub struct Sim {
    /// The true landmarks; a landmark's id is its index.
    pub landmarks: Vec<Vector2<f64>>,
    /// The true pose.
    pub truth: Pose2,
    dead_reckoning: Pose2,
    model: MotionModel,
    sensor: Sensor,
    rng: SimRng,
}

/// Errors collected at every scan.
#[derive(Default)]
pub struct Errors {
    /// The published estimate's distance from the truth (m).
    pub filter: Vec<f64>,
    /// Dead reckoning's distance from the truth (m).
    pub dead_reckoning: Vec<f64>,
    /// Scans after which the particles were resampled.
    pub resampled: usize,
}

/// Root mean square of `v`.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
}

/// Distance between the positions of two poses (m).
pub fn distance(a: &Pose2, b: &Pose2) -> f64 {
    (a.x - b.x).hypot(a.y - b.y)
}

impl Sim {
    /// A run among `landmarks` from the origin, its noise drawn from `seed`.
    pub fn new(landmarks: Vec<Vector2<f64>>, seed: u64) -> Self {
        Self {
            landmarks,
            truth: Pose2::default(),
            dead_reckoning: Pose2::default(),
            model: MotionModel::default(),
            sensor: Sensor::default(),
            rng: seeded(seed),
        }
    }

    fn normal(&mut self) -> f64 {
        self.rng.sample(StandardNormal)
    }

    /// One control period: the truth moves with `steering`, odometry reports it noisily.
    pub fn odometry(&mut self, steering: f64) -> Control {
        let truth = Control {
            v: SPEED,
            omega: 0.0,
            steering,
            ..Control::ZERO
        };
        self.truth = self.model.propagate(&self.truth, &truth, DT);
        let MotionModel::Bicycle(bicycle) = &self.model else {
            unreachable!("the simulator drives a bicycle")
        };
        let (sv, sg) = (bicycle.sigma_v, bicycle.sigma_steering);
        let reported = Control {
            v: SPEED + sv * self.normal(),
            omega: 0.0,
            steering: steering + sg * self.normal(),
            ..Control::ZERO
        };
        self.dead_reckoning = self.model.propagate(&self.dead_reckoning, &reported, DT);
        reported
    }

    /// A noisy scan of the landmarks in the true footprint, with their ids.
    pub fn scan(&mut self) -> Vec<Observation> {
        let mut out = Vec::new();
        for k in 0..self.landmarks.len() {
            let z = measure(&self.truth, &self.landmarks[k]);
            if self.sensor.sees(&z, 0.0, 0.0) {
                out.push(Observation {
                    range: z[0] + self.sensor.sigma_range * self.normal(),
                    bearing: z[1] + self.sensor.sigma_bearing * self.normal(),
                    id: Some(k as u64),
                });
            }
        }
        out
    }

    /// Drives `scans` scans with the steering of `route(scan index)`, feeding `slam`;
    /// `extra(scan index)` may add observations (clutter) to a scan.
    pub fn run(
        &mut self,
        slam: &mut FastSlam,
        scans: usize,
        route: impl Fn(usize) -> f64,
        extra: impl Fn(usize, &Pose2) -> Vec<Observation>,
    ) -> Errors {
        self.run_refined(slam, scans, route, extra, None)
    }

    /// [`Sim::run`] with a pose refiner in step 2.
    pub fn run_refined(
        &mut self,
        slam: &mut FastSlam,
        scans: usize,
        route: impl Fn(usize) -> f64,
        extra: impl Fn(usize, &Pose2) -> Vec<Observation>,
        mut refiner: Option<&mut dyn PoseRefiner>,
    ) -> Errors {
        let mut errors = Errors::default();
        for s in 0..scans {
            for _ in 0..CONTROLS_PER_SCAN {
                let control = self.odometry(route(s));
                slam.predict(&control, DT).unwrap();
            }
            let mut scan = self.scan();
            scan.extend(extra(s, &self.truth));
            let sensor = slam.config().sensor.clone();
            let refiner = refiner.as_mut().map(|r| &mut **r as &mut dyn PoseRefiner);
            let mut published = None;
            let report = slam
                .update_publishing(&scan, &sensor, refiner, |e| published = Some(*e))
                .unwrap();
            let estimate = published.expect("a successful step publishes its estimate");
            if !(report.resampled || slam.defers_sampling()) {
                // The map updates move no pose: without resampling, the published cloud
                // is the filter's.
                assert_eq!(estimate, slam.estimate());
            }
            errors.resampled += usize::from(report.resampled);
            errors.filter.push(distance(&estimate.mean, &self.truth));
            errors
                .dead_reckoning
                .push(distance(&self.dead_reckoning, &self.truth));
        }
        errors
    }
}

/// The filter's defaults with `mode` association, `seed` and Bailey's resampling threshold.
pub fn config(mode: AssociationMode, seed: u64) -> FastSlamConfig {
    let mut config = FastSlamConfig {
        seed,
        ..FastSlamConfig::default()
    };
    config.association.mode = mode;
    config.resampling.neff_ratio = 0.75; // Bailey's scenario
    config
}

/// Two rows of landmarks along the x axis, `spacing` apart, 8 m either side.
pub fn corridor(length: f64, spacing: f64) -> Vec<Vector2<f64>> {
    let n = (length / spacing) as usize;
    (0..=n)
        .flat_map(|k| {
            let x = k as f64 * spacing + 5.0;
            [Vector2::new(x, 8.0), Vector2::new(x + spacing / 2.0, -8.0)]
        })
        .collect()
}

/// No extra observations: for [`Sim::run`]'s `extra`.
pub fn no_clutter(_: usize, _: &Pose2) -> Vec<Observation> {
    Vec::new()
}

/// The simulator's landmarks as a surveyed prior map (1 cm standard deviation).
pub fn surveyed(landmarks: &[Vector2<f64>]) -> Vec<MapLandmark> {
    landmarks
        .iter()
        .enumerate()
        .map(|(k, &mean)| MapLandmark {
            id: k as u64,
            mean,
            covariance: Matrix2::identity() * 1e-4,
            hits: 10,
        })
        .collect()
}

/// Pairs every landmark of `a` with its nearest in `b`; returns the largest distance.
pub fn worst_nearest(a: &[MapLandmark], b: &[Vector2<f64>]) -> f64 {
    a.iter()
        .map(|l| {
            b.iter()
                .map(|p| (l.mean - p).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}
