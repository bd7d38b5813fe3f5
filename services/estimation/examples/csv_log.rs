//! Runs the FastSLAM filter on a log of controls and landmark observations in CSV, as
//! Tim Bailey's simulator produces them, and prints the ATE of its published estimates at
//! the scans — the paired comparison of docs/RESULTS.md, where the same inputs went
//! through Bailey & Nieto's own FastSLAM 2.0.
//!
//! ```sh
//! cargo run --release -p fastslam-estimation --example csv_log -- \
//!     [--proposal motion|fastslam2] [--particles N] [--seed S] DIR [DIR …]
//! ```
//!
//! Each `DIR` holds (headers as shown; `k` counts controls from 1, `dt` = 25 ms):
//! - `controls.csv`: `k,t,v,g` — speed (m/s) and steering (rad) applied over control `k`;
//! - `scans.csv`: `k,t,count,…` — the controls after which a scan was taken;
//! - `observations.csv`: `k,t,landmark,range,bearing` — range (m) and bearing (rad) of a
//!   landmark seen at control `k`, with its identity;
//! - `truth.csv`: `k,t,x,y,phi` — the true pose after control `k`.
//!
//! The filter runs with Bailey's configuration (bicycle, wheelbase 4 m, σ_v 0.3 m/s,
//! σ_γ 3°, σ_r 0.1 m, σ_b 1°, 30 m over the front half-plane, known association,
//! resampling below N_eff = 0.75 N). Per folder it prints the ATE RMSE over the scans and
//! the final position error; the seed of folder `i` is `--seed + i`.

use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::{FastSlam, FastSlamConfig, Proposal};
use fastslam_estimation::motion::Control;
use fastslam_estimation::observation::Observation;
use fastslam_estimation::stats::Summary;
use std::collections::BTreeMap;
use std::path::Path;

/// Bailey's `configfile.m` in the filter's configuration format.
const BAILEY: &str = r#"
particles = 100
[motion]
model = "bicycle"
wheelbase = 4.0
sigma_v = 0.3
sigma_steering = 0.05235987755982988
[sensor]
sigma_range = 0.1
sigma_bearing = 0.017453292519943295
max_range = 30.0
field_of_view = 3.141592653589793
[association]
mode = "known"
[resampling]
neff_ratio = 0.75
"#;

/// Control period of Bailey's simulator (s).
const DT: f64 = 0.025;

/// The rows of `name` in `dir` (header skipped), each split at commas into numbers.
fn rows(dir: &Path, name: &str) -> Result<Vec<Vec<f64>>, String> {
    let path = dir.join(name);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    text.lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(n, line)| {
            line.split(',')
                .map(|f| f.trim().parse::<f64>())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| format!("{}:{}: {e}", path.display(), n + 1))
        })
        .collect()
}

/// ATE RMSE over the scans and final position error of one log.
fn run(dir: &Path, config: FastSlamConfig) -> Result<(f64, f64), String> {
    let controls = rows(dir, "controls.csv")?;
    let scans: Vec<u64> = rows(dir, "scans.csv")?
        .iter()
        .map(|r| r[0] as u64)
        .collect();
    let mut seen: BTreeMap<u64, Vec<Observation>> = BTreeMap::new();
    for r in rows(dir, "observations.csv")? {
        seen.entry(r[0] as u64).or_default().push(Observation {
            range: r[3],
            bearing: r[4],
            id: Some(r[2] as u64),
        });
    }
    let truth: BTreeMap<u64, (f64, f64)> = rows(dir, "truth.csv")?
        .iter()
        .map(|r| (r[0] as u64, (r[2], r[3])))
        .collect();
    let mut slam = FastSlam::new(config, Pose2::default()).map_err(|e| e.to_string())?;
    let sensor = slam.config().sensor.clone();
    let mut scans = scans.iter().peekable();
    let mut errors = Vec::new();
    for c in &controls {
        let k = c[0] as u64;
        let control = Control {
            v: c[2],
            omega: 0.0,
            steering: c[3],
            ..Control::ZERO
        };
        slam.predict(&control, DT).map_err(|e| e.to_string())?;
        if scans.next_if(|&&s| s == k).is_none() {
            continue;
        }
        let observations = seen.remove(&k).unwrap_or_default();
        let mut published = None;
        slam.update_publishing(&observations, &sensor, None, |e| published = Some(e.mean))
            .map_err(|e| e.to_string())?;
        if let (Some(estimate), Some(&(x, y))) = (published, truth.get(&k)) {
            errors.push((estimate.x - x).hypot(estimate.y - y));
        }
    }
    let rmse = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    Ok((rmse, errors.last().copied().unwrap_or(f64::NAN)))
}

fn main() -> Result<(), String> {
    let mut config: FastSlamConfig = toml::from_str(BAILEY).map_err(|e| e.to_string())?;
    let (mut dirs, mut seed) = (Vec::new(), 1);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || args.next().ok_or(format!("{arg} needs a value"));
        match arg.as_str() {
            "--proposal" => config.proposal = value()?.parse().map_err(|e| format!("{e}"))?,
            "--particles" => config.particles = value()?.parse().map_err(|e| format!("{e}"))?,
            "--seed" => seed = value()?.parse().map_err(|e| format!("{e}"))?,
            _ => dirs.push(arg),
        }
    }
    if dirs.is_empty() {
        return Err(
            "usage: csv_log [--proposal motion|fastslam2] [--particles N] [--seed S] DIR…".into(),
        );
    }
    let method = match config.proposal {
        Proposal::Motion => "FastSLAM 1.0",
        Proposal::FastSlam2 => "FastSLAM 2.0",
    };
    println!(
        "{method}, N = {}: ATE RMSE over the scans, final error",
        config.particles
    );
    let mut ates = Vec::new();
    for (i, dir) in dirs.iter().enumerate() {
        config.seed = seed + i as u64;
        let (ate, last) = run(Path::new(dir), config.clone())?;
        println!("  {dir}: ATE {ate:.3} m, final {last:.3} m");
        ates.push(ate);
    }
    let s = Summary::of(&ates);
    println!(
        "  mean {:.3} ± {:.3} m over {} logs (95 % CI of the mean {:.3}–{:.3})",
        s.mean, s.std, s.n, s.ci95.0, s.ci95.1
    );
    Ok(())
}
