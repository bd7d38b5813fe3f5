//! `fastslam-stack bench`: the stack's performance figures (step time, latency, throughput,
//! memory), printed with the machine they were measured on. BENCHMARKS.md records runs of it.
//!
//! 1. Filter step time over particles N × landmarks M per optimiser (synthetic workload of
//!    `fastslam_estimation::workload`), with the growth ratios ×N and ×M.
//! 2. End-to-end latency through the real processes at the scenario's real-time rate;
//!    optionally the same with one particle, the pipeline's floor on this machine.
//! 3. As-fast-as-possible throughput of the whole multi-process stack against the
//!    in-process driver on the same scenario (the ratio is the IPC overhead), with CPU
//!    time and peak memory per process; and the same run with the live viewer (`--live`),
//!    against the run without it.
//! 4. Optionally, peak memory of the service over runs of growing length.

use crate::commands::host::HostArgs;
use crate::commands::launch::LaunchArgs;
use crate::commands::live::LiveArgs;
use crate::commands::run::{self, RunArgs};
use anyhow::{Context, bail};
use fastslam_client::Metrics;
use fastslam_client::metrics::SERVICE_NODE;
use fastslam_client::stats::Spread;
use fastslam_estimation::fastslam::Proposal;
use fastslam_estimation::moves::MoveCorrection;
use fastslam_estimation::optimise::OptimiserKind;
use fastslam_estimation::workload::{Workload, machine};
use fastslam_protocol::cli::PaceArgs;
use fastslam_sensors_sim::Scenario;
use fastslam_service::config::{Overrides, ServiceConfig};
use fastslam_stack::lists::List;
use fastslam_stack::{offline, settings};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Flags of `bench`.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// A short run: N ∈ {10, 100}, M ∈ {10, 1000}, fewer repetitions, short scenarios.
    #[arg(long)]
    pub quick: bool,
    /// Particle counts of the step-time grid: `a,b,c` or `a..b` (default
    /// 10,30,100,300,1000).
    #[arg(long)]
    pub particles: Option<List<usize>>,
    /// Map sizes (landmarks) of the step-time grid: `a,b,c` or `a..b` (default
    /// 10,100,1000,10000).
    #[arg(long)]
    pub landmarks: Option<List<usize>>,
    /// Optimisers of the step-time grid, comma-separated: none, fastslam2 (FastSLAM 2.0's
    /// proposal), coa, icoa, ba, iba, gwo, qpso, pso — each in the papers' mode, or with
    /// `+proposal` or `+resample-move` in a corrected one (`coa+proposal`).
    #[arg(long, value_delimiter = ',', default_value = "none")]
    pub optimizers: Vec<String>,
    /// Measured steps per grid cell (median reported; default 31, quick 11).
    #[arg(long)]
    pub steps: Option<usize>,
    /// Only these parts, comma-separated: step, latency, latency-floor, latency-busy-poll,
    /// latency-spin, throughput, memory, bridge (default: step, latency, throughput).
    /// `latency-floor` repeats the latency run with one particle: what the processes and
    /// the machine cost when the filter costs nothing. `latency-busy-poll` repeats it with
    /// the service and the client polling instead of sleeping (`run --busy-poll`);
    /// `latency-spin` with them polling after each wake-up until the inputs have been quiet
    /// for `--spin-us` (`run --spin-us`). `memory` runs long. `bridge` runs the latency
    /// run on one host, then split across two "hosts" on this machine joined by two
    /// bridges (`run --host`, Zenoh over loopback TCP): what the hops add.
    #[arg(long, value_delimiter = ',', default_value = "step,latency,throughput")]
    pub parts: Vec<String>,
    /// Scenario of the latency measurement (real time: its simulated length is the wall
    /// time it takes). The default sees about 20 landmarks per scan, the load the
    /// latency target is stated for.
    #[arg(long, default_value = "bailey-dense")]
    pub latency_scenario: String,
    /// Scenario of the throughput comparison.
    #[arg(long, default_value = "bailey-webmap")]
    pub throughput_scenario: String,
    /// Rounds of the throughput comparison, each an in-process run then a multi-process
    /// one; the ratios are reported per round and as their median (default 5, quick 2).
    /// On a shared machine one round's ratio can be off by a quarter either way.
    #[arg(long)]
    pub throughput_rounds: Option<usize>,
    /// Spin period of the `latency-spin` part (`run --spin-us`: µs without a sample
    /// before a poller sleeps again).
    #[arg(long, default_value_t = 1000, value_name = "US")]
    pub spin_us: u64,
    /// Particles of the latency and throughput runs.
    #[arg(long, default_value_t = 100)]
    pub stack_particles: usize,
    /// Route loops of the memory runs (the throughput scenario driven this many times).
    #[arg(long, value_delimiter = ',', default_value = "2,8,32")]
    pub memory_loops: Vec<u32>,
    /// Where the runs' folders go.
    #[arg(long, default_value = "runs/bench")]
    pub out: PathBuf,
}

/// Runs the selected parts and prints their figures.
///
/// # Errors
/// A bad flag, a failed run, or a run folder without metrics.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    println!("machine: {}", machine());
    println!("(wall times depend on the load: on a shared machine compare ratios within one run)");
    for part in &args.parts {
        match part.as_str() {
            "step" => step_times(args)?,
            "latency" => latency(args, LatencyRun::Default)?,
            "latency-floor" => latency(args, LatencyRun::Floor)?,
            "latency-busy-poll" => latency(args, LatencyRun::BusyPoll)?,
            "latency-spin" => latency(args, LatencyRun::Spin)?,
            "throughput" => throughput(args)?,
            "memory" => memory(args)?,
            "bridge" => bridge(args)?,
            other => {
                bail!(
                    "unknown part `{other}`: step, latency, latency-floor, latency-busy-poll, \
                     latency-spin, throughput, memory or bridge"
                )
            }
        }
    }
    Ok(())
}

/// The proposal, optimiser and correction of a `--optimizers` name.
fn method(name: &str) -> anyhow::Result<(Proposal, OptimiserKind, MoveCorrection)> {
    if name == "fastslam2" {
        return Ok((
            Proposal::FastSlam2,
            OptimiserKind::None,
            MoveCorrection::None,
        ));
    }
    let (kind, correction) = name.split_once('+').unwrap_or((name, "none"));
    let kind = kind
        .parse::<OptimiserKind>()
        .map_err(|e| anyhow::anyhow!("optimizer `{name}`: {e}"))?;
    let correction = correction
        .parse::<MoveCorrection>()
        .map_err(|e| anyhow::anyhow!("optimizer `{name}`: {e}"))?;
    Ok((Proposal::Motion, kind, correction))
}

/// The workload of one grid cell.
fn workload(
    n: usize,
    m: usize,
    (proposal, kind, correction): (Proposal, OptimiserKind, MoveCorrection),
) -> anyhow::Result<Workload> {
    let w = Workload::new(n, m, proposal, kind)?;
    Ok(if correction.is_valid() {
        w.with_correction(correction)?
    } else {
        w
    })
}

/// Median wall times (s) of `steps` steps of `w`, each from a clone of its filter (clone
/// and drop not timed): the whole step, and until the estimate was handed out (before
/// the map updates).
fn median_step(w: &mut Workload, steps: usize) -> anyhow::Result<(f64, f64)> {
    let (mut whole, mut pose) = (Vec::with_capacity(steps), Vec::with_capacity(steps));
    for _ in 0..steps {
        let mut filter = w.filter.clone();
        let start = Instant::now();
        let mut ready = None;
        w.step_publishing(black_box(&mut filter), |e| {
            ready = Some(start.elapsed());
            black_box(e);
        })?;
        whole.push(start.elapsed().as_secs_f64());
        pose.push(ready.map_or(f64::NAN, |t| t.as_secs_f64()));
        drop(black_box(filter));
    }
    Ok((sorted(whole).median, sorted(pose).median))
}

/// The median (the upper one of an even count), smallest and largest of some samples.
struct Sorted {
    median: f64,
    min: f64,
    max: f64,
}

/// [`Sorted`] figures of `samples` (at least one).
fn sorted(mut samples: Vec<f64>) -> Sorted {
    samples.sort_by(f64::total_cmp);
    Sorted {
        median: samples[samples.len() / 2],
        min: samples[0],
        max: samples[samples.len() - 1],
    }
}

/// Part 1: the step-time grid and its growth ratios.
fn step_times(args: &BenchArgs) -> anyhow::Result<()> {
    let or = |given: &Option<List<usize>>, full: &[usize], quick: &[usize]| match given {
        None if args.quick => quick.to_vec(),
        None => full.to_vec(),
        Some(g) => g.to_vec(),
    };
    let ns = or(&args.particles, &[10, 30, 100, 300, 1000], &[10, 100]);
    let ms = or(&args.landmarks, &[10, 100, 1000, 10_000], &[10, 1000]);
    let steps = args
        .steps
        .unwrap_or(if args.quick { 11 } else { 31 })
        .max(1);
    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "all".into());
    for name in &args.optimizers {
        let method = method(name)?;
        println!(
            "\n[step] filter step (predict + update) of `{name}`, median of {steps} (ms), \
             {threads} rayon threads; rows N, columns M"
        );
        let mut table = vec![vec![f64::NAN; ms.len()]; ns.len()];
        let mut pose_table = table.clone();
        let mut seen = vec![0; ms.len()];
        for (i, &n) in ns.iter().enumerate() {
            for (j, &m) in ms.iter().enumerate() {
                let mut w = workload(n, m, method)?;
                seen[j] = w.scan.len();
                let (whole, pose) = median_step(&mut w, steps)?;
                (table[i][j], pose_table[i][j]) = (whole * 1e3, pose * 1e3);
            }
        }
        let header: String = ms
            .iter()
            .map(|m| format!("{:>12}", format!("M={m}")))
            .collect();
        println!("  {:>8}{header}", "");
        let obs: String = seen
            .iter()
            .map(|k| format!("{:>12}", format!("({k} obs)")))
            .collect();
        println!("  {:>8}{obs}", "");
        print_rows(&ns, &table);
        println!("  growth with M (time ratio to the previous column):");
        for (n, row) in ns.iter().zip(&table) {
            let ratios: Vec<String> = row
                .windows(2)
                .zip(ms.windows(2))
                .map(|(t, m)| format!("x{:.0} M: {:.2}x", m[1] as f64 / m[0] as f64, t[1] / t[0]))
                .collect();
            println!("    N={n:<6} {}", ratios.join("   "));
        }
        println!("  growth with N (time ratio to the previous row):");
        for (j, m) in ms.iter().enumerate() {
            let ratios: Vec<String> = table
                .windows(2)
                .zip(ns.windows(2))
                .map(|(t, n)| {
                    let grow = n[1] as f64 / n[0] as f64;
                    format!("x{grow:.0} N: {:.2}x", t[1][j] / t[0][j])
                })
                .collect();
            println!("    M={m:<6} {}", ratios.join("   "));
        }
        println!(
            "  pose ready (ms, median): when the step hands out its estimate, before the map \
             updates"
        );
        print_rows(&ns, &pose_table);
    }
    Ok(())
}

/// Prints one grid row per particle count.
fn print_rows(ns: &[usize], table: &[Vec<f64>]) {
    for (n, row) in ns.iter().zip(table) {
        let cells: String = row.iter().map(|t| format!("{t:>12.3}")).collect();
        println!("  {:>8}{cells}", format!("N={n}"));
    }
}

/// How a benchmark's stack runs: `run --realtime`, `--busy-poll`, `--spin-us`, `--live`.
#[derive(Debug, Clone, Copy, Default)]
struct Pacing {
    realtime: bool,
    busy_poll: bool,
    spin_us: u64,
    live: bool,
}

/// Runs the whole stack with `particles` and returns its `metrics.json`.
fn stack_run(
    args: &BenchArgs,
    scenario: &str,
    (label, particles): (&str, usize),
    Pacing {
        realtime,
        busy_poll,
        spin_us,
        live,
    }: Pacing,
) -> anyhow::Result<(Metrics, Duration)> {
    let out = args.out.join(label);
    let run_args = RunArgs {
        scenario: scenario.to_string(),
        seed: None,
        choice: Default::default(),
        particles: Some(particles),
        config: None,
        out: Some(out.clone()),
        launch: LaunchArgs {
            runs_dir: args.out.clone(),
            pace: PaceArgs {
                realtime,
                rate: 1.0,
            },
            timeout_s: None,
            prefix: None,
            iox_root: None,
            judge: Default::default(),
            // Any free port: the bench measures the viewer's cost to the stack, with no
            // Foxglove connected.
            live: LiveArgs { live, live_port: 0 },
            split: HostArgs::default(),
        },
        pass: Default::default(),
        busy_poll,
        spin_us,
    };
    let started = Instant::now();
    let code = run::run(run_args)?;
    let wall = started.elapsed();
    if code != 0 {
        bail!("the {label} run exited with code {code}");
    }
    Ok((Metrics::read(&out.join("metrics.json"))?, wall))
}

/// Prints a spread of `metrics.json` (median, p99, p99.9, max in ms).
fn print_spread(what: &str, v: &Spread) {
    println!(
        "  {what:<22} median {:.3} ms   p99 {:.3} ms   p99.9 {:.3} ms   max {:.3} ms   ({} samples)",
        v.median, v.p99, v.p999, v.max, v.samples
    );
}

/// Prints the cost section: CPU time and peak memory per process.
fn print_processes(m: &Metrics) {
    println!(
        "  {:<18} {:>10} {:>10} {:>10} {:>14}",
        "process", "CPU s", "user s", "sys s", "peak RSS MiB"
    );
    for p in &m.cost.processes {
        println!(
            "  {:<18} {:>10.3} {:>10.2} {:>10.2} {:>14.1}",
            p.name, p.cpu_s, p.cpu_user_s, p.cpu_system_s, p.peak_rss_mib
        );
    }
    println!("  {:<18} {:>10.3}", "all", m.cost.stack_cpu_s);
}

/// The variants of the latency run.
#[derive(Debug, Clone, Copy, PartialEq)]
enum LatencyRun {
    /// The stack as `run --realtime` starts it.
    Default,
    /// One particle: what the processes and the machine cost when the filter costs
    /// nothing.
    Floor,
    /// The service and the client busy-poll (`run --busy-poll`).
    BusyPoll,
    /// The service and the client poll for a while after each wake-up (`run --spin-us`).
    Spin,
}

/// The latency two bridges add: the latency run on one host, then split across two hosts
/// on this machine (`run --host`, Zenoh over loopback TCP), where an observation crosses
/// to the service's host and its pose crosses back.
fn bridge(args: &BenchArgs) -> anyhow::Result<()> {
    let scenario = if args.quick {
        "indoor-loop"
    } else {
        &args.latency_scenario
    };
    let n = args.stack_particles;
    println!(
        "\n[bridge] {scenario}, N = {n}, real time: one host, then two hosts joined by bridges \
         (Zenoh over loopback TCP)"
    );
    let pacing = Pacing {
        realtime: true,
        ..Pacing::default()
    };
    let (one, _) = stack_run(args, scenario, ("bridge-one-host", n), pacing)?;
    let two = split_run(args, scenario, n)?;
    print_spread("one host", &one.cost.latency_ms);
    print_spread("two hosts", &two.cost.latency_ms);
    let (one, two) = (&one.cost.latency_ms, &two.cost.latency_ms);
    println!(
        "  the two hops (observation out, pose back) add: median {:+.3} ms, p99 {:+.3} ms; one hop about half",
        two.median - one.median,
        two.p99 - one.p99
    );
    Ok(())
}

/// Runs the stack split across two hosts on this machine (`run --host service` and
/// `run --host sensors`, as separate launchers) in real time; the sensor host's metrics.
fn split_run(args: &BenchArgs, scenario: &str, particles: usize) -> anyhow::Result<Metrics> {
    let exe = std::env::current_exe().context("locating the launcher's own executable")?;
    let port = std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let key = format!("fastslam/bench{}", std::process::id());
    let launcher = |host: &str, peer: &str, out: &str| {
        let mut command = std::process::Command::new(&exe);
        command
            .args(["run", "--scenario", scenario, "--realtime"])
            .args(["--particles", &particles.to_string()])
            .args(["--host", host, peer, &endpoint, "--key", &key, "--out"])
            .arg(args.out.join(out))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null());
        fastslam_stack::children::dying_with_this_process(&mut command).spawn()
    };
    let mut service = launcher("service", "--listen", "bridge-service-host")?;
    let sensors = launcher("sensors", "--connect", "bridge-sensor-host")?.wait()?;
    let service = service.wait()?;
    if !sensors.success() || !service.success() {
        bail!(
            "the split run failed (sensor host {sensors}, service host {service}); logs in {}",
            args.out.display()
        );
    }
    Metrics::read(&args.out.join("bridge-sensor-host").join("metrics.json"))
}

/// Part 2: end-to-end latency at the real-time rate.
fn latency(args: &BenchArgs, run: LatencyRun) -> anyhow::Result<()> {
    let scenario = if args.quick {
        "indoor-loop"
    } else {
        &args.latency_scenario
    };
    if run == LatencyRun::Spin && args.spin_us == 0 {
        bail!("latency-spin needs --spin-us above 0 (0 is the plain latency part)");
    }
    let (label, particles, note) = match run {
        LatencyRun::Default => ("latency", args.stack_particles, String::new()),
        LatencyRun::Floor => (
            "latency-floor",
            1,
            " (the floor: the filter costs almost nothing)".to_string(),
        ),
        LatencyRun::BusyPoll => (
            "latency-busy-poll",
            args.stack_particles,
            " (the service and the client busy-poll)".to_string(),
        ),
        LatencyRun::Spin => (
            "latency-spin",
            args.stack_particles,
            format!(
                " (after each wake-up the service and the client poll until {} us pass without a sample)",
                args.spin_us
            ),
        ),
    };
    println!("\n[{label}] {scenario}, N = {particles}, real time, through the processes{note}");
    let pacing = Pacing {
        realtime: true,
        busy_poll: run == LatencyRun::BusyPoll,
        spin_us: if run == LatencyRun::Spin {
            args.spin_us
        } else {
            0
        },
        live: false,
    };
    let (m, wall) = stack_run(args, scenario, (label, particles), pacing)?;
    println!("  wall time {:.1} s", wall.as_secs_f64());
    print_spread("observation -> pose", &m.cost.latency_ms);
    print_spread("filter step", &m.cost.step_time_ms);
    print_processes(&m);
    Ok(())
}

/// Part 3: as-fast-as-possible throughput, multi-process against in-process.
fn throughput(args: &BenchArgs) -> anyhow::Result<()> {
    let name = if args.quick {
        "bailey-short"
    } else {
        &args.throughput_scenario
    };
    let scenario = Scenario::load(name)?;
    let overrides = Overrides {
        particles: Some(args.stack_particles),
        seed: Some(scenario.seed),
        ..Overrides::default()
    };
    let config = settings::service_config(&scenario, None, &overrides)?;
    println!(
        "\n[throughput] {name}, N = {}, {}, as fast as possible",
        args.stack_particles,
        config.method()
    );
    let rounds = args
        .throughput_rounds
        .unwrap_or(if args.quick { 2 } else { 5 })
        .max(1);
    let mut results = Vec::with_capacity(rounds);
    for _ in 0..rounds {
        results.push(throughput_round(args, name, &scenario, &config)?);
    }
    // After the rounds, whose runs print their own summaries.
    println!(
        "\n[throughput] {rounds} rounds: {:>12} {:>10} {:>14} {:>12} {:>12} {:>14} {:>12} {:>12} {:>10}",
        "in-proc s",
        "CPU s",
        "multi-proc s",
        "streamed s",
        "streamed/in",
        "service CPU s",
        "svc/in CPU",
        "live strm s",
        "live/off"
    );
    for (round, r) in results.iter().enumerate() {
        println!(
            "  round {:>13} {:>12.3} {:>10.3} {:>14.3} {:>12.3} {:>11.2}x {:>14.3} {:>11.2}x {:>12.3} {:>9.2}x",
            round + 1,
            r.in_wall,
            r.in_cpu,
            r.multi_wall,
            r.streamed,
            r.streamed / r.in_wall,
            r.service_cpu,
            r.service_cpu / r.in_cpu,
            r.live_streamed,
            r.live_streamed / r.streamed
        );
    }
    let last = results.last().expect("at least one round");
    let simulated = last.simulated;
    let spread = |figure: fn(&Round) -> f64| sorted(results.iter().map(figure).collect());
    let in_wall = spread(|r| r.in_wall).median;
    let in_cpu = spread(|r| r.in_cpu).median;
    let filter = spread(|r| r.filter).median;
    let streamed = spread(|r| r.streamed).median;
    println!("  simulated {simulated:.1} s; medians over {rounds} rounds:");
    println!(
        "  in process    {in_wall:>8.3} s wall  {:>8.1} sim s / wall s   CPU {in_cpu:.3} s (filter alone {filter:.3} s wall)",
        simulated / in_wall,
    );
    println!(
        "  streamed      {streamed:>8.3} s wall  {:>8.1} sim s / wall s   (first observation to last pose at the client: no start-up, shutdown or scoring)",
        simulated / streamed
    );
    let ratio = |figure: fn(&Round) -> f64| {
        let s = spread(figure);
        format!("{:.2}x [{:.2}, {:.2}]", s.median, s.min, s.max)
    };
    println!(
        "  IPC overhead (median [min, max]): streamed {}; with start-up {}; service CPU against in-process CPU {} (targets: in-process < 1 s CPU, ratio <= 1.2x)",
        ratio(|r| r.streamed / r.in_wall),
        ratio(|r| r.multi_wall / r.in_wall),
        ratio(|r| r.service_cpu / r.in_cpu)
    );
    println!(
        "  live view (--live, the viewer subscribed, no Foxglove connected): streamed time {} of the same run without it",
        ratio(|r| r.live_streamed / r.streamed)
    );
    println!(
        "  same metrics as in process: ATE {:.3} m (in process {:.3} m)",
        last.metrics.estimate.ate_rmse_m, last.in_process_ate
    );
    println!("  last round's processes:");
    print_processes(&last.metrics);
    Ok(())
}

/// One in-process run and one multi-process run of the throughput comparison.
struct Round {
    simulated: f64,
    in_wall: f64,
    in_cpu: f64,
    /// The in-process run's filter time alone (wall).
    filter: f64,
    in_process_ate: f64,
    multi_wall: f64,
    streamed: f64,
    service_cpu: f64,
    /// The same multi-process run with the live viewer (`--live`, no Foxglove connected):
    /// its streaming time.
    live_streamed: f64,
    metrics: Metrics,
}

/// Runs `scenario` in process, then through the processes, as fast as possible.
fn throughput_round(
    args: &BenchArgs,
    name: &str,
    scenario: &Scenario,
    config: &ServiceConfig,
) -> anyhow::Result<Round> {
    let cpu_before = own_cpu_s();
    let started = Instant::now();
    let source = offline::Source::Simulation(Box::new(scenario.clone()));
    let offline = offline::run_in_process(&source, scenario.seed, config)?;
    let in_wall = started.elapsed().as_secs_f64();
    let in_cpu = own_cpu_s() - cpu_before;
    let (metrics, wall) = stack_run(
        args,
        name,
        ("throughput", args.stack_particles),
        Pacing::default(),
    )?;
    let live = Pacing {
        live: true,
        ..Pacing::default()
    };
    let (live_metrics, _) = stack_run(args, name, ("throughput-live", args.stack_particles), live)?;
    Ok(Round {
        simulated: offline.simulated.as_secs_f64(),
        in_wall,
        in_cpu,
        filter: offline.filter_time.as_secs_f64(),
        in_process_ate: offline.metrics.estimate.ate_rmse_m,
        multi_wall: wall.as_secs_f64(),
        streamed: metrics.cost.stream_wall_s,
        service_cpu: metrics.cost.service_cpu_s,
        live_streamed: live_metrics.cost.stream_wall_s,
        metrics,
    })
}

/// CPU time (s) this process has used so far (user + system, from `/proc/self/stat`).
fn own_cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name (which may hold spaces): utime is the 12th, stime 13th.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |k: usize| {
        fields
            .get(k)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    let hz = nix::unistd::sysconf(nix::unistd::SysconfVar::CLK_TCK)
        .ok()
        .flatten()
        .map_or(100.0, |t| t as f64);
    (ticks(11) + ticks(12)) / hz
}

/// Part 4: the service's peak memory over runs of growing length.
fn memory(args: &BenchArgs) -> anyhow::Result<()> {
    let name = &args.throughput_scenario;
    let source = fastslam_sensors_sim::scenario::BUILT_IN
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, t)| t.to_string())
        .map_or_else(|| std::fs::read_to_string(name), Ok)
        .with_context(|| format!("reading scenario {name}"))?;
    let mut doc: toml::Table = toml::from_str(&source)?;
    println!(
        "\n[memory] {name}, N = {}, as fast as possible: service peak RSS against run length",
        args.stack_particles
    );
    std::fs::create_dir_all(&args.out)?;
    let base = (doc.get("name").and_then(toml::Value::as_str))
        .unwrap_or("scenario")
        .to_string();
    for &loops in &args.memory_loops {
        if let Some(route) = doc.get_mut("route").and_then(toml::Value::as_table_mut) {
            route.insert("loops".into(), toml::Value::Integer(loops.into()));
        }
        // A name of its own: a scenario file may not take a built-in's.
        let renamed = toml::Value::String(format!("{base}-{loops}loops"));
        doc.insert("name".into(), renamed);
        let file = args.out.join(format!("{name}-{loops}loops.toml"));
        std::fs::write(&file, toml::to_string(&doc)?)?;
        let (m, wall) = stack_run(
            args,
            &file.display().to_string(),
            (&format!("memory-{loops}"), args.stack_particles),
            Pacing::default(),
        )?;
        let service = m
            .cost
            .processes
            .iter()
            .find(|p| p.name == SERVICE_NODE)
            .map_or(f64::NAN, |p| p.peak_rss_mib);
        println!(
            "  {loops:>3} loops: {:>7} filter steps, {:>6.1} s wall, service peak RSS {service:.1} MiB, \
             service CPU {:.2} s, {} landmarks in the map",
            m.filter.steps,
            wall.as_secs_f64(),
            m.cost.service_cpu_s,
            m.map.estimated
        );
    }
    Ok(())
}
