//! The service's configuration file (TOML). Every section has defaults that run; unknown
//! keys are errors, so a typo is reported instead of silently ignored.
//!
//! ```toml
//! [filter]            # fastslam_estimation::fastslam::FastSlamConfig
//! particles = 100
//! proposal = "fastslam2"   # or "motion" (FastSLAM 1.0)
//! [filter.association]
//! mode = "known"
//! [features]        # fastslam_estimation::features::ExtractorConfig (raw scans)
//! max_range = 20.0
//! [grid]            # fastslam_estimation::grid::GridConfig (raw scans)
//! resolution = 0.1
//! [input]
//! lidar = "auto"
//! [optimizer]         # fastslam_estimation::optimise::OptimiserConfig
//! kind = "icoa"       # one of OptimiserKind::ALL (`--help` lists them)
//! iterations = 10
//! [optimizer.icoa]
//! omega_max = 0.9
//! [optimizer.hill]
//! climbers = 2       # only the best-starting members climb (0: all)
//! refinements = 5    # a climber stops after its step halved this often (0: never)
//! [moves]             # fastslam_estimation::moves::MoveConfig
//! bound_sigmas = 3.0
//! prior_weight = 1.0
//! correction = "proposal"   # or "resample-move", or "none" (the papers)
//! [output]
//! map_every = 5
//! grid_every = 50
//! particles_every = 0   # the particle cloud, for a live view (0: never)
//! [smoother]          # fastslam_estimation::graph::SmootherConfig
//! enabled = true
//! loop_gap_s = 30.0
//! reanchor = false
//! fuse_duplicates = true   # under unknown association: fuse landmarks mapped twice
//! [loop_closure]      # fastslam_estimation::loop_closure::LoopClosureConfig (grid maps)
//! enabled = false   # on in the planar-laser replay profile
//! delay_keyframes = 2
//! min_score = 0.6
//! ```
//!
//! IBA comes with its partial resampling (docs/ALGORITHMS.md §4.4): with `kind = "iba"`,
//! `[optimizer.iba] partial_resampling = true` (the default) and the papers' mode
//! (`[moves] correction = "none"`) the filter resamples with the partial EWA scheme
//! whatever `[filter.resampling] scheme` says ([`ServiceConfig::filter_config`]); the
//! scheme is biased, so the corrected modes keep the filter's own.

use clap::builder::PossibleValuesParser;
use fastslam_estimation::fastslam::{AssociationMode, FastSlamConfig, Proposal, ResamplingScheme};
use fastslam_estimation::features::ExtractorConfig;
use fastslam_estimation::graph::SmootherConfig;
use fastslam_estimation::grid::GridConfig;
use fastslam_estimation::gridslam::ScanMatchConfig;
use fastslam_estimation::loop_closure::LoopClosureConfig;
use fastslam_estimation::moves::{MoveConfig, MoveCorrection};
use fastslam_estimation::optimise::{OptimiserConfig, OptimiserKind};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What can be wrong with the configuration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("cannot read config {path}: {reason}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        reason: String,
    },
    /// The file is not valid TOML for this schema.
    #[error("config {path}: {reason}")]
    Parse {
        /// The file.
        path: String,
        /// The parser's message.
        reason: String,
    },
    /// A value is out of range, or a name is not one of the choices.
    #[error("invalid config: {0}")]
    Invalid(fastslam_estimation::Error),
}

impl From<fastslam_estimation::Error> for ConfigError {
    /// The estimator's reason, said once (not repeated as a `source` in error chains).
    fn from(e: fastslam_estimation::Error) -> Self {
        Self::Invalid(e)
    }
}

/// Everything the service needs to run.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ServiceConfig {
    /// The FastSLAM filter, its proposal included.
    pub filter: FastSlamConfig,
    /// The particle optimiser of step 2 (`kind = "none"` = no optimiser) and its constants.
    pub optimizer: OptimiserConfig,
    /// How the optimiser's moves are bounded, scored and corrected.
    pub moves: MoveConfig,
    /// What is published and how often.
    pub output: OutputConfig,
    /// Which lidar input the service takes.
    pub input: InputConfig,
    /// Pole extraction from raw scans.
    pub features: ExtractorConfig,
    /// The occupancy grid built from raw scans.
    pub grid: GridConfig,
    /// The smoothing back-end beside the filter (docs/ALGORITHMS.md §8.1).
    pub smoother: SmootherConfig,
    /// What each particle maps: landmarks, or an occupancy grid (docs/ALGORITHMS.md §9).
    pub map: MapConfig,
    /// Where the laser sits on the robot.
    pub laser: LaserConfig,
    /// The loop-closing back-end behind grid FastSLAM (docs/ALGORITHMS.md §9.1).
    pub loop_closure: LoopClosureConfig,
}

/// Where the laser sits on the robot (`[laser]`): the estimate is the base frame's pose,
/// and raw scans are placed through this mount (a ROS bag's `/tf_static` base → laser).
///
/// ```toml
/// mount = [0.2, 0.0, 0.0]
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LaserConfig {
    /// The laser's pose in the base frame (REP-103: x forward, y left): x (m), y (m),
    /// yaw (rad). Default: at the base's origin, facing forward.
    pub mount: [f64; 3],
}

impl LaserConfig {
    /// The mount as a pose.
    pub fn mount(&self) -> fastslam_estimation::Pose2 {
        let [x, y, yaw] = self.mount;
        fastslam_estimation::Pose2::new(x, y, yaw)
    }

    /// Checks that the mount is finite.
    ///
    /// # Errors
    /// [`ConfigError::Invalid`] naming `laser.mount`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.mount.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(fastslam_estimation::Error::InvalidParameter {
                name: "laser.mount",
                reason: format!("{:?} must be three finite numbers", self.mount),
            }
            .into())
        }
    }
}

/// What each particle maps (`[map]`).
///
/// ```toml
/// kind = "grid"
/// [matching]
/// sigma = 0.05
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapConfig {
    /// `landmarks` (the default) or `grid`.
    pub kind: MapKind,
    /// Grid FastSLAM's scan likelihood.
    pub matching: ScanMatchConfig,
}

/// What each particle maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MapKind {
    /// Point landmarks: observations, or poles extracted from raw scans (FastSLAM 1.0 /
    /// 2.0). The occupancy grid is drawn afterwards along the best particle's path.
    #[default]
    Landmarks,
    /// An occupancy grid per particle, matched against each raw scan to build the
    /// particle's proposal (grid FastSLAM, as GMapping). Raw scans only.
    Grid,
}

impl MapKind {
    /// The names, as in config files and on the command line.
    pub const NAMES: [&'static str; 2] = ["landmarks", "grid"];

    /// The name, as in config files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Landmarks => "landmarks",
            Self::Grid => "grid",
        }
    }

    /// The kind named `name`.
    ///
    /// # Errors
    /// [`ConfigError::Invalid`] naming the choices.
    pub fn parse(name: &str) -> Result<Self, ConfigError> {
        match name {
            "landmarks" => Ok(Self::Landmarks),
            "grid" => Ok(Self::Grid),
            _ => Err(fastslam_estimation::Error::InvalidParameter {
                name: "map.kind",
                reason: format!("`{name}` is not one of: {}", Self::NAMES.join(", ")),
            }
            .into()),
        }
    }
}

/// Which lidar input the service takes, and how it judges its inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InputConfig {
    /// `auto`: whichever of `scan` and `observations` gets a publisher first (a lidar
    /// process publishes one of them); or one of them by name.
    pub lidar: LidarInput,
    /// A stream that delivered nothing for this long (wall time, s) is *quiet*: the
    /// service marks itself degraded and stops waiting for it (odometry keeps
    /// predicting without the lidar; scans are processed without odometry). Real-time
    /// sensors only: as fast as possible no deadline applies.
    pub deadline_s: f64,
    /// Largest step between consecutive stamps of a stream (s); a bigger jump ahead is
    /// rejected (unless the stream was quiet). Default one hour: it catches garbage and
    /// far-future stamps, while a sensor that legitimately reports nothing for a while
    /// (MRCLAM robot 1 sees no landmark for 35 s) is not cut off.
    pub max_stamp_jump_s: f64,
    /// Largest plausible odometry speed |v| (m/s).
    pub max_speed_mps: f64,
    /// Largest plausible odometry yaw rate |ω| (rad/s).
    pub max_yaw_rate_rad_s: f64,
    /// Slack on the dead-reckoned position step beyond `max_speed_mps · dt` (m).
    pub pose_slack_m: f64,
    /// Most inputs waiting per stream, so a flooding publisher cannot grow the service's
    /// memory. In real time, beyond it the oldest is dropped and counted as overflow; as
    /// fast as possible, a full stream is not taken from until the queue has room.
    pub max_queue: usize,
    /// Rejections of one kind are logged once per this interval (s), then summarised.
    pub log_interval_s: f64,
}

impl Default for InputConfig {
    fn default() -> Self {
        Self {
            lidar: LidarInput::default(),
            deadline_s: 1.0,
            max_stamp_jump_s: 3600.0,
            max_speed_mps: 30.0,
            max_yaw_rate_rad_s: 10.0,
            pose_slack_m: 0.5,
            max_queue: crate::sequencer::DEFAULT_MAX_QUEUE,
            log_interval_s: 5.0,
        }
    }
}

impl InputConfig {
    /// Checks that every limit is a positive finite number.
    ///
    /// # Errors
    /// [`ConfigError::Invalid`] naming the first bad value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (name, v) in [
            ("input.deadline_s", self.deadline_s),
            ("input.max_stamp_jump_s", self.max_stamp_jump_s),
            ("input.max_speed_mps", self.max_speed_mps),
            ("input.max_yaw_rate_rad_s", self.max_yaw_rate_rad_s),
            ("input.pose_slack_m", self.pose_slack_m),
            ("input.log_interval_s", self.log_interval_s),
            ("input.max_queue", self.max_queue as f64),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(fastslam_estimation::Error::InvalidParameter {
                    name,
                    reason: format!("{v} must be a positive finite number"),
                }
                .into());
            }
        }
        Ok(())
    }

    /// The odometry plausibility limits.
    pub fn motion_limits(&self) -> fastslam_protocol::validate::MotionLimits {
        fastslam_protocol::validate::MotionLimits {
            max_speed: self.max_speed_mps,
            max_yaw_rate: self.max_yaw_rate_rad_s,
            pose_slack: self.pose_slack_m,
        }
    }
}

/// The lidar topic the service subscribes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum LidarInput {
    /// Whichever topic gets a publisher first (`scan` if both already have one).
    #[default]
    Auto,
    /// Raw scans on `scan`: poles are extracted, and the occupancy grid is built.
    Scan,
    /// Landmark observations on `observations` (a feature-level sensor).
    Observations,
}

/// What is published and how often.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputConfig {
    /// Publish the landmark map after every `map_every` observation steps (and always at
    /// the end); 0 publishes it only at the end. The default 5 is 1 Hz at Bailey's 5 Hz
    /// scans: each message carries the whole map, which changes slowly, and publishing
    /// it after every scan cost ≈ 15 % of the stack's streaming time as fast as possible
    /// (BENCHMARKS.md).
    pub map_every: u64,
    /// Publish the occupancy grid after every `grid_every` observation steps from raw
    /// scans (and always at the end); 0 publishes it only at the end. Building it stops
    /// the filter for a moment (see `fastslam_estimation::grid`), so keep this low-rate.
    pub grid_every: u64,
    /// Publish the particle cloud (every particle's pose and weight, for a live view)
    /// after every `particles_every` observation steps; 0, the default, never: a cloud is
    /// one pose per particle, and the run folder's `run.mcap` records each one.
    pub particles_every: u64,
}

impl Default for OutputConfig {
    fn default() -> Self {
        Self {
            map_every: 5,
            grid_every: 50,
            particles_every: 0,
        }
    }
}

/// The names of [`OptimiserKind::ALL`] as a command-line value parser, so `--help` lists
/// them and an unknown name is refused with the list.
pub fn optimiser_names() -> PossibleValuesParser {
    PossibleValuesParser::new(OptimiserKind::ALL.map(OptimiserKind::name))
}

/// The names of [`Proposal::ALL`] as a command-line value parser.
pub fn proposal_names() -> PossibleValuesParser {
    PossibleValuesParser::new(Proposal::ALL.map(Proposal::name))
}

/// The names of [`MoveCorrection::ALL`] as a command-line value parser.
pub fn correction_names() -> PossibleValuesParser {
    PossibleValuesParser::new(MoveCorrection::ALL.map(MoveCorrection::name))
}

/// The estimator's choices by name: flags of the service process and of the launcher's
/// `run`, each replacing the config file's value when given.
#[derive(Debug, Clone, Default, PartialEq, Eq, clap::Args)]
pub struct EstimatorChoice {
    /// Particle optimiser of step 2 (iba also switches to partial resampling; default:
    /// the config's, else none).
    #[arg(long, value_parser = optimiser_names())]
    pub optimizer: Option<String>,
    /// Proposal of the new poses: motion (FastSLAM 1.0) or fastslam2 (default: the
    /// config's, else motion).
    #[arg(long, value_parser = proposal_names())]
    pub proposal: Option<String>,
    /// What the optimiser's answer does: none (the papers: move the cloud, weigh at the
    /// moved poses; biased), proposal (per particle: draw from the Laplace Gaussian at
    /// the optimum, weigh by target / proposal) or resample-move (Metropolis–Hastings
    /// moves of every resampled copy); default: the config's, else none.
    #[arg(long, value_parser = correction_names())]
    pub move_correction: Option<String>,
    /// What each particle maps: landmarks (point landmarks, poles from raw scans) or grid
    /// (an occupancy grid per particle, the scan matched against it; raw scans only);
    /// default: the config's, else landmarks.
    #[arg(long, value_parser = PossibleValuesParser::new(MapKind::NAMES))]
    pub map: Option<String>,
}

/// Command-line values that replace the file's (flags win). Names are checked against the
/// choices, and an unknown one is an error listing them.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Overrides {
    /// `filter.particles`.
    pub particles: Option<usize>,
    /// `filter.seed`.
    pub seed: Option<u64>,
    /// `optimizer.kind`, `filter.proposal` and `moves.correction`, by name.
    pub choice: EstimatorChoice,
}

impl Overrides {
    /// The service process's flags that carry the given values (`--particles 30`, …), to
    /// start it with exactly these settings.
    pub fn flags(&self) -> Vec<String> {
        let numbers = [
            ("--particles", self.particles.map(|n| n.to_string())),
            ("--seed", self.seed.map(|s| s.to_string())),
        ];
        let c = &self.choice;
        let names = [
            ("--optimizer", c.optimizer.clone()),
            ("--proposal", c.proposal.clone()),
            ("--move-correction", c.move_correction.clone()),
            ("--map", c.map.clone()),
        ];
        numbers
            .into_iter()
            .chain(names)
            .filter_map(|(flag, value)| value.map(|v| [flag.to_string(), v]))
            .flatten()
            .collect()
    }

    /// Writes the given values into `config`.
    ///
    /// # Errors
    /// [`ConfigError::Invalid`] for a name that is not one of the choices.
    pub fn apply(&self, config: &mut ServiceConfig) -> Result<(), ConfigError> {
        if let Some(n) = self.particles {
            config.filter.particles = n;
        }
        if let Some(seed) = self.seed {
            config.filter.seed = seed;
        }
        let c = &self.choice;
        if let Some(name) = &c.optimizer {
            config.optimizer.kind = name.parse::<OptimiserKind>()?;
        }
        if let Some(name) = &c.map {
            config.map.kind = MapKind::parse(name)?;
        }
        if let Some(name) = &c.proposal {
            config.filter.proposal = name.parse::<Proposal>()?;
        }
        if let Some(name) = &c.move_correction {
            config.moves.correction = name.parse::<MoveCorrection>()?;
        }
        Ok(())
    }
}

impl ServiceConfig {
    /// Reads `path`, or the defaults when `None`.
    ///
    /// # Errors
    /// [`ConfigError`] when the file cannot be read or parsed.
    pub fn load(path: Option<&Path>) -> Result<Self, ConfigError> {
        let Some(path) = path else {
            return Ok(Self::default());
        };
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Read {
            path: shown.clone(),
            reason: e.to_string(),
        })?;
        Self::parse(&shown, &text)
    }

    /// Parses config text; `origin` names it in errors.
    ///
    /// # Errors
    /// [`ConfigError::Parse`] for invalid TOML, unknown keys or values of the wrong type.
    pub fn parse(origin: &str, text: &str) -> Result<Self, ConfigError> {
        toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: origin.to_string(),
            reason: e.to_string(),
        })
    }

    /// This config with the flags' values written in ([`Overrides::apply`]), validated.
    ///
    /// # Errors
    /// [`ConfigError::Invalid`] for an unknown name or a bad value.
    pub fn with_overrides(mut self, overrides: &Overrides) -> Result<Self, ConfigError> {
        overrides.apply(&mut self)?;
        self.validate()?;
        Ok(self)
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`ConfigError::Invalid`] naming the first bad value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.filter.validate()?;
        self.features.validate()?;
        self.grid.validate()?;
        self.optimizer.validate()?;
        self.moves.validate()?;
        self.input.validate()?;
        self.smoother.validate()?;
        self.map.matching.validate()?;
        self.laser.validate()?;
        self.loop_closure.validate()?;
        Ok(())
    }

    /// A short name of the estimator: the optimiser, then `+fastslam2` for FastSLAM 2.0's
    /// proposal and `+proposal` or `+resample-move` for the corrected optimiser modes
    /// (`none`, `coa+proposal`, `none+fastslam2`); `grid-` and the scan matcher for grid
    /// FastSLAM (`grid-hill`).
    pub fn method(&self) -> String {
        if self.map.kind == MapKind::Grid {
            return format!("grid-{}", self.optimizer.kind);
        }
        let mut name = self.optimizer.kind.to_string();
        if self.filter.proposal == Proposal::FastSlam2 {
            name.push_str("+fastslam2");
        }
        if self.optimizer.kind != OptimiserKind::None && self.moves.correction.is_valid() {
            name.push('+');
            name.push_str(self.moves.correction.name());
        }
        name
    }

    /// The filter's configuration as it runs: `[filter]`, with the resampling scheme
    /// switched to partial EWA when the optimiser asks for it (IBA in the papers' mode,
    /// §4.4).
    pub fn filter_config(&self) -> FastSlamConfig {
        let mut filter = self.filter.clone();
        if self.optimizer.partial_resampling(self.moves.correction) {
            filter.resampling.scheme = ResamplingScheme::PartialEwa;
        }
        filter
    }

    /// True when the landmark filter associates its observations without ids.
    pub fn unknown_association(&self) -> bool {
        self.map.kind == MapKind::Landmarks
            && self.filter.association.mode == AssociationMode::Unknown
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_round_trip() {
        let c = ServiceConfig::default();
        c.validate().unwrap();
        let back: ServiceConfig = toml::from_str(&toml::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn typos_and_unknown_names_are_reported_with_the_choices() {
        assert!(toml::from_str::<ServiceConfig>("[output]\nmap_evry = 2").is_err());
        assert!(toml::from_str::<ServiceConfig>("[input]\nlidar = \"radar\"").is_err());
        let c: ServiceConfig = toml::from_str("[grid]\nresolution = -1.0").unwrap();
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("grid.resolution")
        );
        assert!(toml::from_str::<ServiceConfig>("[optimizer]\nkind = \"magic\"").is_err());
        let mut c = ServiceConfig::default();
        for (choice, expected) in [
            (
                EstimatorChoice {
                    optimizer: Some("magic".into()),
                    ..EstimatorChoice::default()
                },
                "none, coa, icoa, ba, iba, gwo, qpso, pso",
            ),
            (
                EstimatorChoice {
                    proposal: Some("fastslam3".into()),
                    ..EstimatorChoice::default()
                },
                "motion, fastslam2",
            ),
            (
                EstimatorChoice {
                    move_correction: Some("metropolis".into()),
                    ..EstimatorChoice::default()
                },
                "none, proposal, resample-move",
            ),
        ] {
            let overrides = Overrides {
                choice,
                ..Overrides::default()
            };
            let err = overrides.apply(&mut c).unwrap_err().to_string();
            assert!(err.contains(expected), "{err}");
        }
    }

    #[test]
    fn flags_override_the_file() {
        let mut c = ServiceConfig::parse(
            "test",
            "[filter]\nparticles = 10\nproposal = \"fastslam2\"\n[optimizer]\nkind = \"coa\"\n",
        )
        .unwrap();
        let overrides = Overrides {
            particles: Some(30),
            seed: Some(4),
            choice: EstimatorChoice {
                optimizer: Some("gwo".into()),
                proposal: Some("motion".into()),
                move_correction: Some("resample-move".into()),
                map: Some("grid".into()),
            },
        };
        overrides.apply(&mut c).unwrap();
        let flags = overrides.flags().join(" ");
        assert_eq!(
            flags,
            "--particles 30 --seed 4 --optimizer gwo --proposal motion --move-correction resample-move --map grid"
        );
        assert_eq!(c.map.kind, MapKind::Grid);
        assert_eq!(c.method(), "grid-gwo");
        c.map.kind = MapKind::Landmarks;
        assert_eq!((c.filter.particles, c.filter.seed), (30, 4));
        assert_eq!(c.optimizer.kind, OptimiserKind::Gwo);
        assert_eq!(c.filter.proposal, Proposal::Motion);
        assert_eq!(c.moves.correction, MoveCorrection::ResampleMove);
        c.validate().unwrap();
        assert_eq!(c.method(), "gwo+resample-move");
        c.optimizer.kind = OptimiserKind::None;
        c.filter.proposal = Proposal::FastSlam2;
        assert_eq!(
            c.method(),
            "none+fastslam2",
            "no optimiser, nothing to correct"
        );
    }

    #[test]
    fn a_map_kind_is_named_and_an_unknown_one_refused_with_the_choices() {
        let c: ServiceConfig = toml::from_str("[map]\nkind = \"grid\"").unwrap();
        assert_eq!(c.map.kind, MapKind::Grid);
        assert!(toml::from_str::<ServiceConfig>("[map]\nkind = \"voxels\"").is_err());
        let err = MapKind::parse("voxels").unwrap_err().to_string();
        assert!(err.contains("landmarks, grid"), "{err}");
        let c: ServiceConfig = toml::from_str("[map.matching]\nwindow = 0").unwrap();
        assert!(c.validate().is_err());
    }

    #[test]
    fn iba_brings_partial_resampling_unless_switched_off() {
        let mut c = ServiceConfig::default();
        c.optimizer.kind = OptimiserKind::Iba;
        assert_eq!(
            c.filter_config().resampling.scheme,
            ResamplingScheme::PartialEwa
        );
        c.optimizer.iba.partial_resampling = false;
        assert_eq!(
            c.filter_config().resampling.scheme,
            ResamplingScheme::Systematic
        );
        c.optimizer.kind = OptimiserKind::Coa;
        c.optimizer.iba.partial_resampling = true;
        assert_eq!(
            c.filter_config().resampling.scheme,
            ResamplingScheme::Systematic
        );
        // The corrected modes keep the filter's own scheme: partial EWA is biased.
        c.optimizer.kind = OptimiserKind::Iba;
        for correction in [MoveCorrection::Proposal, MoveCorrection::ResampleMove] {
            c.moves.correction = correction;
            assert_eq!(
                c.filter_config().resampling.scheme,
                ResamplingScheme::Systematic
            );
        }
    }

    #[test]
    fn bad_values_name_their_field() {
        let c = ServiceConfig::parse("test", "[moves]\nbound_sigmas = -1.0\n").unwrap();
        let err = c.validate().unwrap_err().to_string();
        assert!(err.contains("moves.bound_sigmas"), "{err}");
    }
}
