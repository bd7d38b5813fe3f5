//! The one error type of the estimation library.

/// What can go wrong when building or running an estimator.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value is outside its valid range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The parameter's name as it appears in the config file.
        name: &'static str,
        /// Why the value was rejected.
        reason: String,
    },
    /// Every weight is zero, NaN or −∞: the filter has lost track and cannot normalise.
    #[error("degenerate weights: {reason}")]
    DegenerateWeights {
        /// What was wrong with the weights.
        reason: String,
    },
    /// A runtime input (a control, a time step, an observation, a prior landmark, a pose)
    /// is not finite or out of its domain; it was not applied to the estimator's state.
    #[error("invalid input `{what}`: {reason}")]
    InvalidInput {
        /// Which input was rejected.
        what: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// Optimiser search bounds are unusable (lengths differ, no dimensions, a limit not
    /// finite, or lower ≥ upper).
    #[error("invalid bounds: {reason}")]
    InvalidBounds {
        /// What was wrong, naming the dimension.
        reason: String,
    },
    /// A population does not fit the optimiser run or problem (dimension, member count, a
    /// non-finite coordinate, or `step` without a matching `start`).
    #[error("population mismatch: {reason}")]
    PopulationMismatch {
        /// What did not match.
        reason: String,
    },
    /// An optimiser name that is not one of the known ones.
    #[error("unknown optimiser `{name}` (expected one of: {expected})")]
    UnknownOptimiser {
        /// The name given.
        name: String,
        /// The accepted names, comma-separated.
        expected: String,
    },
}

/// Result alias of the estimation library.
pub type Result<T> = std::result::Result<T, Error>;
