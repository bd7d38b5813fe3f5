//! A sweep in slices: `--shard I/N` runs every N-th configuration of the full list
//! (run k belongs to slice k mod N + 1) and leaves `sweep.json` in its folder — the sweep's
//! definition, its fingerprint, the slice, and each run's wall time and failure. `--merge`
//! reads the slices' records back, refuses folders that are not exactly the N slices of one
//! sweep, and hands the runs, in the order of the full list, to the tables.
//!
//! The fingerprint covers what decides the results: the launcher's version, the scenario's
//! text (not the name or path it was given by) and the other flags of [`Sweep`].

use super::{Config, RunResult, Sweep, read_metrics};
use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// The record file every `compare` folder holds.
const RECORD: &str = "sweep.json";

/// One of N slices of a sweep, counted from 1; `1/1` is the whole sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which slice, 1 ≤ index ≤ count.
    pub index: usize,
    /// How many slices the sweep is cut into.
    pub count: usize,
}

impl Default for Shard {
    fn default() -> Self {
        Self { index: 1, count: 1 }
    }
}

impl Shard {
    /// Whether it is a slice: 1 ≤ index ≤ count.
    fn is_valid(self) -> bool {
        (1..=self.count).contains(&self.index)
    }

    /// Whether run `k` (0-based, in the full list) belongs to this slice.
    pub fn holds(self, k: usize) -> bool {
        k % self.count == self.index - 1
    }

    /// Whether this is the whole sweep.
    pub fn is_whole(self) -> bool {
        self.count == 1
    }

    /// What a slice adds to the default folder name: nothing for the whole sweep.
    pub fn suffix(self) -> String {
        if self.is_whole() {
            String::new()
        } else {
            format!("_shard{}of{}", self.index, self.count)
        }
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let wrong = || format!("`{text}` is not I/N with 1 ≤ I ≤ N (e.g. 2/4)");
        let (i, n) = text.split_once('/').ok_or_else(wrong)?;
        let (index, count) = (
            i.trim().parse().map_err(|_| wrong())?,
            n.trim().parse().map_err(|_| wrong())?,
        );
        let shard = Self { index, count };
        if shard.is_valid() {
            Ok(shard)
        } else {
            Err(wrong())
        }
    }
}

/// What a `compare` folder records about its runs.
#[derive(Debug, Serialize, Deserialize)]
struct Record {
    /// A digest of the sweep's definition; slices of one sweep share it.
    fingerprint: String,
    /// The scenario's own name (the default output folder's).
    scenario_name: String,
    /// The slice this folder holds.
    shard: Shard,
    /// The sweep's definition.
    sweep: Sweep,
    /// The slice's runs, in the order of the full list.
    runs: Vec<RunRecord>,
}

/// One run of a slice.
#[derive(Debug, Serialize, Deserialize)]
struct RunRecord {
    /// Its place in the full list.
    index: usize,
    /// Its folder under `runs/`.
    folder: String,
    /// Its wall time (s).
    wall_s: f64,
    /// Why it failed; none when it finished (its numbers are its `metrics.json`).
    error: Option<String>,
}

/// The digest of a sweep's definition: FNV-1a (64 bit) of the launcher's version, the
/// scenario's text and the other flags as JSON, in hexadecimal.
///
/// # Errors
/// When the scenario can be neither found nor read.
pub fn fingerprint(sweep: &Sweep) -> anyhow::Result<String> {
    let scenario = fastslam_protocol::cli::built_in_or_file(
        &sweep.scenario,
        fastslam_sensors_sim::scenario::BUILT_IN,
    )
    .map_err(|e| anyhow::anyhow!("scenario `{}`: {}", sweep.scenario, e.reason))?;
    let flags = Sweep {
        scenario: String::new(),
        ..sweep.clone()
    };
    let text = format!(
        "{}\n{scenario}\n{}",
        env!("CARGO_PKG_VERSION"),
        serde_json::to_string(&flags)?
    );
    let hash = text.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    });
    Ok(format!("{hash:016x}"))
}

/// Writes `sweep.json` into `out`: the slice `shard` of `sweep` and its `results`.
///
/// # Errors
/// When the file cannot be written.
pub fn write_record(
    out: &Path,
    scenario_name: &str,
    sweep: &Sweep,
    shard: Shard,
    fingerprint: &str,
    results: &[RunResult],
) -> anyhow::Result<()> {
    let record = Record {
        fingerprint: fingerprint.to_string(),
        scenario_name: scenario_name.to_string(),
        shard,
        sweep: sweep.clone(),
        runs: results
            .iter()
            .map(|r| RunRecord {
                index: r.index,
                folder: r.config.folder(),
                wall_s: r.wall_s,
                error: r.metrics.as_ref().err().cloned(),
            })
            .collect(),
    };
    let path = out.join(RECORD);
    std::fs::write(&path, serde_json::to_string_pretty(&record)? + "\n")
        .with_context(|| format!("writing {}", path.display()))
}

/// The runs of a sweep joined from its slices.
pub struct Merged {
    /// The sweep's definition.
    pub sweep: Sweep,
    /// The scenario's own name.
    pub scenario_name: String,
    /// Every run, in the order of the full list; a run's folder is where its slice holds it.
    pub results: Vec<RunResult>,
}

/// Reads the slices in `dirs` and joins their runs.
///
/// # Errors
/// A folder without a readable record, slices of different sweeps or cut differently, a
/// slice missing or given twice, a slice without all its runs (interrupted), or a finished
/// run without its `metrics.json`.
pub fn merge(dirs: &[PathBuf]) -> anyhow::Result<Merged> {
    let mut slices = Vec::new();
    for dir in dirs {
        let path = dir.join(RECORD);
        let text = std::fs::read_to_string(&path).with_context(|| {
            format!(
                "{} is not a compare folder: cannot read {RECORD}",
                dir.display()
            )
        })?;
        let record: Record =
            serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))?;
        if !record.shard.is_valid() {
            bail!(
                "{} names slice {}, which no sweep has",
                path.display(),
                record.shard
            );
        }
        slices.push((dir, record));
    }
    let (first_dir, first) = &slices[0];
    for (dir, r) in &slices[1..] {
        if r.fingerprint != first.fingerprint {
            bail!(
                "{} and {} hold slices of different sweeps (fingerprints {} and {})",
                first_dir.display(),
                dir.display(),
                first.fingerprint,
                r.fingerprint
            );
        }
        if r.shard.count != first.shard.count {
            bail!(
                "{} and {} hold slices of one sweep cut into {} and into {} slices",
                first_dir.display(),
                dir.display(),
                first.shard.count,
                r.shard.count
            );
        }
    }
    let count = first.shard.count;
    let mut by_slice: Vec<Option<&(&PathBuf, Record)>> = vec![None; count];
    for slice in &slices {
        let place = &mut by_slice[slice.1.shard.index - 1];
        if let Some(other) = place {
            bail!(
                "slice {} is given twice: {} and {}",
                slice.1.shard,
                other.0.display(),
                slice.0.display()
            );
        }
        *place = Some(slice);
    }
    let missing: Vec<String> = (1..=count)
        .filter(|i| by_slice[i - 1].is_none())
        .map(|index| Shard { index, count }.to_string())
        .collect();
    if !missing.is_empty() {
        bail!("missing slice(s) {} of the sweep", missing.join(", "));
    }
    // Every slice is there: slice i at i − 1.
    let by_slice: Vec<&(&PathBuf, Record)> = by_slice.into_iter().flatten().collect();

    let configs = first.sweep.configs();
    let mut results = Vec::with_capacity(configs.len());
    for (index, config) in configs.into_iter().enumerate() {
        let (dir, record) = by_slice[index % count];
        results.push(result(dir, record, index, config)?);
    }
    Ok(Merged {
        sweep: first.sweep.clone(),
        scenario_name: first.scenario_name.clone(),
        results,
    })
}

/// Run `index` of the full list, `config`, as the slice in `dir` recorded it.
///
/// # Errors
/// When the slice lacks it or its `metrics.json`.
fn result(dir: &Path, record: &Record, index: usize, config: Config) -> anyhow::Result<RunResult> {
    let name = config.folder();
    let Some(run) = record
        .runs
        .iter()
        .find(|r| r.index == index && r.folder == name)
    else {
        bail!(
            "slice {} in {} lacks run {name} (was it interrupted?)",
            record.shard,
            dir.display()
        );
    };
    let folder = dir.join("runs").join(&name);
    let metrics = match &run.error {
        Some(e) => Err(e.clone()),
        None => Ok(read_metrics(&folder)
            .map_err(|e| anyhow::anyhow!("slice {} in {}: {e}", record.shard, dir.display()))?),
    };
    Ok(RunResult {
        index,
        config,
        folder,
        wall_s: run.wall_s,
        metrics,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slices_are_i_of_n_and_split_the_runs_round_robin() {
        let s: Shard = "2/3".parse().unwrap();
        assert_eq!(s, Shard { index: 2, count: 3 });
        assert_eq!(s.to_string(), "2/3");
        let held: Vec<usize> = (0..7).filter(|&k| s.holds(k)).collect();
        assert_eq!(held, [1, 4]);
        for bad in ["0/2", "3/2", "2", "a/b", "1/0", "/"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        assert!(Shard::default().is_whole());
        assert_eq!(Shard::default().suffix(), "");
        assert_eq!(s.suffix(), "_shard2of3");
    }
}
