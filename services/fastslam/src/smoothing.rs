//! The smoothing back-end on a thread of its own (docs/ALGORITHMS.md §8.1). The filter's
//! thread hands it every control and every scan's keyed sightings through a channel and
//! never waits for it; the back-end grows its graph ([`Smoother`]), solves when a loop
//! closes, and hands the solutions back through another channel, which the service
//! drains between inputs and publishes.
//!
//! Every input it was given is also kept (the feed), so that a checkpoint can carry it
//! and a resumed service rebuilds the same graph by feeding it again.

use fastslam_estimation::graph::{Feed, NoiseModel, Smoother, SmootherConfig, Solution};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

/// The back-end thread and the two channels to it.
#[derive(Debug)]
pub struct Backend {
    to_worker: Option<Sender<Feed>>,
    from_worker: Receiver<Solution>,
    worker: Option<JoinHandle<()>>,
    /// Everything fed so far, in order (for checkpoints).
    feed: Vec<Feed>,
}

impl Backend {
    /// Starts the back-end with `config` and `noise`, first fed with `feed` (a resumed
    /// run's inputs so far).
    ///
    /// # Errors
    /// When the configuration is invalid or the thread cannot be started.
    pub fn start(
        config: SmootherConfig,
        noise: NoiseModel,
        feed: Vec<Feed>,
    ) -> anyhow::Result<Self> {
        let mut smoother = Smoother::new(config, noise)?;
        let (to_worker, inbox) = channel::<Feed>();
        let (outbox, from_worker) = channel::<Solution>();
        let worker = std::thread::Builder::new()
            .name("smoother".into())
            .spawn(move || {
                for feed in inbox {
                    if smoother.feed(&feed) && !solve_and_send(&mut smoother, &outbox) {
                        return;
                    }
                }
                // The filter's side hung up: the stream ended. A last solve over the rest.
                if smoother.has_news() {
                    solve_and_send(&mut smoother, &outbox);
                }
            })?;
        let mut backend = Self {
            to_worker: Some(to_worker),
            from_worker,
            worker: Some(worker),
            feed: Vec::new(),
        };
        for f in feed {
            backend.send(f);
        }
        Ok(backend)
    }

    /// Hands `feed` to the back-end (never waits).
    pub fn send(&mut self, feed: Feed) {
        if let Some(to) = &self.to_worker
            && to.send(feed.clone()).is_err()
        {
            tracing::warn!("smoothing back-end gone: its input is dropped");
            self.to_worker = None;
        }
        self.feed.push(feed);
    }

    /// The newest solution the back-end finished since the last call, if any.
    pub fn latest(&mut self) -> Option<Solution> {
        self.from_worker.try_iter().last()
    }

    /// Everything fed so far, for a checkpoint.
    pub fn feed(&self) -> &[Feed] {
        &self.feed
    }

    /// Ends the input, waits for the back-end's last solve and returns the newest
    /// solution not yet taken.
    pub fn finish(&mut self) -> Option<Solution> {
        self.to_worker = None;
        if let Some(worker) = self.worker.take()
            && worker.join().is_err()
        {
            tracing::warn!("smoothing back-end panicked");
        }
        self.latest()
    }
}

/// One solve, logged; its solution sent. False when nobody listens any more.
fn solve_and_send(smoother: &mut Smoother, outbox: &Sender<Solution>) -> bool {
    match smoother.solve() {
        Ok(solution) => {
            let r = &solution.report;
            tracing::info!(
                solve = solution.solves,
                poses = solution.poses.len(),
                landmarks = solution.landmarks.len(),
                iterations = r.iterations,
                converged = r.converged,
                chi2_per_dof = solution.chi2_per_dof,
                seconds = r.seconds,
                "smoother solved"
            );
            outbox.send(solution).is_ok()
        }
        Err(e) => {
            tracing::warn!("smoother: {e}");
            true
        }
    }
}
