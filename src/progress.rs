//! The launcher's live view of a run: a progress bar of simulated time with the live ATE.
//!
//! The client already sees every pose and the truth, so it is the one that knows how far
//! the run is and how good it is so far; it prints compact progress lines on its stdout
//! (`fastslam_client::progress`). The launcher reads that stdout through a pipe, copies
//! every line into the client's log and draws the bar. This adds no subscriber to the
//! stack, so the view can never slow it down. The bar is drawn on stderr and is hidden
//! when stderr is not a terminal (tests, CI, redirected output).

use fastslam_client::progress::Progress;
use fastslam_sensors_sim::Scenario;
use fastslam_sensors_sim::vehicle::Drive;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::fs::OpenOptions;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::thread::JoinHandle;

/// Routes longer than this many control periods are not timed in advance (the bar then
/// shows no total).
const MAX_STEPS: u64 = 10_000_000;

/// The simulated duration of the scenario's route (s): the truth simulator's last stamp,
/// found by driving the route once without noise, as the simulator does. `None` when the
/// route does not end within [`MAX_STEPS`] control periods.
pub fn simulated_duration_s(scenario: &Scenario) -> Option<f64> {
    let dt = scenario.timing.control_period_s;
    let mut drive = Drive::new(scenario.vehicle.clone(), scenario.route.clone(), dt);
    let mut steps = 0_u64;
    while drive.step().is_some() {
        steps += 1;
        if steps > MAX_STEPS {
            return None;
        }
    }
    Some(steps as f64 * dt)
}

/// A bar of simulated seconds (in ms steps) out of `total_s`, or a spinner without a
/// total; hidden unless stderr is a terminal.
pub fn bar(total_s: Option<f64>) -> ProgressBar {
    let target = ProgressDrawTarget::stderr();
    match total_s {
        Some(total) => {
            let bar = ProgressBar::with_draw_target(Some((total * 1e3) as u64), target);
            let style =
                ProgressStyle::with_template("{elapsed_precise} [{bar:25.cyan/blue}] {msg}")
                    .map_or_else(
                        |_| ProgressStyle::default_bar(),
                        |s| s.progress_chars("=> "),
                    );
            bar.set_style(style);
            bar
        }
        None => {
            let bar = ProgressBar::with_draw_target(None, target);
            bar.set_style(ProgressStyle::default_spinner());
            bar
        }
    }
}

/// Reads the client's stdout until it closes: appends every line to `log` and moves the
/// bar with each progress line. Runs on its own thread; join it after the stack stopped.
///
/// # Errors
/// When the log cannot be opened for appending.
pub fn follow(
    client_stdout: impl Read + Send + 'static,
    log: &Path,
    bar: ProgressBar,
    total_s: Option<f64>,
) -> std::io::Result<JoinHandle<()>> {
    let mut log = OpenOptions::new().append(true).open(log)?;
    Ok(std::thread::spawn(move || {
        for line in BufReader::new(client_stdout).lines() {
            let Ok(line) = line else { break };
            // The log is a copy; a full disk must not stop the run.
            let _ = writeln!(log, "{line}");
            show(&bar, &line, total_s);
        }
        bar.finish_and_clear();
    }))
}

/// Moves the bar to a progress line's simulated time and shows
/// `sim 12.3/60.0 s · ATE 0.532 m` (fits an 80-column terminal); ignores other lines.
fn show(bar: &ProgressBar, line: &str, total_s: Option<f64>) {
    let Some(p) = Progress::parse(line) else {
        return;
    };
    let total = total_s.map_or_else(String::new, |t| format!("/{t:.1}"));
    bar.set_position((p.sim_s * 1e3) as u64);
    bar.set_message(format!(
        "sim {:.1}{total} s · ATE {:.3} m",
        p.sim_s, p.ate_m
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_short_scenario_lasts_about_a_minute() {
        let scenario = Scenario::load("bailey-short").unwrap();
        let t = simulated_duration_s(&scenario).unwrap();
        assert!((40.0..120.0).contains(&t), "{t} s");
    }

    #[test]
    fn progress_lines_move_the_bar_and_other_lines_do_not() {
        let bar = ProgressBar::hidden();
        bar.set_length(10_000);
        show(
            &bar,
            "progress sim_s=3.000 ate_m=0.3000 poses=15",
            Some(10.0),
        );
        show(&bar, "2026 INFO client: recording", Some(10.0));
        assert_eq!(bar.position(), 3000);
        assert_eq!(bar.message(), "sim 3.0/10.0 s · ATE 0.300 m");
        show(&bar, "progress sim_s=4.000 ate_m=NaN poses=0", None);
        assert_eq!(bar.message(), "sim 4.0 s · ATE NaN m");
    }

    #[test]
    fn follow_copies_every_line_to_the_log() {
        let dir = std::env::temp_dir().join(format!("progress-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let log = dir.join("client.log");
        std::fs::write(&log, "started\n").unwrap();
        let out = "progress sim_s=1.500 ate_m=0.2500 poses=7\nnot a progress line\n\
                   progress sim_s=3.000 ate_m=0.3000 poses=15\n";
        let bar = ProgressBar::hidden();
        follow(
            std::io::Cursor::new(out.to_string()),
            &log,
            bar.clone(),
            Some(10.0),
        )
        .unwrap()
        .join()
        .unwrap();
        let text = std::fs::read_to_string(&log).unwrap();
        assert_eq!(text, format!("started\n{out}"));
        assert!(bar.is_finished());
        std::fs::remove_dir_all(&dir).ok();
    }
}
