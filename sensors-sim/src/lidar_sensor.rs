//! The simulated scanning lidar: every beam is ray-cast against the world's walls (line
//! segments) and poles (circles); the nearest hit within range, plus Gaussian range noise,
//! is the beam's range. Some beams return spuriously short or not at all.

use crate::scenario::{LidarSpec, NoReturn, World};
use crate::vehicle::State;
use fastslam_estimation::rng::SimRng;
use fastslam_protocol::{Header, LaserScanHeader};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::f64::consts::TAU;

/// What a beam's return came from (the simulator's truth, for tests and intensities).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// Wall number `i` of the world.
    Wall(usize),
    /// Pole number `i` of the world.
    Pole(usize),
    /// A spurious short return.
    Spurious,
    /// No return.
    Nothing,
}

impl Target {
    /// The intensity the lidar reports for a return from this target.
    fn intensity(self) -> f32 {
        match self {
            Self::Wall(_) => 100.0,
            Self::Pole(_) => 200.0,
            Self::Spurious => 20.0,
            Self::Nothing => 0.0,
        }
    }
}

/// One simulated scan: the ranges (and intensities) as sent, and what each beam saw.
#[derive(Debug, Clone, PartialEq)]
pub struct SimScan {
    /// Ranges then, if the lidar sends them, intensities: the message's slice.
    pub data: Vec<f32>,
    /// What each beam's return came from.
    pub targets: Vec<Target>,
}

/// The lidar over one world.
#[derive(Debug, Clone)]
pub struct Lidar {
    spec: LidarSpec,
    walls: Vec<[f64; 4]>,
    poles: Vec<[f64; 3]>,
    rng: SimRng,
}

impl Lidar {
    /// A lidar seeing `world`, whose noise comes from `rng`.
    pub fn new(spec: LidarSpec, world: &World, rng: SimRng) -> Self {
        Self {
            spec,
            walls: world.walls.clone(),
            poles: world.poles.clone(),
            rng,
        }
    }

    /// Direction of the first beam (rad) and the angle between beams (rad).
    pub fn beam_layout(&self) -> (f64, f64) {
        let fov = self.spec.fov_deg.to_radians();
        let beams = f64::from(self.spec.beams);
        if fov >= TAU - 1e-9 {
            (-TAU / 2.0, TAU / beams)
        } else {
            (-fov / 2.0, fov / (beams - 1.0))
        }
    }

    /// The nearest obstacle along the ray from `(x, y)` in direction `angle` (rad) within
    /// the lidar's range, with what it is.
    pub fn cast(&self, x: f64, y: f64, angle: f64) -> Option<(f64, Target)> {
        let (dx, dy) = (angle.cos(), angle.sin());
        let mut best: Option<(f64, Target)> = None;
        let mut consider = |t: f64, target| {
            if t >= 0.0 && t <= self.spec.max_range_m && best.is_none_or(|(b, _)| t < b) {
                best = Some((t, target));
            }
        };
        for (i, w) in self.walls.iter().enumerate() {
            // Ray p + t·d against segment a + u·(b − a), u ∈ [0, 1].
            let (ex, ey) = (w[2] - w[0], w[3] - w[1]);
            let denominator = dx * ey - dy * ex;
            if denominator.abs() < 1e-12 {
                continue;
            }
            let (ax, ay) = (w[0] - x, w[1] - y);
            let t = (ax * ey - ay * ex) / denominator;
            let u = (ax * dy - ay * dx) / denominator;
            if (0.0..=1.0).contains(&u) {
                consider(t, Target::Wall(i));
            }
        }
        for (i, p) in self.poles.iter().enumerate() {
            let (cx, cy, r) = (p[0] - x, p[1] - y, p[2]);
            let along = cx * dx + cy * dy;
            let across2 = cx * cx + cy * cy - along * along;
            if along > 0.0 && across2 <= r * r {
                consider(along - (r * r - across2).sqrt(), Target::Pole(i));
            }
        }
        best
    }

    /// A noisy scan from pose `s`.
    pub fn scan(&mut self, s: State) -> SimScan {
        let (angle_min, increment) = self.beam_layout();
        let beams = self.spec.beams as usize;
        let no_return = match self.spec.no_return {
            NoReturn::Infinity => f32::INFINITY,
            NoReturn::MaxRange => self.spec.max_range_m as f32,
        };
        let mut ranges = Vec::with_capacity(beams);
        let mut targets = Vec::with_capacity(beams);
        for i in 0..beams {
            let truth = self.cast(s.x, s.y, s.theta + angle_min + i as f64 * increment);
            let (u_drop, u_spurious, u_where): (f64, f64, f64) =
                (self.rng.random(), self.rng.random(), self.rng.random());
            let noise: f64 = self.rng.sample(StandardNormal);
            let spec = &self.spec;
            let (range, target) = if u_drop < spec.dropout_probability {
                (None, Target::Nothing)
            } else if u_spurious < spec.spurious_probability {
                let far = truth.map_or(spec.max_range_m, |(t, _)| t);
                let r = spec.min_range_m + u_where * (far - spec.min_range_m).max(0.0);
                (Some(r), Target::Spurious)
            } else if let Some((t, target)) = truth {
                let r = (t + spec.sigma_range_m * noise).max(spec.min_range_m);
                ((r < spec.max_range_m).then_some(r), target)
            } else {
                (None, Target::Nothing)
            };
            let target = if range.is_some() {
                target
            } else {
                Target::Nothing
            };
            ranges.push(range.map_or(no_return, |r| r as f32));
            targets.push(target);
        }
        let mut data = ranges;
        if self.spec.intensities {
            data.extend(targets.iter().map(|t| t.intensity()));
        }
        SimScan { data, targets }
    }

    /// The message header of a scan stamped `header`, taken every `scan_time_s`.
    pub fn header(&self, header: Header, scan_time_s: f64) -> LaserScanHeader {
        let (angle_min, increment) = self.beam_layout();
        LaserScanHeader {
            header,
            angle_min: angle_min as f32,
            angle_increment: increment as f32,
            time_increment: 0.0,
            scan_time: scan_time_s as f32,
            range_min: self.spec.min_range_m as f32,
            range_max: self.spec.max_range_m as f32,
            ranges: self.spec.beams,
            intensities: if self.spec.intensities {
                self.spec.beams
            } else {
                0
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_estimation::rng::seeded;

    fn spec() -> LidarSpec {
        LidarSpec {
            beams: 360,
            fov_deg: 360.0,
            min_range_m: 0.1,
            max_range_m: 20.0,
            sigma_range_m: 0.0,
            spurious_probability: 0.0,
            dropout_probability: 0.0,
            no_return: NoReturn::Infinity,
            intensities: false,
        }
    }

    fn world() -> World {
        World {
            landmarks: Vec::new(),
            poles: vec![[5.0, 0.0, 0.5]],
            walls: vec![[-3.0, -10.0, -3.0, 10.0]],
        }
    }

    #[test]
    fn rays_hit_the_nearest_wall_or_pole() {
        let lidar = Lidar::new(spec(), &world(), seeded(1));
        assert_eq!(lidar.cast(0.0, 0.0, 0.0), Some((4.5, Target::Pole(0))));
        let (r, t) = lidar.cast(0.0, 0.0, std::f64::consts::PI).unwrap();
        assert!((r - 3.0).abs() < 1e-12 && t == Target::Wall(0));
        let (r, _) = lidar
            .cast(0.0, 0.0, 3.0 * std::f64::consts::FRAC_PI_4)
            .unwrap();
        assert!((r - 3.0 * 2f64.sqrt()).abs() < 1e-9, "slanted hit {r}");
        assert_eq!(lidar.cast(0.0, 0.0, std::f64::consts::FRAC_PI_2), None);
        assert_eq!(lidar.cast(10.0, 0.0, 0.0), None, "the pole is behind");
    }

    #[test]
    fn scans_report_no_returns_noise_and_intensities_as_configured() {
        let pose = State::default();
        let quiet = Lidar::new(spec(), &world(), seeded(1)).scan(pose);
        assert_eq!(quiet.data.len(), 360);
        assert_eq!(quiet.data[180], 4.5, "beam 180 points forward");
        assert!(quiet.data[90].is_infinite(), "nothing to the right");
        let max_range = LidarSpec {
            no_return: NoReturn::MaxRange,
            intensities: true,
            ..spec()
        };
        let scan = Lidar::new(max_range, &world(), seeded(1)).scan(pose);
        assert_eq!(scan.data.len(), 720);
        assert_eq!((scan.data[90], scan.data[360 + 90]), (20.0, 0.0));
        assert_eq!(scan.data[360 + 180], 200.0, "a pole's intensity");
        let noisy = LidarSpec {
            sigma_range_m: 0.05,
            ..spec()
        };
        let mut lidar = Lidar::new(noisy, &world(), seeded(2));
        let errors: Vec<f64> = (0..2000)
            .map(|_| f64::from(lidar.scan(pose).data[0]) - 3.0)
            .collect();
        let sd = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        assert!((sd - 0.05).abs() < 0.005, "range noise {sd}");
        let dropouts = LidarSpec {
            dropout_probability: 1.0,
            ..spec()
        };
        let scan = Lidar::new(dropouts, &world(), seeded(3)).scan(pose);
        assert!(scan.targets.iter().all(|t| *t == Target::Nothing));
        let clutter = LidarSpec {
            spurious_probability: 1.0,
            ..spec()
        };
        let scan = Lidar::new(clutter, &world(), seeded(4)).scan(pose);
        assert!(scan.data[180] < 4.5 && scan.targets[180] == Target::Spurious);
    }
}
