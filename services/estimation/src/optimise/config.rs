//! The optimiser choices and their configuration: the one place an optimiser is
//! registered (its kind, its name, its constants' table and how it is built).

use super::chaos::CircleMap;
use super::{
    Ba, BaConfig, Coa, Gwo, GwoConfig, HillClimb, HillConfig, Iba, IbaConfig, Icoa, IcoaConfig,
    Optimiser, Pso, PsoConfig, Qpso, QpsoConfig,
};
use crate::check::require;
use crate::moves::MoveCorrection;
use crate::rng::SimRng;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The optimiser choices, by the names used in config files and on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OptimiserKind {
    /// No optimiser: plain FastSLAM 1.0 (§1 step 2 is skipped).
    #[default]
    None,
    /// Coati optimisation (§4.1).
    Coa,
    /// Improved coati optimisation (§4.2).
    Icoa,
    /// Butterfly optimisation (§4.3).
    Ba,
    /// Improved butterfly optimisation (§4.4).
    Iba,
    /// Grey wolf optimisation (§4.5).
    Gwo,
    /// Quantum-behaved particle swarm (§4.5).
    Qpso,
    /// Canonical particle swarm (§4.5).
    Pso,
    /// Hill climbing, GMapping's scan matcher (§4.6): the baseline.
    Hill,
}

impl OptimiserKind {
    /// Every choice, in the order of docs/ALGORITHMS.md.
    pub const ALL: [Self; 9] = [
        Self::None,
        Self::Coa,
        Self::Icoa,
        Self::Ba,
        Self::Iba,
        Self::Gwo,
        Self::Qpso,
        Self::Pso,
        Self::Hill,
    ];

    /// The lower-case name (`"icoa"`), as in config files.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Coa => "coa",
            Self::Icoa => "icoa",
            Self::Ba => "ba",
            Self::Iba => "iba",
            Self::Gwo => "gwo",
            Self::Qpso => "qpso",
            Self::Pso => "pso",
            Self::Hill => "hill",
        }
    }
}

impl fmt::Display for OptimiserKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for OptimiserKind {
    type Err = Error;

    /// Parses a lower-case name, exactly as [`fmt::Display`] writes it.
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| Error::UnknownOptimiser {
                name: s.to_owned(),
                expected: Self::ALL.map(Self::name).join(", "),
            })
    }
}

/// The optimiser section of the service's config: which optimiser, how many generations per
/// filter step, and each optimiser's constants in its own table (all present, so switching
/// `kind` from the command line needs nothing else; COA has no constants, so no table).
///
/// ```toml
/// kind = "icoa"
/// iterations = 10
/// [icoa]
/// omega_max = 0.9
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OptimiserConfig {
    /// Which optimiser runs after the prediction step; `none` = plain FastSLAM.
    pub kind: OptimiserKind,
    /// Generations per filter step, `K` of §4 (count). 10 as in the UNGM measurements of §5.
    pub iterations: usize,
    /// ICOA constants (§4.2).
    pub icoa: IcoaConfig,
    /// BA constants (§4.3).
    pub ba: BaConfig,
    /// IBA constants (§4.4).
    pub iba: IbaConfig,
    /// GWO constants (§4.5).
    pub gwo: GwoConfig,
    /// QPSO constants (§4.5).
    pub qpso: QpsoConfig,
    /// PSO constants (§4.5).
    pub pso: PsoConfig,
    /// Hill climber constants (§4.6).
    pub hill: HillConfig,
}

impl Default for OptimiserConfig {
    fn default() -> Self {
        Self {
            kind: OptimiserKind::None,
            iterations: 10,
            icoa: IcoaConfig::default(),
            ba: BaConfig::default(),
            iba: IbaConfig::default(),
            gwo: GwoConfig::default(),
            qpso: QpsoConfig::default(),
            pso: PsoConfig::default(),
            hill: HillConfig::default(),
        }
    }
}

/// The most generations per step an optimiser runs: the papers use 5–50; a count above
/// this would stall every step and is refused.
pub const MAX_ITERATIONS: usize = 10_000;

impl OptimiserConfig {
    /// Checks every section (also those of optimisers not selected, so a bad value is found
    /// when the file is loaded, not when someone switches `kind`).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] naming the first bad constant.
    pub fn validate(&self) -> Result<()> {
        require(
            (1..=MAX_ITERATIONS).contains(&self.iterations),
            "optimizer.iterations",
            || format!("must be in 1..={MAX_ITERATIONS}, not {}", self.iterations),
        )?;
        self.icoa.validate()?;
        self.ba.validate()?;
        self.iba.validate()?;
        self.gwo.validate()?;
        self.qpso.validate()?;
        self.pso.validate()
    }

    /// Whether the filter must resample with IBA's partial EWA scheme (docs/ALGORITHMS.md
    /// §4.4): IBA is selected, [`IbaConfig::partial_resampling`] is on, and the moves run
    /// in the papers' mode (`correction`). The scheme is biased — the replaced particles'
    /// mass goes to draws from the whole cloud — so the corrected modes, which promise a
    /// correct sampler, keep the filter's own scheme.
    pub fn partial_resampling(&self, correction: MoveCorrection) -> bool {
        self.kind == OptimiserKind::Iba
            && self.iba.partial_resampling
            && correction == MoveCorrection::None
    }

    /// The selected optimiser, or `None` for [`OptimiserKind::None`]. ICOA seeds its
    /// persistent chaotic sequence from `rng` (one draw); the others draw nothing here.
    ///
    /// # Errors
    ///
    /// As [`OptimiserConfig::validate`].
    pub fn build(&self, rng: &mut SimRng) -> Result<Option<Box<dyn Optimiser>>> {
        self.validate()?;
        Ok(match self.kind {
            OptimiserKind::None => None,
            OptimiserKind::Coa => Some(Box::new(Coa::new())),
            OptimiserKind::Icoa => Some(Box::new(Icoa::new(
                self.icoa.clone(),
                CircleMap::from_rng(rng),
            )?)),
            OptimiserKind::Ba => Some(Box::new(Ba::new(self.ba.clone())?)),
            OptimiserKind::Iba => Some(Box::new(Iba::new(self.iba.clone())?)),
            OptimiserKind::Gwo => Some(Box::new(Gwo::new(self.gwo.clone())?)),
            OptimiserKind::Qpso => Some(Box::new(Qpso::new(self.qpso.clone())?)),
            OptimiserKind::Pso => Some(Box::new(Pso::new(self.pso.clone())?)),
            OptimiserKind::Hill => Some(Box::new(HillClimb::new(self.hill.clone()))),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::seeded;
    #[test]
    fn names_round_trip_through_from_str_display_and_serde() {
        for kind in OptimiserKind::ALL {
            assert_eq!(kind.to_string().parse::<OptimiserKind>().unwrap(), kind);
            let json = serde_json::to_string(&kind).unwrap();
            assert_eq!(json, format!("\"{kind}\""));
            assert_eq!(serde_json::from_str::<OptimiserKind>(&json).unwrap(), kind);
        }
        assert!(matches!(
            "COA".parse::<OptimiserKind>(),
            Err(Error::UnknownOptimiser { .. })
        ));
        assert!("sa".parse::<OptimiserKind>().is_err());
    }

    #[test]
    fn generations_are_bounded() {
        for iterations in [0, MAX_ITERATIONS + 1] {
            let config = OptimiserConfig {
                iterations,
                ..OptimiserConfig::default()
            };
            assert!(config.validate().is_err(), "{iterations}");
        }
        let most = OptimiserConfig {
            iterations: MAX_ITERATIONS,
            ..OptimiserConfig::default()
        };
        assert!(most.validate().is_ok());
    }

    #[test]
    fn config_round_trips_through_toml_fills_defaults_and_rejects_unknown_fields() {
        let config = OptimiserConfig {
            kind: OptimiserKind::Icoa,
            iterations: 7,
            ..OptimiserConfig::default()
        };
        let text = toml::to_string(&config).unwrap();
        assert_eq!(toml::from_str::<OptimiserConfig>(&text).unwrap(), config);

        let partial: OptimiserConfig =
            toml::from_str("kind = \"gwo\"\n[pso]\ncognitive = 1.5\n").unwrap();
        assert_eq!(partial.kind, OptimiserKind::Gwo);
        assert_eq!(partial.pso.cognitive, 1.5);
        assert_eq!(
            partial.pso,
            PsoConfig {
                cognitive: 1.5,
                ..PsoConfig::default()
            }
        );
        assert_eq!(partial.iterations, OptimiserConfig::default().iterations);

        for bad in [
            "kind = \"sa\"",
            "omega = 1.0",
            "[icoa]\nomega_maximum = 1.0",
            "[coa]\n",
        ] {
            assert!(
                toml::from_str::<OptimiserConfig>(bad).is_err(),
                "accepted {bad:?}"
            );
        }
    }

    #[test]
    fn defaults_validate_and_out_of_range_constants_are_rejected() {
        assert!(OptimiserConfig::default().validate().is_ok());
        let mut rng = seeded(0);
        let mut config = OptimiserConfig {
            kind: OptimiserKind::Ba,
            ..OptimiserConfig::default()
        };
        config.ba.switch_probability = 1.5;
        assert!(matches!(
            config.build(&mut rng),
            Err(Error::InvalidParameter { .. })
        ));
        // A bad section is reported even when another optimiser is selected.
        let mut config = OptimiserConfig::default();
        config.icoa.omega_min = 2.0;
        assert!(config.validate().is_err());
    }

    #[test]
    fn none_builds_no_optimiser_and_the_others_report_their_kind() {
        let mut rng = seeded(0);
        for kind in OptimiserKind::ALL {
            let config = OptimiserConfig {
                kind,
                ..OptimiserConfig::default()
            };
            match config.build(&mut rng).unwrap() {
                None => assert_eq!(kind, OptimiserKind::None),
                Some(optimiser) => assert_eq!(optimiser.kind(), kind),
            }
        }
    }
}
