//! The service settings of a run, resolved the same way for a run through the processes
//! (`run`, `replay`) and in process (`monte-carlo`): a config file, else the scenario's or
//! the replay profile's `[service]` table, else the defaults; then the flags on top.

use anyhow::{Context, bail};
use fastslam_replay::dataset::Association;
use fastslam_replay::profile::Profile;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::{Overrides, ServiceConfig};
use std::path::Path;

/// The service configuration for `scenario`: `file` if given, else the scenario's
/// `[service]` table, else the defaults, with `overrides` applied and validated.
///
/// # Errors
/// When the file or table does not parse, a name is not one of the choices, or a value is
/// out of range.
pub fn service_config(
    scenario: &Scenario,
    file: Option<&Path>,
    overrides: &Overrides,
) -> anyhow::Result<ServiceConfig> {
    let base = match (file, &scenario.service) {
        (Some(path), _) => ServiceConfig::load(Some(path))?,
        (None, Some(table)) => ServiceConfig::parse(
            &format!("scenario {} [service]", scenario.name),
            &toml::to_string(table)?,
        )?,
        (None, None) => ServiceConfig::default(),
    };
    base.with_overrides(overrides).context("service settings")
}

/// The service's config: `config` (a file) or the profile's `[service]` table, with
/// `filter.association.mode` set to what the replay publishes.
///
/// # Errors
/// A file that cannot be read or parsed, or a `filter` or `association` that is no table.
pub fn replay_service_table(
    config: Option<&Path>,
    profile: &Profile,
    association: Association,
) -> anyhow::Result<toml::Table> {
    let mut table = match config {
        Some(c) => read_table(c)?,
        None => profile.service.clone().unwrap_or_default(),
    };
    set_association_mode(&mut table, association)?;
    Ok(table)
}

/// The service config file `path` as a TOML table.
///
/// # Errors
/// A file that cannot be read or is not TOML.
pub fn read_table(path: &Path) -> anyhow::Result<toml::Table> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("service config {}", path.display()))?;
    toml::from_str::<toml::Table>(&text)
        .with_context(|| format!("service config {}", path.display()))
}

/// Sets `filter.association.mode` of the service table `table` to what a replay with
/// `association` publishes.
///
/// # Errors
/// A `filter` or `association` that is no table.
pub fn set_association_mode(
    table: &mut toml::Table,
    association: Association,
) -> anyhow::Result<()> {
    let mut section = table;
    for key in ["filter", "association"] {
        let entry = section
            .entry(key)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let Some(inner) = entry.as_table_mut() else {
            bail!("service config: `{key}` must be a table");
        };
        section = inner;
    }
    section.insert("mode".into(), association.service_mode().into());
    Ok(())
}
