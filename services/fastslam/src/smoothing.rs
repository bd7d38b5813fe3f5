//! The smoothing back-end on a thread of its own (docs/ALGORITHMS.md §8.1). The filter's
//! thread collects every control and every scan's keyed sightings and hands them over
//! in one message per wake-up ([`Backend::flush`], after the pose has gone out, so that
//! waking the back-end never competes with the pose), and waits for it only to take
//! something over ([`Backend::due`]); the back-end grows its graph ([`Smoother`]), solves when a loop
//! closes, and reports after every scan — with the solution when that scan closed a
//! loop — through another channel, which the service drains between inputs.
//!
//! Re-anchoring needs a solution at a point the data fixes, and so does running the
//! filter on the back-end's noise fit: what scan `t` brought (a solution, variance
//! components) is handed to the filter after scan `t + delay` ([`Backend::due`]); only
//! if the back-end has not reported scan `t` by then does the filter wait for it.
//!
//! Every input it was given is also kept (the feed), so that a checkpoint can carry it
//! and a resumed service rebuilds the same graph by feeding it again.
//!
//! After every whole solve the back-end also fits the variance components of its graph
//! (`Graph::variance_components`, docs/ALGORITHMS.md §8.4) — torn or not, since a noise
//! model that tears the solution is what they are for — and reports them beside the
//! solve; [`Backend::noise`] holds the newest.
//!
//! A torn solution (its fit beyond [`SmootherConfig::torn_gate`], docs/ALGORITHMS.md
//! §8.3) is withheld: not published and not used for re-anchoring, so the previous good
//! solution (or the filter) stands; it is logged and counted ([`TornSolves`]).

use fastslam_estimation::graph::{
    Feed, NoiseModel, Smoother, SmootherConfig, Solution, TornGate, VarianceComponents,
};
use fastslam_estimation::stats::percentile;
use std::collections::VecDeque;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Instant;

/// What the back-end reports after each scan it was fed (numbered from 1).
#[derive(Debug)]
struct Report {
    scan: u64,
    solve: Solve,
    /// The variance components after a whole solve.
    noise: Option<VarianceComponents>,
}

/// What became of the solve a scan asked for.
#[derive(Debug)]
enum Solve {
    /// No solve: none was due, or it failed (logged).
    None,
    /// A solution that passed the gate.
    Good(Solution),
    /// A solution withheld as torn (logged).
    Torn,
}

/// What one scan's report hands the filter, `delay` scans later.
#[derive(Debug)]
pub struct Handover {
    /// A solution to re-anchor on (a good one, with re-anchoring).
    pub solution: Option<Solution>,
    /// The variance components of a whole solve (when the filter runs on them).
    pub noise: Option<VarianceComponents>,
}

/// What the filter takes over from the back-end.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Takes {
    /// Its good solutions (re-anchoring).
    pub solutions: bool,
    /// Its variance components (`[filter.noise] adapt = "smoother"`).
    pub noise: bool,
}

/// The solves withheld as torn.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TornSolves {
    /// Solves withheld so far.
    pub count: u32,
    /// Whether the newest solve was withheld (the published solution is an older one,
    /// or there is none).
    pub newest: bool,
}

/// The back-end thread, the two channels to it and what it reported.
#[derive(Debug)]
pub struct Backend {
    to_worker: Option<Sender<Vec<Feed>>>,
    from_worker: Receiver<Report>,
    worker: Option<JoinHandle<()>>,
    /// Everything fed so far, in order (for checkpoints); the part from `handed_over` on
    /// waits for the next [`flush`](Self::flush).
    feed: Vec<Feed>,
    handed_over: usize,
    /// Scans fed, and scans the back-end has reported.
    scans_fed: u64,
    scans_reported: u64,
    /// The newest solution not yet taken for publishing.
    unpublished: Option<Solution>,
    /// What the filter takes over (see [`Handover`]), with the scan that brought it;
    /// `None` when it takes nothing.
    pending: Option<VecDeque<(u64, Handover)>>,
    /// Whether the filter takes over solutions (re-anchoring) and variance components.
    takes: Takes,
    /// The solves withheld as torn.
    torn: TornSolves,
    /// The variance components of the newest whole solve.
    noise: Option<VarianceComponents>,
}

impl Backend {
    /// Starts the back-end with `config` and `noise`, first fed with `feed` (a resumed
    /// run's inputs so far); the filter `takes` what it says from it ([`due`](Self::due)).
    ///
    /// # Errors
    /// When the configuration is invalid or the thread cannot be started.
    pub fn start(
        config: SmootherConfig,
        noise: NoiseModel,
        takes: Takes,
        feed: Vec<Feed>,
    ) -> anyhow::Result<Self> {
        let graph_out = config.graph_out.clone();
        let gate = config.torn_gate();
        let mut smoother = Smoother::new(config, noise)?;
        let (to_worker, inbox) = channel::<Vec<Feed>>();
        let (outbox, from_worker) = channel::<Report>();
        let worker = std::thread::Builder::new()
            .name("smoother".into())
            .spawn(move || {
                let (mut scan, mut busy, mut spent) = (0, ScanTimes::default(), 0.0);
                for feed in inbox.iter().flatten() {
                    let started = Instant::now();
                    let due = smoother.feed(&feed);
                    if matches!(feed, Feed::Scan { .. }) {
                        scan += 1;
                        let (solve, noise) = if due {
                            let outcome = smoother.solve();
                            let noise = components(&outcome, &smoother);
                            (judge(outcome, &busy, &gate), noise)
                        } else {
                            (Solve::None, None)
                        };
                        busy.add(spent + started.elapsed().as_secs_f64());
                        spent = 0.0;
                        if outbox.send(Report { scan, solve, noise }).is_err() {
                            return;
                        }
                    } else {
                        spent += started.elapsed().as_secs_f64();
                    }
                }
                // The filter's side hung up: the stream ended. A last solve over everything.
                if smoother.has_news() {
                    let outcome = smoother.solve_whole();
                    let noise = components(&outcome, &smoother);
                    let solve = judge(outcome, &busy, &gate);
                    let _ = outbox.send(Report { scan, solve, noise });
                }
                busy.log();
                if let Some(path) = graph_out {
                    write_graph(smoother.graph(), &path);
                }
            })?;
        let mut backend = Self {
            to_worker: Some(to_worker),
            from_worker,
            worker: Some(worker),
            feed: Vec::new(),
            handed_over: 0,
            scans_fed: 0,
            scans_reported: 0,
            unpublished: None,
            pending: (takes.solutions || takes.noise).then(VecDeque::new),
            takes,
            torn: TornSolves::default(),
            noise: None,
        };
        for f in feed {
            backend.send(f);
        }
        backend.flush();
        Ok(backend)
    }

    /// Collects `feed` for the back-end (handed over at the next [`flush`](Self::flush)).
    pub fn send(&mut self, feed: Feed) {
        self.scans_fed += u64::from(matches!(feed, Feed::Scan { .. }));
        self.feed.push(feed);
    }

    /// Hands what was collected since the last call to the back-end, in one message
    /// (never waits).
    pub fn flush(&mut self) {
        if self.handed_over == self.feed.len() {
            return;
        }
        let batch = self.feed[self.handed_over..].to_vec();
        self.handed_over = self.feed.len();
        if let Some(to) = &self.to_worker
            && to.send(batch).is_err()
        {
            tracing::warn!("smoothing back-end gone: its input is dropped");
            self.to_worker = None;
        }
    }

    /// Takes one report in.
    fn take(&mut self, report: Report) {
        self.scans_reported = self.scans_reported.max(report.scan);
        if report.noise.is_some() {
            self.noise = report.noise;
        }
        let mut handover = Handover {
            solution: None,
            noise: report.noise.filter(|_| self.takes.noise),
        };
        match report.solve {
            Solve::None => {}
            Solve::Torn => {
                self.torn.count += 1;
                self.torn.newest = true;
            }
            Solve::Good(solution) => {
                self.torn.newest = false;
                handover.solution = self.takes.solutions.then(|| solution.clone());
                self.unpublished = Some(solution);
            }
        }
        if let Some(pending) = &mut self.pending
            && (handover.solution.is_some() || handover.noise.is_some())
        {
            pending.push_back((report.scan, handover));
        }
    }

    /// The newest solution the back-end finished since the last call, if any.
    pub fn latest(&mut self) -> Option<Solution> {
        while let Ok(report) = self.from_worker.try_recv() {
            self.take(report);
        }
        self.unpublished.take()
    }

    /// What the filter takes over now, after `scans_fed` scans: what the scan `delay`
    /// scans ago brought, waiting for the back-end to report that scan if it has not
    /// yet. `None` when the filter takes nothing or that scan brought nothing.
    pub fn due(&mut self, delay: u64) -> Option<Handover> {
        self.pending.as_ref()?;
        let target = self.scans_fed.checked_sub(delay)?;
        if self.scans_reported < target {
            self.flush();
        }
        while self.scans_reported < target {
            match self.from_worker.recv() {
                Ok(report) => self.take(report),
                Err(_) => return None,
            }
        }
        let pending = self.pending.as_mut()?;
        while let Some((scan, _)) = pending.front()
            && *scan < target
        {
            pending.pop_front();
        }
        match pending.front() {
            Some((scan, _)) if *scan == target => pending.pop_front().map(|(_, s)| s),
            _ => None,
        }
    }

    /// The solves withheld as torn, as far as the back-end has reported.
    pub fn torn(&self) -> TornSolves {
        self.torn
    }

    /// The variance components of the newest whole solve reported (`None` before the
    /// first). After [`finish`](Self::finish), those of the last whole solve, which the
    /// data alone decides.
    pub fn noise(&self) -> Option<VarianceComponents> {
        self.noise
    }

    /// Everything fed so far, for a checkpoint.
    pub fn feed(&self) -> &[Feed] {
        &self.feed
    }

    /// Ends the input, waits for the back-end's last solve and returns the newest
    /// solution not yet taken.
    pub fn finish(&mut self) -> Option<Solution> {
        self.flush();
        self.to_worker = None;
        if let Some(worker) = self.worker.take()
            && worker.join().is_err()
        {
            tracing::warn!("smoothing back-end panicked");
        }
        self.latest()
    }
}

/// The variance components of `smoother`'s graph after `outcome`, when it is a whole
/// solve (logged; a failure is logged and gives `None`).
fn components(
    outcome: &fastslam_estimation::Result<Solution>,
    smoother: &Smoother,
) -> Option<VarianceComponents> {
    if !matches!(outcome, Ok(solution) if solution.whole) {
        return None;
    }
    let started = Instant::now();
    match smoother.graph().variance_components() {
        Ok(v) => {
            tracing::info!(
                odometry_scale = v.odometry.scale,
                odometry_redundancy = v.odometry.redundancy,
                sensor_scale = v.landmarks.scale,
                sensor_redundancy = v.landmarks.redundancy,
                rounds = v.rounds,
                seconds = started.elapsed().as_secs_f64(),
                "smoother variance components"
            );
            Some(v)
        }
        Err(e) => {
            tracing::warn!("smoother: no variance components: {e}");
            None
        }
    }
}

/// A solve's outcome, logged and judged by `gate`.
fn judge(
    outcome: fastslam_estimation::Result<Solution>,
    busy: &ScanTimes,
    gate: &TornGate,
) -> Solve {
    match outcome {
        Ok(solution) => {
            let r = &solution.report;
            let fit = &solution.fit;
            tracing::info!(
                solve = solution.solves,
                over = if solution.whole { "whole" } else { "window" },
                scan = busy.times.len() + 1,
                poses = solution.poses.len(),
                landmarks = solution.landmarks.len(),
                fused = solution.fused,
                iterations = r.iterations,
                converged = r.converged,
                chi2_per_dof = fit.chi2_per_dof,
                robust_per_dof = fit.robust_per_dof,
                outlier_share = fit.outlier_share,
                seconds = r.seconds,
                "smoother solved"
            );
            match gate.verdict(fit) {
                None => Solve::Good(solution),
                Some(why) => {
                    tracing::warn!(
                        solve = solution.solves,
                        "smoother: solution torn ({why}): not published, the previous one \
                         stands; the noise model or the associations do not fit this data"
                    );
                    Solve::Torn
                }
            }
        }
        Err(e) => {
            tracing::warn!("smoother: {e}");
            Solve::None
        }
    }
}

/// Writes `graph` as g2o at `path`, saying where or why not.
fn write_graph(graph: &fastslam_estimation::graph::Graph, path: &std::path::Path) {
    match fastslam_estimation::graph::g2o::G2o::from_graph(graph).save(path) {
        Ok(()) => {
            tracing::info!(path = %path.display(), poses = graph.poses.len(), "smoother graph written")
        }
        Err(e) => tracing::warn!(path = %path.display(), "smoother graph not written: {e}"),
    }
}

/// The back-end's time per scan (feeding it in, and the solve it asked for): the figure
/// to hold against the scan period, logged at the end.
#[derive(Debug, Default)]
struct ScanTimes {
    times: Vec<f64>,
}

impl ScanTimes {
    fn add(&mut self, seconds: f64) {
        self.times.push(seconds);
    }

    fn log(mut self) {
        if self.times.is_empty() {
            return;
        }
        self.times.sort_by(f64::total_cmp);
        let ms = |p: f64| percentile(&self.times, p) * 1e3;
        tracing::info!(
            scans = self.times.len(),
            median_ms = ms(50.0),
            p99_ms = ms(99.0),
            max_ms = ms(100.0),
            total_s = self.times.iter().sum::<f64>(),
            "smoother time per scan"
        );
    }
}
