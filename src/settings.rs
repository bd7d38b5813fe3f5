//! The service settings of a run, resolved the same way for a run through the processes
//! (`run`) and in process (`monte-carlo`): a config file, else the scenario's `[service]`
//! table, else the defaults; then the flags on top.

use anyhow::Context;
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
