//! The launcher's subcommands, one module each: `run` (the whole stack on a scenario),
//! `replay` (a recorded data set through the stack), `compare` (many runs through the
//! processes, tabled), `monte-carlo` (many runs in process), `ungm` (the UNGM benchmark),
//! `bench` (performance figures), `test` (your own publisher through the service and the
//! client, judged by expectations), `map-get` (a running stack's map), `scenarios`,
//! `extraction-report` and `fit-noise` (a robot's noise from a recording); `launch` holds what `run` and `replay` share, `live` their live
//! view, `host` a stack split across two computers (`run --host`).

pub mod bench;
pub mod compare;
pub mod extraction_report;
pub mod fit_noise;
pub mod host;
pub mod launch;
pub mod live;
pub mod map_get;
pub mod monte_carlo;
pub mod replay;
pub mod run;
pub mod scenarios;
pub mod solve;
pub mod test;
pub mod ungm;

/// Writes `lines` (a CSV header and its rows) to `path` with a final newline, and says
/// so; nothing without a path (`--csv` not given).
///
/// # Errors
/// When the file cannot be written.
pub(crate) fn write_csv(
    path: Option<&std::path::Path>,
    mut lines: Vec<String>,
) -> anyhow::Result<()> {
    use anyhow::Context;
    if let Some(path) = path {
        lines.push(String::new());
        std::fs::write(path, lines.join("\n"))
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("rows written to {}", path.display());
    }
    Ok(())
}
