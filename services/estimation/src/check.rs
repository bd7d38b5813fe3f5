//! Small validation helpers: each turns one failed check of a configuration value into
//! [`Error::InvalidParameter`] naming the parameter as it appears in the config file.

use crate::{Error, Result};

/// `Ok` when `ok`, otherwise an [`Error::InvalidParameter`] for `name` with `reason`.
pub(crate) fn require(ok: bool, name: &'static str, reason: impl FnOnce() -> String) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            reason: reason(),
        })
    }
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<()> {
    require(value.is_finite() && value > 0.0, name, || {
        format!("must be finite and > 0, got {value}")
    })
}

/// Checks that `value` is finite and not negative.
pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<()> {
    require(value.is_finite() && value >= 0.0, name, || {
        format!("must be finite and >= 0, got {value}")
    })
}

/// Checks that `value` lies in the closed interval `[lo, hi]` (NaN fails).
pub(crate) fn in_range(name: &'static str, value: f64, lo: f64, hi: f64) -> Result<()> {
    require((lo..=hi).contains(&value), name, || {
        format!("must lie in [{lo}, {hi}], got {value}")
    })
}

/// Gives a configuration enum its names: `ALL` (every variant, in order), `name()`,
/// [`std::fmt::Display`] and a [`std::str::FromStr`] whose error, an
/// [`Error::InvalidParameter`] for `$param`, lists the choices.
///
/// `named_choices!(Proposal, "proposal", { Motion => "motion", FastSlam2 => "fastslam2" });`
macro_rules! named_choices {
    ($ty:ident, $param:literal, { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Every choice, as named in config files and on the command line.
            pub const ALL: [Self; [$($name),+].len()] = [$(Self::$variant),+];

            /// The name in config files and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $name),+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = $crate::Error;

            /// Parses a name, exactly as `Display` writes it.
            fn from_str(s: &str) -> $crate::Result<Self> {
                Self::ALL
                    .into_iter()
                    .find(|c| c.name() == s)
                    .ok_or_else(|| $crate::Error::InvalidParameter {
                        name: $param,
                        reason: format!(
                            "unknown `{s}` (expected one of: {})",
                            Self::ALL.map(Self::name).join(", ")
                        ),
                    })
            }
        }
    };
}
pub(crate) use named_choices;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_reject_nan_and_out_of_range_values() {
        assert!(positive("a", 1.0).is_ok());
        assert!(positive("a", 0.0).is_err());
        assert!(positive("a", f64::NAN).is_err());
        assert!(positive("a", f64::INFINITY).is_err());
        assert!(non_negative("a", 0.0).is_ok());
        assert!(non_negative("a", -1e-9).is_err());
        assert!(in_range("a", 0.5, 0.0, 1.0).is_ok());
        assert!(in_range("a", f64::NAN, 0.0, 1.0).is_err());
        let err = in_range("ratio", 2.0, 0.0, 1.0).unwrap_err();
        assert!(matches!(err, Error::InvalidParameter { name: "ratio", .. }));
    }
}
