//! Replay profiles: for each data set, the sensor description the replay publishes, the
//! FastSLAM settings that suit the data (the service's config-file format, passed on by
//! the launcher) and extra flags for the client. The shipped profiles are built in and
//! found by name; any other file is found by path.

use crate::dataset::SensorSpec;
use serde::Deserialize;

/// Profiles shipped with the stack: (name, file contents).
pub const BUILT_IN: &[(&str, &str)] = &[
    ("mrclam", include_str!("../profiles/mrclam.toml")),
    (
        "victoria-park",
        include_str!("../profiles/victoria-park.toml"),
    ),
    (
        "victoria-park-scans",
        include_str!("../profiles/victoria-park-scans.toml"),
    ),
    (
        "planar-laser",
        include_str!("../profiles/planar-laser.toml"),
    ),
];

/// What can be wrong with a profile.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ProfileError {
    /// Neither a built-in name nor a readable file.
    #[error("profile `{name}` is neither a built-in ({built_in}) nor a readable file: {reason}")]
    NotFound {
        /// What was asked for.
        name: String,
        /// The built-in names.
        built_in: String,
        /// Why the file could not be read.
        reason: String,
    },
    /// The TOML does not parse, has unknown keys, or a value out of range.
    #[error("profile `{name}`: {reason}")]
    Invalid {
        /// The profile's name or path.
        name: String,
        /// The parser's or validator's message.
        reason: String,
    },
}

/// How one data set is replayed and filtered.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// Short name, used for run folders.
    pub name: String,
    /// The landmark sensor as described in every observations message.
    pub sensor: SensorSpec,
    /// Extra flags for the metrics client.
    #[serde(default)]
    pub client: ClientSettings,
    /// The FastSLAM service's settings for this data set (its config-file format).
    #[serde(default)]
    pub service: Option<toml::Table>,
}

/// Extra flags for the metrics client.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClientSettings {
    /// Passed verbatim after the client's own flags (for example an alignment option for
    /// data whose truth lives in a frame of its own).
    #[serde(default)]
    pub flags: Vec<String>,
}

impl Profile {
    /// Loads a built-in profile by name, or a profile file by path.
    ///
    /// # Errors
    /// [`ProfileError`] when it cannot be found, parsed or validated.
    pub fn load(name_or_path: &str) -> Result<Self, ProfileError> {
        let text =
            fastslam_protocol::cli::built_in_or_file(name_or_path, BUILT_IN).map_err(|e| {
                ProfileError::NotFound {
                    name: name_or_path.to_string(),
                    built_in: e.built_in,
                    reason: e.reason,
                }
            })?;
        let invalid = |reason: String| ProfileError::Invalid {
            name: name_or_path.to_string(),
            reason,
        };
        let profile: Self = toml::from_str(&text).map_err(|e| invalid(e.to_string()))?;
        profile
            .sensor
            .validate()
            .map_err(|e| invalid(e.to_string()))?;
        Ok(profile)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_profiles_load_and_carry_service_settings() {
        for (name, _) in BUILT_IN {
            let p = Profile::load(name).unwrap();
            assert_eq!(&p.name, name);
            assert!(p.service.is_some(), "{name} has filter settings");
        }
    }

    #[test]
    fn unknown_names_typos_and_bad_values_are_reported() {
        let err = Profile::load("no-such-profile").unwrap_err().to_string();
        assert!(
            err.contains("mrclam") && err.contains("victoria-park"),
            "{err}"
        );
        let dir = std::env::temp_dir().join(format!("profile-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = BUILT_IN[0].1;
        for (file, text, expected) in [
            (
                "typo.toml",
                good.replace("[sensor]", "[sensor]\nmax_rnage_m = 1.0"),
                "max_rnage_m",
            ),
            (
                "bad.toml",
                good.replace("max_range_m = ", "max_range_m = -"),
                "max_range_m",
            ),
        ] {
            let path = dir.join(file);
            std::fs::write(&path, text).unwrap();
            let err = Profile::load(path.to_str().unwrap())
                .unwrap_err()
                .to_string();
            assert!(err.contains(expected), "{err}");
        }
        std::fs::remove_dir_all(dir).unwrap();
    }
}
