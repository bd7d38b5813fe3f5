//! The numbers of `metrics.json` read back: a value that is not a number (NaN: nothing to
//! measure) is written as `null`.

use serde::Deserialize;

/// Reads a number of `metrics.json`, where a value that is not a number (NaN: nothing to
/// measure) is written as `null`, back into an `f64`.
///
/// # Errors
/// The deserializer's error for anything but a number or `null`.
pub fn number<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}
