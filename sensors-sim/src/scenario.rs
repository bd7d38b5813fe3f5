//! Scenario files: one TOML file describes a simulated experiment. The shipped ones are
//! built into the binaries (so the default runs from any directory) and found by name;
//! any other file is found by path.

use serde::Deserialize;
use std::collections::HashSet;

/// Scenarios shipped with the stack: (name, file contents).
pub const BUILT_IN: &[(&str, &str)] = &[
    (
        "bailey-webmap",
        include_str!("../scenarios/bailey-webmap.toml"),
    ),
    (
        "bailey-loop-biased",
        include_str!("../scenarios/bailey-loop-biased.toml"),
    ),
    (
        "office-corridors",
        include_str!("../scenarios/office-corridors.toml"),
    ),
    (
        "bailey-short",
        include_str!("../scenarios/bailey-short.toml"),
    ),
    (
        "bailey-dense",
        include_str!("../scenarios/bailey-dense.toml"),
    ),
    (
        "bailey-poles",
        include_str!("../scenarios/bailey-poles.toml"),
    ),
    (
        "structured-100m",
        include_str!("../scenarios/structured-100m.toml"),
    ),
    ("indoor-loop", include_str!("../scenarios/indoor-loop.toml")),
];

/// The scenario a plain `run` uses.
pub const DEFAULT_SCENARIO: &str = "bailey-webmap";

/// What can be wrong with a scenario.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScenarioError {
    /// Neither a built-in name nor a readable file.
    #[error("scenario `{name}` is neither a built-in ({built_in}) nor a readable file: {reason}")]
    NotFound {
        /// What was asked for.
        name: String,
        /// The built-in names.
        built_in: String,
        /// Why the file could not be read.
        reason: String,
    },
    /// The TOML does not parse or has unknown/missing keys.
    #[error("scenario `{name}`: {reason}")]
    Parse {
        /// The scenario's name or path.
        name: String,
        /// The parser's message.
        reason: String,
    },
    /// A number is outside the range that keeps a run finite.
    #[error(
        "scenario `{name}`: `{field}` = {} is outside its allowed range {range}",
        short(*.value)
    )]
    OutOfRange {
        /// The scenario's name.
        name: String,
        /// The offending key.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range, with its unit.
        range: &'static str,
    },
    /// A value is outside its valid range.
    #[error("scenario `{name}`: `{field}` {reason}")]
    Invalid {
        /// The scenario's name.
        name: String,
        /// The offending key.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
}

/// `v` in plain digits, or in scientific notation when very large or small.
fn short(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A simulated experiment.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name, used for run folders.
    pub name: String,
    /// Seed of every random draw of the simulation (the `--seed` flag overrides it).
    pub seed: u64,
    /// Clock of the simulation.
    pub timing: Timing,
    /// The vehicle and how it steers.
    pub vehicle: VehicleSpec,
    /// Where the vehicle drives.
    pub route: Route,
    /// What is in the world.
    pub world: World,
    /// Noise of the odometry sensor.
    pub odometry: OdometrySpec,
    /// The feature-level landmark sensor (used when there is no `[lidar]`; default:
    /// Bailey's, without ids).
    #[serde(default)]
    pub landmark_sensor: LandmarkSensorSpec,
    /// A lidar that sends raw scans ray-cast against the walls and poles; when present,
    /// `lidar-sim` publishes scans instead of landmark observations.
    #[serde(default)]
    pub lidar: Option<LidarSpec>,
    /// Settings for the FastSLAM service that suit this scenario (its config file's
    /// format), passed on by the launcher.
    #[serde(default)]
    pub service: Option<toml::Table>,
}

/// Clock of the simulation.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    /// Control, ground-truth and odometry period (s).
    pub control_period_s: f64,
    /// A landmark observation every this many control periods.
    pub observe_every: u64,
}

/// The vehicle: kinematics, speed and steering limits.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase", deny_unknown_fields)]
pub enum VehicleSpec {
    /// Car-like vehicle steered by its front wheel.
    Bicycle {
        /// Distance between the axles (m).
        wheelbase_m: f64,
        /// Cruise speed (m/s).
        speed_mps: f64,
        /// Steering angle limit (deg).
        max_steer_deg: f64,
        /// Steering rate limit (deg/s).
        max_steer_rate_deg_s: f64,
    },
    /// Differential-drive robot commanded by speed and yaw rate.
    Unicycle {
        /// Cruise speed (m/s).
        speed_mps: f64,
        /// Yaw-rate limit (deg/s).
        max_yaw_rate_deg_s: f64,
        /// Yaw rate commanded per radian of heading error (1/s).
        heading_gain: f64,
    },
}

/// The most loops a route may have: 10 000 loops of the Bailey webmap are 23 days of
/// simulated driving; more is a typo, refused instead of running until a timeout.
pub const MAX_LOOPS: u32 = 10_000;

/// The bounds of the numbers that set a run's length and output: each key with its
/// allowed range, inclusive (`key`, lowest, highest, the range in words). A value outside
/// them is a typo that would run until a timeout, writing gigabytes.
pub const BOUNDS: &[(&str, f64, f64, &str)] = &[
    ("timing.control_period_s", 1e-3, 1.0, "0.001 to 1 s"),
    ("timing.observe_every", 1.0, 1000.0, "1 to 1000"),
    ("vehicle.speed_mps", 0.01, 50.0, "0.01 to 50 m/s"),
    ("route.switch_distance_m", 0.01, 1000.0, "0.01 to 1000 m"),
    (
        "route / world coordinates",
        -1e5,
        1e5,
        "-100000 to 100000 m",
    ),
    ("world.poles radius", 1e-3, 100.0, "0.001 to 100 m"),
    ("lidar.beams", 2.0, 65536.0, "2 to 65536"),
    ("lidar.max_range_m", 0.0, 1e4, "up to 10000 m"),
    ("landmark_sensor.max_range_m", 0.0, 1e4, "up to 10000 m"),
];

/// The route: waypoints driven in order, `loops` times.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Route {
    /// Switch to the next waypoint within this distance (m).
    pub switch_distance_m: f64,
    /// How many times the waypoint list is driven.
    pub loops: u32,
    /// Waypoints `[x, y]` (m); the vehicle starts at the origin heading +x.
    pub waypoints: Vec<[f64; 2]>,
}

/// The world's contents.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Point landmarks `[x, y]` (m): seen by the feature-level sensor, invisible to a
    /// lidar.
    #[serde(default)]
    pub landmarks: Vec<[f64; 2]>,
    /// Round poles `[x, y, radius]` (m): obstacles a lidar sees, and landmarks.
    #[serde(default)]
    pub poles: Vec<[f64; 3]>,
    /// Walls, line segments `[x1, y1, x2, y2]` (m): obstacles a lidar sees, no landmarks.
    #[serde(default)]
    pub walls: Vec<[f64; 4]>,
}

impl World {
    /// Every landmark position: the point landmarks, then the poles' centres. A
    /// landmark's id is its index here (the true map and known association use it).
    pub fn point_landmarks(&self) -> Vec<[f64; 2]> {
        let poles = self.poles.iter().map(|p| [p[0], p[1]]);
        self.landmarks.iter().copied().chain(poles).collect()
    }

    /// How well a map's occupied cells (their centres, m, on a lattice of side
    /// `resolution`) draw this world's walls and poles: **precision**, the share of cells
    /// within `tolerance` (m) of a wall or a pole's surface, and **recall**, the share of
    /// points every 0.1 m along the walls with an occupied cell within `tolerance` (walls
    /// the route never saw count as missed). NaN when there are no cells or no walls.
    pub fn map_precision_recall(
        &self,
        cells: &[[f64; 2]],
        resolution: f64,
        tolerance: f64,
    ) -> (f64, f64) {
        let near_structure = |p: [f64; 2]| {
            self.walls.iter().any(|w| to_segment(p, w) <= tolerance)
                || (self.poles.iter())
                    .any(|c| ((p[0] - c[0]).hypot(p[1] - c[1]) - c[2]).abs() <= tolerance)
        };
        let precision =
            cells.iter().filter(|&&p| near_structure(p)).count() as f64 / cells.len() as f64;
        let key = |p: [f64; 2]| {
            (
                (p[0] / resolution).floor() as i64,
                (p[1] / resolution).floor() as i64,
            )
        };
        let occupied: HashSet<(i64, i64)> = cells.iter().map(|&p| key(p)).collect();
        let reach = (tolerance / resolution).ceil() as i64;
        let found = |p: [f64; 2]| {
            let (i, j) = key(p);
            (-reach..=reach)
                .any(|di| (-reach..=reach).any(|dj| occupied.contains(&(i + di, j + dj))))
        };
        let samples: Vec<[f64; 2]> = (self.walls.iter())
            .flat_map(|w| {
                let n = ((w[2] - w[0]).hypot(w[3] - w[1]) / 0.1).ceil().max(1.0) as usize;
                (0..=n).map(move |k| {
                    let t = k as f64 / n as f64;
                    [w[0] + t * (w[2] - w[0]), w[1] + t * (w[3] - w[1])]
                })
            })
            .collect();
        let recall = samples.iter().filter(|&&p| found(p)).count() as f64 / samples.len() as f64;
        (precision, recall)
    }
}

/// Distance from `p` to the segment `w` = [x1, y1, x2, y2] (m).
fn to_segment(p: [f64; 2], w: &[f64; 4]) -> f64 {
    let (dx, dy) = (w[2] - w[0], w[3] - w[1]);
    let length2 = dx * dx + dy * dy;
    let t = if length2 > 0.0 {
        (((p[0] - w[0]) * dx + (p[1] - w[1]) * dy) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - w[0] - t * dx).hypot(p[1] - w[1] - t * dy)
}

/// Odometry errors: white noise on the measured controls (standard deviations) and,
/// optionally, systematic errors like a real vehicle's (a wrong wheel radius scales the
/// speed; a misaligned steering sensor offsets the angle).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometrySpec {
    /// Speed noise (m/s).
    pub sigma_v_mps: f64,
    /// Steering-angle noise (deg), for a bicycle.
    #[serde(default)]
    pub sigma_steer_deg: f64,
    /// Yaw-rate noise (deg/s), for a unicycle.
    #[serde(default)]
    pub sigma_omega_deg_s: f64,
    /// Measured speed = true speed × this (1 = no scale error).
    #[serde(default = "one")]
    pub speed_scale: f64,
    /// Added to the measured steering angle (deg), for a bicycle.
    #[serde(default)]
    pub steer_offset_deg: f64,
    /// Added to the measured yaw rate (deg/s), for a unicycle.
    #[serde(default)]
    pub omega_offset_deg_s: f64,
}

fn one() -> f64 {
    1.0
}

/// The landmark sensor: what it sees and how noisily.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LandmarkSensorSpec {
    /// Maximum range (m).
    pub max_range_m: f64,
    /// Field of view centred on the heading (deg).
    pub fov_deg: f64,
    /// Range noise (m).
    pub sigma_range_m: f64,
    /// Bearing noise (deg).
    pub sigma_bearing_deg: f64,
    /// Report each landmark's id (known data association).
    pub report_ids: bool,
}

impl Default for LandmarkSensorSpec {
    /// Bailey's simulator: 30 m over the front half-plane, σ_r 0.1 m, σ_b 1°, no ids.
    fn default() -> Self {
        Self {
            max_range_m: 30.0,
            fov_deg: 180.0,
            sigma_range_m: 0.1,
            sigma_bearing_deg: 1.0,
            report_ids: false,
        }
    }
}

/// A scanning lidar: beam layout, range, noise and clutter. One scan every
/// `timing.observe_every` control periods (so 40 Hz … 5 Hz at a 25 ms control period);
/// every beam of a scan is taken at the scan's pose (`time_increment` = 0).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LidarSpec {
    /// Beams per scan (e.g. 361 over 180°, 720 over 360°).
    pub beams: u32,
    /// Angular span centred on the heading (deg); 360 = a full turn (then the beams are
    /// 360°/beams apart, else span/(beams − 1)).
    pub fov_deg: f64,
    /// Shortest range measured (m).
    pub min_range_m: f64,
    /// Longest range measured (m).
    pub max_range_m: f64,
    /// Range noise of a return (m).
    pub sigma_range_m: f64,
    /// Chance per beam of a spurious short return (dust, rain, a passer-by): a range
    /// drawn uniformly between `min_range_m` and the true range.
    #[serde(default)]
    pub spurious_probability: f64,
    /// Chance per beam of a missing return (a dark or glancing surface).
    #[serde(default)]
    pub dropout_probability: f64,
    /// What a beam without a return reports: `"infinity"` (REP-117) or `"max_range"`
    /// (like scanners that report a fixed maximum value).
    #[serde(default)]
    pub no_return: NoReturn,
    /// Also send an intensity per beam (walls 100, poles 200, spurious returns 20, no
    /// return 0).
    #[serde(default)]
    pub intensities: bool,
}

/// What a lidar reports for a beam that saw nothing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoReturn {
    /// `+∞`, as REP-117 asks.
    #[default]
    Infinity,
    /// Exactly `max_range_m`.
    MaxRange,
}

impl Scenario {
    /// Loads a built-in scenario by name, or a scenario file by path.
    ///
    /// # Errors
    /// [`ScenarioError`] when it cannot be found, parsed or validated.
    pub fn load(name_or_path: &str) -> Result<Self, ScenarioError> {
        let text =
            fastslam_protocol::cli::built_in_or_file(name_or_path, BUILT_IN).map_err(|e| {
                ScenarioError::NotFound {
                    name: name_or_path.to_string(),
                    built_in: e.built_in,
                    reason: e.reason,
                }
            })?;
        let scenario = Self::parse(name_or_path, &text)?;
        // A file named as a built-in would share its run folder, and overwrite it.
        let impostor = BUILT_IN
            .iter()
            .any(|(name, built_in)| *name == scenario.name && *built_in != text);
        if impostor {
            return Err(ScenarioError::Invalid {
                name: scenario.name,
                field: "name",
                reason: "is a built-in scenario's: a scenario file of other content needs a \
                         name of its own (run folders are named after it)",
            });
        }
        Ok(scenario)
    }

    /// Parses and validates scenario text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`ScenarioError::Parse`] or [`ScenarioError::Invalid`].
    pub fn parse(origin: &str, text: &str) -> Result<Self, ScenarioError> {
        let scenario: Self = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            name: origin.to_string(),
            reason: e.to_string(),
        })?;
        scenario.validate()?;
        Ok(scenario)
    }

    /// The first number outside [`BOUNDS`], as an error naming its key and range.
    fn check_bounds(&self) -> Result<(), ScenarioError> {
        let speed = match self.vehicle {
            VehicleSpec::Bicycle { speed_mps, .. } | VehicleSpec::Unicycle { speed_mps, .. } => {
                speed_mps
            }
        };
        let w = &self.world;
        let coordinates = (self.route.waypoints.iter().chain(&w.landmarks).flatten())
            .chain(w.poles.iter().flat_map(|p| &p[..2]))
            .chain(w.walls.iter().flatten());
        let mut values: Vec<(&str, f64)> = vec![
            ("timing.control_period_s", self.timing.control_period_s),
            ("timing.observe_every", self.timing.observe_every as f64),
            ("vehicle.speed_mps", speed),
            ("route.switch_distance_m", self.route.switch_distance_m),
        ];
        values.extend(coordinates.map(|&v| ("route / world coordinates", v)));
        values.extend(w.poles.iter().map(|p| ("world.poles radius", p[2])));
        if let Some(l) = &self.lidar {
            values.push(("lidar.beams", f64::from(l.beams)));
            values.push(("lidar.max_range_m", l.max_range_m));
        }
        values.push((
            "landmark_sensor.max_range_m",
            self.landmark_sensor.max_range_m,
        ));
        for (field, value) in values {
            let Some(&(field, low, high, range)) = BOUNDS.iter().find(|b| b.0 == field) else {
                continue;
            };
            // NaN is outside every range.
            if !(low..=high).contains(&value) {
                return Err(ScenarioError::OutOfRange {
                    name: self.name.clone(),
                    field,
                    value,
                    range,
                });
            }
        }
        Ok(())
    }

    fn validate(&self) -> Result<(), ScenarioError> {
        self.check_bounds()?;
        let invalid = |field, reason| {
            Err(ScenarioError::Invalid {
                name: self.name.clone(),
                field,
                reason,
            })
        };
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let non_negative = |v: f64| v.is_finite() && v >= 0.0;
        if !positive(self.timing.control_period_s) {
            return invalid("timing.control_period_s", "must be > 0");
        }
        if self.timing.observe_every == 0 {
            return invalid("timing.observe_every", "must be ≥ 1");
        }
        if self.route.waypoints.is_empty() || self.route.loops == 0 {
            return invalid("route", "needs at least one waypoint and one loop");
        }
        if self.route.loops > MAX_LOOPS {
            return invalid("route.loops", "must be at most 10000");
        }
        if !positive(self.route.switch_distance_m) {
            return invalid("route.switch_distance_m", "must be > 0");
        }
        let points = self.route.waypoints.iter().chain(&self.world.landmarks);
        let shapes = self
            .world
            .poles
            .iter()
            .flatten()
            .chain(self.world.walls.iter().flatten());
        if points.flatten().chain(shapes).any(|v| !v.is_finite()) {
            return invalid("route / world", "coordinates must be finite");
        }
        if self.world.poles.iter().any(|p| p[2] <= 0.0) {
            return invalid("world.poles", "radius must be > 0");
        }
        if let Some(l) = &self.lidar {
            let probability = |p: f64| (0.0..=1.0).contains(&p);
            let valid = l.beams >= 2
                && positive(l.fov_deg)
                && l.fov_deg <= 360.0
                && non_negative(l.min_range_m)
                && l.min_range_m < l.max_range_m
                && non_negative(l.sigma_range_m)
                && probability(l.spurious_probability)
                && probability(l.dropout_probability);
            if !valid {
                return invalid(
                    "lidar",
                    "needs beams ≥ 2, fov_deg in (0, 360], 0 ≤ min_range_m < max_range_m, \
                     sigma ≥ 0 and probabilities in [0, 1]",
                );
            }
        }
        let speed_ok = match &self.vehicle {
            VehicleSpec::Bicycle {
                wheelbase_m,
                speed_mps,
                max_steer_deg,
                max_steer_rate_deg_s,
            } => [
                *wheelbase_m,
                *speed_mps,
                *max_steer_deg,
                *max_steer_rate_deg_s,
            ]
            .into_iter()
            .all(positive),
            VehicleSpec::Unicycle {
                speed_mps,
                max_yaw_rate_deg_s,
                heading_gain,
            } => [*speed_mps, *max_yaw_rate_deg_s, *heading_gain]
                .into_iter()
                .all(positive),
        };
        if !speed_ok {
            return invalid("vehicle", "every parameter must be > 0");
        }
        let speed = match self.vehicle {
            VehicleSpec::Bicycle { speed_mps, .. } | VehicleSpec::Unicycle { speed_mps, .. } => {
                speed_mps
            }
        };
        if speed * self.timing.control_period_s > self.route.switch_distance_m {
            return invalid(
                "vehicle.speed_mps",
                "× timing.control_period_s must be at most route.switch_distance_m: a vehicle \
                 that moves further in one control period can pass its waypoints forever",
            );
        }
        let o = &self.odometry;
        if ![o.sigma_v_mps, o.sigma_steer_deg, o.sigma_omega_deg_s]
            .into_iter()
            .all(non_negative)
        {
            return invalid("odometry", "noise must be ≥ 0");
        }
        if !positive(o.speed_scale)
            || !o.steer_offset_deg.is_finite()
            || !o.omega_offset_deg_s.is_finite()
        {
            return invalid("odometry", "speed_scale must be > 0 and offsets finite");
        }
        let l = &self.landmark_sensor;
        if !(positive(l.max_range_m) && positive(l.fov_deg) && l.fov_deg <= 360.0) {
            return invalid(
                "landmark_sensor",
                "max_range_m must be > 0 and fov_deg in (0, 360]",
            );
        }
        if ![l.sigma_range_m, l.sigma_bearing_deg]
            .into_iter()
            .all(non_negative)
        {
            return invalid("landmark_sensor", "noise must be ≥ 0");
        }
        Ok(())
    }

    /// The observation period (s).
    pub fn observe_period_s(&self) -> f64 {
        self.timing.control_period_s * self.timing.observe_every as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_scenarios_load() {
        for (name, _) in BUILT_IN {
            let s = Scenario::load(name).unwrap();
            assert_eq!(&s.name, name);
            let landmarks = s.world.point_landmarks().len();
            match *name {
                "office-corridors" => assert_eq!(landmarks, 0, "not a single pole"),
                _ if name.starts_with("bailey") => assert!(landmarks >= 35, "{name}"),
                _ => assert!(landmarks >= 10, "{name}"),
            }
            // A lidar sees poles and walls; the feature-level sensor point landmarks.
            let obstacles = !(s.world.poles.is_empty() && s.world.walls.is_empty());
            assert_eq!(s.lidar.is_some(), obstacles, "{name}");
        }
    }

    #[test]
    fn a_scenario_file_may_not_take_a_built_in_name_unless_it_is_that_scenario() {
        let (name, text) = BUILT_IN[0];
        let dir = std::env::temp_dir().join(format!("scenario-name-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let copy = dir.join("copy.toml");
        std::fs::write(&copy, text).unwrap();
        let loaded = Scenario::load(&copy.display().to_string()).unwrap();
        assert_eq!(loaded.name, name, "an unchanged copy is that scenario");
        let edited = dir.join("edited.toml");
        std::fs::write(&edited, text.replacen("seed = 1", "seed = 2", 1)).unwrap();
        let err = Scenario::load(&edited.display().to_string()).unwrap_err();
        assert!(err.to_string().contains("built-in"), "{err}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn unknown_scenario_names_the_built_ins() {
        let err = Scenario::load("no-such-scenario").unwrap_err().to_string();
        assert!(err.contains("bailey-webmap"), "{err}");
    }

    #[test]
    fn numbers_that_would_run_forever_are_refused_with_their_key_and_range() {
        let good = BUILT_IN[0].1;
        for (from, to, key) in [
            (
                "speed_mps = 3.0",
                "speed_mps = 1e300",
                "`vehicle.speed_mps` = 1e300",
            ),
            (
                "speed_mps = 3.0",
                "speed_mps = 1e-300",
                "`vehicle.speed_mps`",
            ),
            (
                "control_period_s = 0.025",
                "control_period_s = 1e-9",
                "`timing.control_period_s` = 1e-9",
            ),
            (
                "observe_every = 8",
                "observe_every = 100000",
                "`timing.observe_every`",
            ),
            (
                "switch_distance_m = 1.0",
                "switch_distance_m = 1e9",
                "`route.switch_distance_m`",
            ),
            (
                "[12.649533, -41.588785]",
                "[12.649533, -2.5e7]",
                "`route / world coordinates` = -2.5e7",
            ),
        ] {
            assert!(good.contains(from), "{from}");
            let e = Scenario::parse("t", &good.replacen(from, to, 1)).unwrap_err();
            let e = e.to_string();
            assert!(e.contains(key) && e.contains("allowed range"), "{e}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
        let e = Scenario::parse("t", &good.replace("speed_mps = 3.0", "speed_mps = 45.0"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("vehicle.speed_mps") && e.contains("switch_distance_m"),
            "{e}"
        );
        let beams = BUILT_IN
            .iter()
            .find(|(n, _)| *n == "indoor-loop")
            .unwrap()
            .1;
        let e = Scenario::parse("t", &beams.replace("beams = 720", "beams = 4000000000"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`lidar.beams`"), "{e}");
    }

    #[test]
    fn unknown_keys_and_bad_values_are_rejected() {
        let good = BUILT_IN[0].1;
        let typo = good.replace("loops = 2", "loops = 2\nlooops = 3");
        assert!(matches!(
            Scenario::parse("t", &typo),
            Err(ScenarioError::Parse { .. })
        ));
        for (from, to) in [
            ("control_period_s = 0.025", "control_period_s = -1.0"),
            ("loops = 2", "loops = 10001"),
        ] {
            assert!(good.contains(from), "{from}");
            assert!(matches!(
                Scenario::parse("t", &good.replace(from, to)),
                Err(ScenarioError::Invalid { .. } | ScenarioError::OutOfRange { .. })
            ));
        }
    }
}
