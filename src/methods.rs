//! Which estimators a comparison runs — optimisers × move corrections × particle counts:
//! the flags `ungm` and `monte-carlo` share.

use crate::lists::List;
use clap::builder::TypedValueParser;
use fastslam_estimation::moves::MoveCorrection;
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_service::config::{correction_names, optimiser_names};

/// Optimisers × move corrections × particle counts, from comma-separated flags; an empty
/// list means the default.
#[derive(Debug, Clone, Default, PartialEq, clap::Args)]
pub struct Methods {
    /// Optimisers, comma-separated (default: all).
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = optimiser_names().map(|s| s.parse::<OptimiserKind>().expect("a listed name"))
    )]
    pub optimizers: Vec<OptimiserKind>,
    /// Move corrections, comma-separated: none (the papers), proposal, resample-move
    /// (default: all). Rows without an optimiser have nothing to correct and appear once.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = correction_names().map(|s| s.parse::<MoveCorrection>().expect("a listed name"))
    )]
    pub move_corrections: Vec<MoveCorrection>,
    /// Particle counts: `a,b,c` or `a..b` (default: the command's).
    #[arg(long)]
    pub particles: Option<List<usize>>,
}

impl Methods {
    /// The (optimiser, correction) pairs in the order given, `none` once.
    pub fn methods(&self) -> Vec<(OptimiserKind, MoveCorrection)> {
        let optimizers = or_all(&self.optimizers, &OptimiserKind::ALL);
        let corrections = or_all(&self.move_corrections, &MoveCorrection::ALL);
        let mut out = Vec::new();
        for kind in optimizers {
            for &correction in &corrections {
                let first = corrections[0];
                if kind != OptimiserKind::None || correction == first {
                    out.push((kind, correction));
                }
            }
        }
        out
    }

    /// The particle counts, or `default` when none were given.
    pub fn particles_or(&self, default: &[usize]) -> Vec<usize> {
        self.particles
            .as_ref()
            .map_or_else(|| default.to_vec(), |l| l.values().to_vec())
    }
}

/// `given`, or `all` when `given` is empty.
fn or_all<T: Clone>(given: &[T], all: &[T]) -> Vec<T> {
    if given.is_empty() { all } else { given }.to_vec()
}

/// A method's label: the optimiser's name, then `+proposal` or `+resample-move` for the
/// corrected modes.
pub fn label(kind: OptimiserKind, correction: MoveCorrection) -> String {
    if kind == OptimiserKind::None || !correction.is_valid() {
        kind.to_string()
    } else {
        format!("{kind}+{correction}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        methods: Methods,
    }

    #[test]
    fn lists_parse_default_to_everything_and_list_none_once() {
        let cli = Cli::parse_from(["x", "--optimizers", "none,coa", "--particles", "30,100"]);
        let methods = cli.methods.methods();
        assert_eq!(
            methods,
            [
                (OptimiserKind::None, MoveCorrection::None),
                (OptimiserKind::Coa, MoveCorrection::None),
                (OptimiserKind::Coa, MoveCorrection::Proposal),
                (OptimiserKind::Coa, MoveCorrection::ResampleMove),
            ]
        );
        assert_eq!(cli.methods.particles_or(&[5]), [30, 100]);
        let all = Cli::parse_from(["x"]).methods;
        assert_eq!(all.methods().len(), 1 + 8 * 3);
        assert_eq!(all.particles_or(&[5]), [5]);
        let err = Cli::try_parse_from(["x", "--optimizers", "magic"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("none, coa, icoa"), "{err}");
        assert_eq!(
            label(OptimiserKind::Pso, MoveCorrection::ResampleMove),
            "pso+resample-move"
        );
        assert_eq!(label(OptimiserKind::None, MoveCorrection::Proposal), "none");
    }
}
