//! What `run` and `replay` share around the stack they start: where it lives (prefix and
//! iceoryx2 root), its run folder, and the report when it has ended — the summary, the
//! expectations' verdict, or what went wrong.

use crate::commands::host::HostArgs;
use crate::commands::live::LiveArgs;
use crate::supervisor::Outcome;
use anyhow::{Context, bail};
use fastslam_client::Metrics;
use fastslam_client::expect::{Expectations, JudgeArgs};
use fastslam_client::mcap::Closed;
use fastslam_client::warnings::Warnings;
use fastslam_protocol::cli::PaceArgs;
use fastslam_protocol::ipc::{self, StackConfig};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The flags `run` and `replay` share: where the stack runs and its run folder goes, how
/// fast, for how long, what is judged, the live view, and the host it runs on when split
/// across two.
#[derive(Debug, Clone, clap::Args)]
pub struct LaunchArgs {
    /// Where run folders go by default.
    #[arg(long, default_value = "runs")]
    pub runs_dir: PathBuf,
    /// Real time (at a rate) or as fast as the stack can go.
    #[command(flatten)]
    pub pace: PaceArgs,
    /// Stop everything after this many seconds, more than 0 (default: no limit); the launcher
    /// then names the processes still running and prints the last lines of their logs.
    #[arg(long, value_parser = timeout_s)]
    pub timeout_s: Option<f64>,
    /// Stack prefix, to let your own processes join (default: a fresh one per run,
    /// removed with its shared-memory files at the end).
    #[arg(long)]
    pub prefix: Option<String>,
    /// iceoryx2 root directory of the stack (default: $TMPDIR/fsl/<prefix>, removed at the
    /// end; a root you name is kept).
    #[arg(long)]
    pub iox_root: Option<PathBuf>,
    /// Expectations on the metrics and a JUnit report, passed on to the client.
    #[command(flatten)]
    pub judge: JudgeArgs,
    /// The live view in Foxglove.
    #[command(flatten)]
    pub live: LiveArgs,
    /// One host's part of a stack split across two computers.
    #[command(flatten)]
    pub split: HostArgs,
}

/// Flags a launcher passes through, as they are, to the FastSLAM service and the client
/// it starts.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct PassThrough {
    /// An extra flag for the FastSLAM service, passed through as is (repeatable), e.g.
    /// `--service-flag=--save-map=map.csv` or `--service-flag=--checkpoint=run.ckpt`.
    #[arg(long = "service-flag", value_name = "FLAG", allow_hyphen_values = true)]
    pub service: Vec<String>,
    /// An extra flag for the client, passed through as is (repeatable), e.g.
    /// `--client-flag=--align=se2` for a publisher whose estimate frame is its own.
    #[arg(long = "client-flag", value_name = "FLAG", allow_hyphen_values = true)]
    pub client: Vec<String>,
}

/// Where a launcher's stack lives: its prefix and iceoryx2 root, owned by this launcher
/// for as long as the value lives.
pub(crate) struct Place {
    /// The stack prefix.
    pub prefix: String,
    /// The iceoryx2 root.
    pub root: PathBuf,
    /// True when the launcher chose the root (so it removes it at the end).
    own_root: bool,
    /// The launcher's hold on the prefix.
    _lock: PrefixLock,
}

impl Place {
    /// The prefix and root given, else a fresh prefix and a root of its own; checked,
    /// owned (a second launcher on the prefix is refused) and cleaned of what the nodes of
    /// a stack that died there left behind. Call it before starting any process.
    ///
    /// # Errors
    /// When the prefix or root cannot name an iceoryx2 stack, another launcher's stack
    /// runs on the prefix, or the lock file cannot be made.
    pub fn claim(prefix: Option<&str>, root: Option<&Path>) -> anyhow::Result<Self> {
        let prefix = prefix.map_or_else(fastslam_stack::fresh_prefix, str::to_string);
        let own_root = root.is_none();
        let root = root.map_or_else(|| fastslam_stack::stack_root(&prefix), Path::to_path_buf);
        let stack = StackConfig {
            prefix: prefix.clone(),
            root: Some(root.display().to_string()),
        };
        stack.iceoryx_config().context("--prefix/--iox-root")?;
        let place = Self {
            _lock: PrefixLock::take(&prefix)?,
            prefix,
            root,
            own_root,
        };
        let dead = ipc::remove_dead_nodes(&stack).context("cleaning up the stack's prefix")?;
        if dead > 0 {
            tracing::info!(
                dead,
                prefix = place.prefix,
                "removed what the nodes of a dead stack left"
            );
        }
        Ok(place)
    }

    /// Prints how a process of yours joins the stack.
    pub fn announce(&self) {
        eprintln!(
            "join it with FASTSLAM_PREFIX={} FASTSLAM_IOX_ROOT={}",
            self.prefix,
            self.root.display()
        );
    }

    /// Removes the stack's shared memory, and its root when the launcher chose it.
    pub fn remove(&self) {
        ipc::remove_stack_files(&self.prefix, self.own_root.then_some(self.root.as_path()));
    }
}

/// An exclusive `flock` on the prefix's lock file ([`fastslam_stack::stack_lock`]),
/// which holds the owner's process id. The kernel releases it when the launcher dies,
/// however it dies; a launcher that ends removes the file first.
struct PrefixLock {
    /// Held open (and so locked) until dropped.
    _file: File,
    path: PathBuf,
}

impl PrefixLock {
    /// Takes the lock of `prefix` (a valid prefix: see `StackConfig`), or refuses naming
    /// the prefix and its owner.
    fn take(prefix: &str) -> anyhow::Result<Self> {
        let path = fastslam_stack::stack_lock(prefix);
        let context = || format!("locking stack prefix {prefix} ({})", path.display());
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).with_context(context)?;
        }
        loop {
            let mut file = OpenOptions::new()
                .create(true)
                .truncate(false)
                .read(true)
                .write(true)
                .open(&path)
                .with_context(context)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    let mut owner = String::new();
                    let _ = file.read_to_string(&mut owner);
                    bail!(
                        "stack prefix {prefix} is in use by another launcher (process {}); \
                         pick another --prefix or end that run",
                        owner.trim()
                    );
                }
                Err(TryLockError::Error(e)) => return Err(e).with_context(context),
            }
            // The previous owner may have removed the file between our open and our lock:
            // then the lock is on a file nobody else can find, and we try again.
            let locked = file.metadata().with_context(context)?;
            if std::fs::metadata(&path).is_ok_and(|m| m.ino() == locked.ino()) {
                file.set_len(0).with_context(context)?;
                writeln!(file, "{}", std::process::id()).with_context(context)?;
                return Ok(Self { _file: file, path });
            }
        }
    }
}

impl Drop for PrefixLock {
    fn drop(&mut self) {
        // Removed while still locked, so the next owner never locks a removed file
        // (see `take`); closing the file then releases the lock.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Makes the run folder `out` and its `logs/` folder, without the metrics of an earlier
/// run (so metrics.json is this run's or absent); returns the logs folder.
///
/// # Errors
/// When a folder cannot be made or an old metrics.json cannot be removed.
pub(crate) fn prepare(out: &Path) -> anyhow::Result<PathBuf> {
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let metrics = out.join("metrics.json");
    if metrics.is_file() {
        std::fs::remove_file(&metrics)
            .with_context(|| format!("removing {}", metrics.display()))?;
    }
    Ok(logs)
}

/// How a launcher's stack ended and where its run folder and logs are.
pub(crate) struct Ended<'a> {
    /// What the supervisor saw.
    pub outcome: Outcome,
    /// The run folder.
    pub out: &'a Path,
    /// The processes' logs.
    pub logs: &'a Path,
    /// Wall time of the run.
    pub wall: Duration,
}

/// Closes the run folder's `run.mcap` when a client that was killed left it unfinished
/// (whole records kept, see [`fastslam_client::mcap::close_unfinished`]), saying so.
fn close_recording(out: &Path) {
    let path = out.join(fastslam_client::report::files::MCAP);
    match fastslam_client::mcap::close_unfinished(&path) {
        Ok(Closed::Recovered { kept, dropped }) => eprintln!(
            "warning: {} was left unfinished by a client that died: closed, {kept} bytes of whole records kept, {dropped} dropped",
            path.display()
        ),
        Ok(Closed::Absent | Closed::Finished) => {}
        Err(e) => eprintln!("warning: {} cannot be closed: {e}", path.display()),
    }
}

/// Reports how a stack ended: the summary of its run folder when it finished (with the
/// expectations' lines when it is judged), else what went wrong and where the logs are.
/// Returns the launcher's exit code (0 finished, 1 failed or timed out, 130 interrupted).
///
/// A client that exits 1 because the run failed its expectations (it wrote metrics.json
/// that fail them) is the verdict, not a failure of the stack.
///
/// # Errors
/// When a finished run's metrics cannot be read, or the run failed its expectations.
pub(crate) fn conclude(
    ended: Ended<'_>,
    judge: &JudgeArgs,
    expectations: &Expectations,
) -> anyhow::Result<u8> {
    let Ended {
        outcome,
        out,
        logs,
        wall,
    } = ended;
    close_recording(out);
    // The client fails a run without a pose itself; with its run folder written, that is
    // the run's one error line.
    let client_done = matches!(
        outcome,
        Outcome::Finished | Outcome::Failed { name: "client", .. }
    );
    if client_done && out.join("metrics.json").is_file() {
        Metrics::read(&out.join("metrics.json"))?.require_a_pose(out)?;
    }
    let judged = judge.on()
        && out.join("metrics.json").is_file()
        && matches!(
            outcome,
            Outcome::Finished | Outcome::Failed { name: "client", .. }
        );
    if judged {
        let verdict = expectations.judge_folder(out)?;
        if outcome == Outcome::Finished || !verdict.passed() {
            print_summary(out, wall)?;
            for line in verdict.lines() {
                println!("  {line}");
            }
            return verdict.into_result().map(|()| 0);
        }
    }
    match outcome {
        Outcome::Finished => {
            print_summary(out, wall)?;
            Ok(0)
        }
        Outcome::Failed { name, status } => {
            eprintln!(
                "{name} failed ({status}); the other processes were stopped. Its log ends with:"
            );
            eprintln!("{}", tail(&logs.join(format!("{name}.log")), 15));
            Ok(1)
        }
        Outcome::Interrupted => {
            eprintln!(
                "interrupted; processes stopped, shared memory removed. Logs: {}",
                logs.display()
            );
            Ok(130)
        }
        Outcome::TimedOut { running } => {
            eprintln!(
                "timed out with {} still running; processes stopped. Logs: {}",
                running.join(", "),
                logs.display()
            );
            for name in running {
                let log = tail(&logs.join(format!("{name}.log")), 4);
                eprintln!("the {name}'s log ends with:\n{log}");
            }
            Ok(1)
        }
    }
}

/// A `--timeout-s` value: a positive number of seconds.
///
/// # Errors
/// When `text` is not a number greater than 0.
pub(crate) fn timeout_s(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s > 0.0 && s.is_finite() => Ok(s),
        _ => Err(format!("`{text}` is not a positive number of seconds")),
    }
}

/// A number in at most 8 characters: fixed point, or scientific when huge.
pub(crate) fn short(v: f64) -> String {
    if v.abs() < 1e5 {
        format!("{v:.2}")
    } else {
        format!("{v:.2e}")
    }
}

/// The last `n` lines of a log file.
fn tail(path: &Path, n: usize) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// Prints where the run folder is and its headline metrics.
pub(crate) fn print_summary(out: &Path, wall: Duration) -> anyhow::Result<()> {
    let m = Metrics::read(&out.join("metrics.json"))?;
    println!("run folder: {}", out.display());
    if m.ground_truth {
        print_truth_scores(&m);
    } else {
        println!("  no ground truth (no ATE, landmark or NEES scores)");
        if let Some(s) = &m.smoothed {
            println!(
                "  smoothed       {:8} poses (back-end, {} solves; χ²/dof {:.2})",
                s.trajectory.poses, s.solves, s.chi2_per_dof
            );
        }
    }
    if let Some(line) = relations_line(&m) {
        println!("{line}");
    }
    let h = &m.filter;
    // Grid FastSLAM has no landmark innovations: no line rather than NaN.
    if h.nis_mean.is_finite() {
        println!(
            "  noise check    {:>8}     (innovations' NIS per degree of freedom; 1 when the noise model fits)",
            short(h.nis_mean)
        );
    }
    println!("  wall time      {:8.2} s", wall.as_secs_f64());
    for line in Warnings::of(&m).lines {
        println!("  warning: {line}");
    }
    Ok(())
}

/// The summary's lines of a run with ground truth: trajectory, map and NEES errors.
fn print_truth_scores(m: &Metrics) {
    println!(
        "  ATE RMSE       {:8.3} m   (dead reckoning {:.3} m)",
        m.estimate.ate_rmse_m, m.dead_reckoning.ate_rmse_m
    );
    if let Some(r) = &m.reference {
        // A ratio to an error of (nearly) nothing, as on noise-free data, says nothing.
        let ratio = if r.ate_rmse_m > 1e-3 {
            format!(
                "the estimate is {:.1}× it; ",
                m.estimate.ate_rmse_m / r.ate_rmse_m
            )
        } else {
            String::new()
        };
        println!(
            "  achievable ATE {:8.3} m   (full-SLAM MAP over the same data; {ratio}χ²/dof {:.2})",
            r.ate_rmse_m, r.chi2_per_dof
        );
    }
    if let Some(s) = &m.smoothed {
        println!(
            "  smoothed ATE   {:8.3} m   (smoothing back-end, {} solves; final error {:.3} m; \
             landmark RMSE {:.3} m; χ²/dof {:.2})",
            s.trajectory.ate_rmse_m,
            s.solves,
            s.trajectory.final_error_m,
            s.map.rmse_m,
            s.chi2_per_dof
        );
    }
    println!("  final error    {:8.3} m", m.estimate.final_error_m);
    if m.map.truth == 0 {
        // Ground truth of the path only (GPS): nothing to score the map against.
        println!(
            "  landmarks      {:8}     (mapped; no true landmarks to score them against)",
            m.map.estimated
        );
    } else {
        println!(
            "  landmark RMSE  {:8.3} m   ({} of {} matched, {} spurious)",
            m.map.rmse_m, m.map.matched, m.map.truth, m.map.spurious
        );
    }
    let c = &m.consistency;
    println!(
        "  NEES mean      {:>8}     ({:.0} % of steps within the 95 % bound; 3 when consistent; \
         {} steps with a singular covariance)",
        short(c.nees_mean),
        100.0 * c.nees_within_95,
        c.singular
    );
}

/// The summary's line of the relation errors, when the run was scored against relations:
/// the estimate's mean translational and rotational error beside dead reckoning's and the
/// smoothed trajectory's.
fn relations_line(m: &Metrics) -> Option<String> {
    let r = m.estimate.relations?;
    let mut others: Vec<String> = Vec::new();
    if let Some(d) = m.dead_reckoning.relations {
        others.push(format!(
            "dead reckoning {:.3} m {:.2}°",
            d.trans_mean_m, d.rot_mean_deg
        ));
    }
    if let Some(s) = m.smoothed.as_ref().and_then(|s| s.trajectory.relations) {
        others.push(format!(
            "smoothed {:.3} m {:.2}°",
            s.trans_mean_m, s.rot_mean_deg
        ));
    }
    others.push(format!("{} relations", r.count));
    Some(format!(
        "  relations      {:8.3} m  {:.2}°  ({})",
        r.trans_mean_m,
        r.rot_mean_deg,
        others.join("; ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_client::Recording;
    use fastslam_client::metrics::{Alignment, ScoreAt};
    use fastslam_client::relations::RelationErrors;

    fn errors(trans_mean_m: f64, rot_mean_deg: f64, count: usize) -> RelationErrors {
        RelationErrors {
            count,
            trans_mean_m,
            trans_std_m: 0.0,
            trans_sq_mean_m2: 0.0,
            trans_sq_std_m2: 0.0,
            rot_mean_deg,
            rot_std_deg: 0.0,
            rot_sq_mean_deg2: 0.0,
            rot_sq_std_deg2: 0.0,
        }
    }

    #[test]
    fn the_relations_line_puts_the_estimate_beside_dead_reckoning() {
        let mut m = Metrics::compute(
            &Recording::default(),
            true,
            Alignment::default(),
            ScoreAt::default(),
        );
        assert_eq!(relations_line(&m), None, "no relations file");
        m.estimate.relations = Some(errors(0.052, 0.41, 2984));
        m.dead_reckoning.relations = Some(errors(7.37, 39.17, 2984));
        assert_eq!(
            relations_line(&m).unwrap(),
            "  relations         0.052 m  0.41°  (dead reckoning 7.370 m 39.17°; 2984 relations)"
        );
    }
}
