//! The service's wake loop as a type. [`Service`] holds everything that lives from one
//! wake-up to the next; [`Service::wake`] runs the stages of a wake-up, in order: answer
//! map requests, drain odometry, drain end-of-stream, take lidar messages, check
//! deadlines, release the queue, publish the smoothing back-end's news, flush. [`Service::finish`] ends the run. Underneath,
//! [`Core`] applies inputs to the filter and publishes what they produce.
//!
//! The sensors' [`Pace`] decides what a full queue and a silent sensor mean. In real time
//! a full queue drops its oldest input and a sensor silent beyond its deadline is not
//! waited for. As fast as possible neither depends on the wall clock: a stream whose
//! queue is full is not taken from (its samples wait in shared memory, its publisher
//! waits), and no deadline applies.

use crate::admit::Admission;
use crate::checkpoint::{Checkpoint, Floor, ResumeFloor};
use crate::config::ServiceConfig;
use crate::deadline::{Change, Watchdog};
use crate::health::Health;
use crate::inputs::{Inputs, LaneMessage, Lidar};
use crate::outputs::Outputs;
use crate::per_stream::PerStream;
use crate::persist::PersistArgs;
use crate::sequencer::{Input, Place, Pushed, Sequencer};
use crate::slam::{PoseSink, Slam, Step};
use fastslam_protocol::ipc::{Flow, Ipc, Sub, Taken};
use fastslam_protocol::status::RejectionKind;
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::validate::Rejection;
use fastslam_protocol::{Header, Odometry, StreamId};
use std::time::{Duration, Instant};

/// The longest a scan is held back in shared memory waiting for odometry, as a share of
/// the sensors' deadline; then it is queued (a copy). A publisher that sends both streams
/// from one thread could otherwise wait on a full lidar buffer, with the odometry the
/// held scan needs still unsent. Well inside the deadline, so that holding never makes
/// the lidar look quiet.
const HOLD_SHARE_OF_DEADLINE: u32 = 4;

/// How the sensors deliver: what a full queue and a silent sensor mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pace {
    /// At their own rate: a full queue drops its oldest input, deadlines apply.
    RealTime,
    /// As fast as the stack takes their samples: a full queue stops the service taking
    /// that stream, no deadline applies. Nothing is dropped, and the run's result does
    /// not depend on the wall clock.
    AsFastAsPossible,
}

/// The service between wake-ups: the [`Core`], and around it the state of the inputs —
/// their checks, the resume floor, deadlines and stream ends.
pub(crate) struct Service {
    core: Core,
    /// The input checks, with their per-stream state.
    admission: Admission,
    /// Skips the inputs a resumed run's checkpoint already covers.
    floor: ResumeFloor,
    /// The input streams, in the sequencer's order.
    streams: Vec<StreamId>,
    /// Each stream's deadline.
    watchdogs: PerStream<Watchdog>,
    /// Each stream's end: announced, and its last message in.
    ends: PerStream<StreamEnd>,
    /// What hearing from each stream changed during this wake-up (a quiet stream is
    /// back); the deadline check reads and resets it.
    heard: PerStream<Option<Change>>,
    /// The first output error of a scan applied while the lidar was drained; returned
    /// once the drain is over.
    failed: Option<anyhow::Error>,
    /// The sensors' deadline.
    deadline: Duration,
    /// The longest a scan is held in shared memory ([`HOLD_SHARE_OF_DEADLINE`]).
    hold_limit: Duration,
    /// How the sensors deliver.
    pace: Pace,
    /// The streams whose taking stopped at their full queue during this wake-up.
    stopped: PerStream<bool>,
}

impl Service {
    /// The service about to take its first input of `streams` (in the sequencer's
    /// order) from sensors delivering at `pace`: `slam` and `out` continue `resumed`, if
    /// given.
    pub(crate) fn new(
        pace: Pace,
        streams: &[StreamId],
        config: ServiceConfig,
        persist: PersistArgs,
        slam: Slam,
        resumed: Option<&Checkpoint>,
        out: Outputs,
    ) -> Self {
        let admission = Admission::new(streams, &config);
        let deadline = Duration::from_secs_f64(config.input.deadline_s);
        Self {
            admission,
            floor: ResumeFloor::of(resumed, streams),
            streams: streams.to_vec(),
            watchdogs: PerStream::new(streams, |_| Watchdog::new(deadline)),
            ends: PerStream::new(streams, |_| StreamEnd::default()),
            heard: PerStream::new(streams, |_| None),
            failed: None,
            deadline,
            hold_limit: deadline / HOLD_SHARE_OF_DEADLINE,
            pace,
            stopped: PerStream::new(streams, |_| false),
            core: Core::new(streams, config, persist, slam, resumed, out),
        }
    }

    /// The longest a scan is held back in shared memory: the wake loop ticks at least
    /// this often, so the limit is checked in time even with no input waking it.
    pub(crate) fn hold_limit(&self) -> Duration {
        self.hold_limit
    }

    /// One wake-up: every stage, in order.
    ///
    /// # Errors
    /// IPC errors (receiving, publishing).
    pub(crate) fn wake(&mut self, inputs: &Inputs) -> anyhow::Result<Flow> {
        let now = Instant::now();
        self.answer_map_requests()?;
        loop {
            self.stopped.fill(false);
            self.drain_odometry(&inputs.odometry, now)?;
            // Before the lidar: a scan held for odometry goes once the odometry has ended.
            self.drain_end_of_stream(inputs)?;
            self.take_lidar_messages(&inputs.lidar, now)?;
            self.vouch(inputs)?;
            self.check_deadlines(now)?;
            self.core.release_queued()?;
            // A stream stopped at its full queue, which the release emptied, is taken
            // from again now: its publisher may be waiting, and send nothing to wake us.
            let seq = &self.core.sequencer;
            if !self
                .streams
                .iter()
                .any(|&s| self.stopped[s] && !seq.full(s))
            {
                break;
            }
        }
        self.core.health.log.flush(now);
        if let Some(solution) = self.core.slam.smoothed() {
            self.core.out.smoothed(&solution)?;
        }
        self.core.out.flush()?;
        self.core.slam.flush_smoother();
        Ok(if self.finished(&inputs.lidar) {
            Flow::Stop
        } else {
            Flow::Continue
        })
    }

    /// Answers pending `map/get` requests with the map as it is now.
    fn answer_map_requests(&self) -> anyhow::Result<()> {
        self.core.out.answer_map_requests(&self.core.slam)
    }

    /// Takes the odometry messages received ([`Service::take_odometry`]); as fast as
    /// possible, only until the odometry queue is full.
    fn drain_odometry(&mut self, odometry: &Sub<Odometry, ()>, now: Instant) -> anyhow::Result<()> {
        if !self.stops_at_full(StreamId::Odometry) {
            odometry.drain_while(|s| {
                self.take_odometry(*s.payload(), now);
                !self.stops_at_full(StreamId::Odometry)
            })?;
        }
        Ok(())
    }

    /// True when the service takes nothing more of `stream` now, as fast as possible with
    /// its queue full; the stream is then marked stopped.
    fn stops_at_full(&mut self, stream: StreamId) -> bool {
        let stop = self.pace == Pace::AsFastAsPossible && self.core.sequencer.full(stream);
        self.stopped[stream] |= stop;
        stop
    }

    /// As fast as possible: a stream stopped at its full queue while the other streams
    /// have nothing waiting would wait for ever on a publisher that sends its streams in
    /// stamp order from one thread (it waits to send the stopped stream's next sample).
    /// Such a publisher has sent the other streams up to the stopped one's newest stamp:
    /// the sequencer takes them as passed ([`crate::sequencer::Sequencer::vouch`]).
    fn vouch(&mut self, inputs: &Inputs) -> anyhow::Result<()> {
        for k in 0..self.streams.len() {
            let stream = self.streams[k];
            if self.stopped[stream] && !self.others_pending(inputs, stream)? {
                self.core.sequencer.vouch(stream);
            }
        }
        Ok(())
    }

    /// True when samples of a stream other than `stream` wait in its subscriber.
    fn others_pending(&self, inputs: &Inputs, stream: StreamId) -> anyhow::Result<bool> {
        for &other in self.streams.iter().filter(|&&s| s != stream) {
            if inputs.pending(other)? {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// One odometry message: admitted first, then queued.
    fn take_odometry(&mut self, m: Odometry, now: Instant) {
        let admitted = self.admit(StreamId::Odometry, m.header, "odometry", now, |a| {
            a.odometry(&m)
        });
        if admitted {
            let pushed = self.core.sequencer.push(Input::Odometry(m));
            self.core
                .count_pushed(now, "odometry", m.header.seq, pushed);
        }
    }

    /// Takes every end-of-stream received; ends the odometry in the sequencer once its
    /// last message is in.
    fn drain_end_of_stream(&mut self, inputs: &Inputs) -> anyhow::Result<()> {
        inputs.end_of_stream.drain(|s| {
            if let Some(stream) = inputs.closed_by(s.payload().stream) {
                let last = s.payload().header;
                self.ends[stream].announce(s.payload());
                // A stream that ended before the checkpoint was written is not sent again.
                if self.floor.covers(stream, last.stamp_ns) {
                    self.ends[stream].saw(last.seq);
                }
            }
        })?;
        // Before the lidar is taken: a scan held for odometry goes once odometry ended.
        self.end_if_finished(StreamId::Odometry);
        Ok(())
    }

    /// Ends `stream` in the sequencer once its end was announced and its last message
    /// is in.
    fn end_if_finished(&mut self, stream: StreamId) {
        if self.ends[stream].finished() {
            self.core.sequencer.end(stream);
        }
    }

    /// Takes the lidar messages received ([`Service::take_lidar`]) until one is held;
    /// ends the lidar in the sequencer once its last message is in.
    fn take_lidar_messages(&mut self, lidar: &Lidar, now: Instant) -> anyhow::Result<()> {
        let drained = match lidar {
            Lidar::Observations(sub) => sub.drain(|s, held| self.take_lidar(s, held, now)),
            Lidar::Scans(sub) => sub.drain(|s, held| self.take_lidar(s, held, now)),
        };
        drained?;
        if let Some(e) = self.failed.take() {
            return Err(e);
        }
        self.end_if_finished(lidar.stream());
        Ok(())
    }

    /// One lidar message `m`: when new (`held_since` is `None`), admitted first. Then
    /// applied straight from shared memory, held there while it waits for the other
    /// streams (up to the hold limit), or copied into the queue.
    fn take_lidar<M: LaneMessage>(
        &mut self,
        m: &M,
        held_since: Option<Instant>,
        now: Instant,
    ) -> Taken {
        let h = m.header();
        if held_since.is_none() && !self.admit(M::STREAM, h, M::WHAT, now, |a| m.admit(a)) {
            return Taken::Done;
        }
        let held_for = held_since.map_or(Duration::ZERO, |t| now.saturating_duration_since(t));
        match self.core.sequencer.place(M::STREAM, h.stamp_ns) {
            Place::Direct => {
                let applied = (self.core).direct(M::STREAM, h.stamp_ns, |slam, publish| {
                    m.apply(slam, publish)
                });
                self.failed = self.failed.take().or(applied.err());
            }
            // A full queue of another stream waits for this message's stamp: queue it.
            Place::AwaitOthers if held_for < self.hold_limit && !self.others_stopped(M::STREAM) => {
                return Taken::Hold;
            }
            Place::AwaitOthers | Place::Queue if self.stops_at_full(M::STREAM) => {
                return Taken::Hold;
            }
            Place::AwaitOthers | Place::Queue => {
                let pushed = m.queue(&mut self.core.sequencer);
                self.core.count_pushed(now, M::WHAT, h.seq, pushed);
            }
        }
        Taken::Done
    }

    /// True when a stream other than `stream` stopped at its full queue in this wake-up.
    fn others_stopped(&self, stream: StreamId) -> bool {
        self.stopped
            .iter()
            .any(|(s, &stopped)| s != stream && stopped)
    }

    /// A new message of `stream` with header `h`, logged as `what` if rejected: skipped
    /// if the checkpoint covers it or it comes again (counted towards its stream's end
    /// unless it comes again), then checked by
    /// `check`. True when it passed; its stream has then been heard from.
    fn admit(
        &mut self,
        stream: StreamId,
        h: Header,
        what: &str,
        now: Instant,
        check: impl FnOnce(&mut Admission) -> Result<(), Rejection>,
    ) -> bool {
        match self.floor.admits(stream, h) {
            Floor::New { lost } => {
                self.ends[stream].saw(h.seq);
                if lost > 0 {
                    self.core.health.log.lost(what, h.seq, lost);
                }
            }
            Floor::Covered { mark } => {
                self.ends[stream].saw(h.seq);
                if !mark {
                    self.core.health.log.covered();
                }
                return false;
            }
            Floor::ComesAgain => return false,
        }
        if let Err(r) = check(&mut self.admission) {
            self.core.health.log.reject(now, what, h.seq, r.kind(), &r);
            return false;
        }
        self.heard[stream] = self.watchdogs[stream].heard(now).or(self.heard[stream]);
        true
    }

    /// Sensor deadlines, in real time only: a stream quiet beyond its deadline is not
    /// waited for; its return ends that.
    fn check_deadlines(&mut self, now: Instant) -> anyhow::Result<()> {
        let realtime = self.pace == Pace::RealTime;
        for k in 0..self.streams.len() {
            let stream = self.streams[k];
            let heard = self.heard[stream].take();
            let change = heard.or_else(|| {
                realtime
                    .then(|| self.watchdogs[stream].check(now))
                    .flatten()
            });
            if let Some(change) = change {
                self.changed(stream, change)?;
            }
        }
        Ok(())
    }

    /// `stream` went quiet or came back: logged, its checks resynchronised (when quiet),
    /// the sequencer's wait and the filter's coasting (odometry) set, and a status sent.
    fn changed(&mut self, stream: StreamId, change: Change) -> anyhow::Result<()> {
        let quiet = change == Change::WentQuiet;
        if quiet {
            let deadline = self.deadline;
            tracing::warn!(
                ?stream,
                ?deadline,
                "input quiet beyond its deadline: degraded"
            );
            self.admission.resync(stream);
        } else {
            tracing::info!(?stream, "input back: recovered");
        }
        self.core.sequencer.set_quiet(stream, quiet);
        if stream == StreamId::Odometry {
            self.core.slam.set_coasting(quiet);
        }
        let status = self.core.health.now(&self.core.sequencer);
        self.core.out.status(status)
    }

    /// True when every input has ended, everything was applied and no scan is held.
    fn finished(&self, lidar: &Lidar) -> bool {
        self.core.sequencer.finished() && !lidar.holds()
    }

    /// Ends the run (finished, or stopped by a signal): the state goes to disk before
    /// anyone is told; then the final map, grid and status, the outputs' end-of-stream,
    /// and the wait for the readers of the map and grid.
    ///
    /// # Errors
    /// When the checkpoint or map cannot be written, or IPC errors.
    pub(crate) fn finish(self, ipc: &Ipc) -> anyhow::Result<()> {
        let mut core = self.core;
        core.persist.write_checkpoint(|| core.checkpoint())?;
        core.persist.save_map(&core.slam)?;
        let last_ns = core.out.last_pose_ns();
        core.out.map(&core.slam, last_ns)?;
        if let Some(solution) = core.slam.finish_smoothing() {
            core.out.smoothed(&solution)?;
        }
        // After the last solve: grid FastSLAM's map is rendered from it.
        core.out.grid(&mut core.slam, last_ns)?;
        core.health.log.flush_all();
        let status = core.health.final_status(&core.slam, &core.sequencer);
        core.out.status(status)?;
        core.out.finish(ipc)?;
        let moves = core.slam.move_stats().unwrap_or_default();
        tracing::info!(
            steps = core.health.steps(),
            rejections = ?core.health.log.counts(),
            scans = core.scans,
            scans_from_shared_memory = core.direct_scans,
            moves_proposed = moves.proposed,
            moves_accepted = moves.accepted,
            skipped_before_checkpoint = self.floor.skipped(),
            "inputs finished"
        );
        if let Some(bytes) = core.slam.grid_bytes() {
            let mib = bytes as f64 / (1024.0 * 1024.0);
            tracing::info!(
                particles = core.slam.particles(),
                "particle grids hold {mib:.1} MiB"
            );
        }
        Ok(())
    }
}

/// The filter side of the service: the filter, its counters, the input queue and the
/// output ports. It applies inputs in stamp order and publishes what they produce.
struct Core {
    slam: Slam,
    health: Health,
    sequencer: Sequencer,
    out: Outputs,
    config: ServiceConfig,
    persist: PersistArgs,
    /// Scans applied straight from shared memory / all scans applied.
    direct_scans: u64,
    scans: u64,
}

impl Core {
    /// The filter side of a run over `streams`; counters continue `resumed`, if given.
    fn new(
        streams: &[StreamId],
        config: ServiceConfig,
        persist: PersistArgs,
        slam: Slam,
        resumed: Option<&Checkpoint>,
        out: Outputs,
    ) -> Self {
        let mut health = Health::new(
            Duration::from_secs_f64(config.input.log_interval_s),
            config.unknown_association(),
        );
        if let Some(c) = resumed {
            health.resume(c);
        }
        Self {
            slam,
            health,
            sequencer: Sequencer::new(streams, config.input.max_queue),
            out,
            config,
            persist,
            direct_scans: 0,
            scans: 0,
        }
    }

    /// The checkpoint of the state now.
    fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            seed: self.config.filter.seed,
            filter: self.slam.state(),
            last_odometry_ns: self.slam.last_odometry_ns(),
            last_odometry_pose: self.slam.last_odometry_pose(),
            processed_ns: self
                .sequencer
                .released()
                .iter()
                .map(|(s, &t)| (s as u32, t))
                .collect(),
            steps: self.health.steps(),
            resamplings: self.health.resamplings(),
            last_seq: self.out.last_seq(),
            smoother_feed: self.slam.smoother_feed(),
            noise_check: self.health.noise_check(),
            rejections: self.health.log.counts(),
        }
    }

    /// Applies every input the sequencer can release now, in stamp order.
    fn release_queued(&mut self) -> anyhow::Result<()> {
        while let Some(input) = self.sequencer.release() {
            self.apply_queued(input)?;
        }
        Ok(())
    }

    /// Applies an input the sequencer released, then takes its buffer back.
    fn apply_queued(&mut self, input: Input) -> anyhow::Result<()> {
        self.scans += u64::from(!matches!(input, Input::Odometry(_)));
        let stepped = self.step(|slam, publish| slam.apply(&input, publish));
        self.sequencer.recycle(input);
        stepped
    }

    /// Applies a message of `stream` stamped `stamp` that the sequencer would release
    /// next ([`Place::Direct`]) straight from shared memory: first the other streams'
    /// queued inputs the order puts before it, then `step` on the sample's own slice (no
    /// copy).
    fn direct(
        &mut self,
        stream: StreamId,
        stamp: u64,
        step: impl FnOnce(&mut Slam, PoseSink<'_>) -> fastslam_estimation::Result<Step>,
    ) -> anyhow::Result<()> {
        while let Some(input) = self.sequencer.before(stream, stamp) {
            self.apply_queued(input)?;
        }
        self.sequencer.took_directly(stream, stamp);
        self.direct_scans += 1;
        self.scans += 1;
        self.step(|slam, publish| step(slam, publish).map(Some))
    }

    /// Runs one filter input through `apply`, publishing its pose the moment the filter
    /// has it (before the maps are updated, about half-way through a scan's step), then
    /// the rest of what it produced ([`Core::after`]).
    fn step(
        &mut self,
        apply: impl FnOnce(&mut Slam, PoseSink<'_>) -> fastslam_estimation::Result<Option<Step>>,
    ) -> anyhow::Result<()> {
        let started = Instant::now();
        let out = &mut self.out;
        let mut sent = Ok(());
        let applied = apply(&mut self.slam, &mut |pose| sent = out.pose(pose));
        sent?;
        self.after(applied, started)
    }

    /// Publishes what an applied input produced besides its pose (map and grid when due,
    /// status, checkpoint when due), or counts the filter's refusal.
    fn after(
        &mut self,
        applied: fastslam_estimation::Result<Option<Step>>,
        started: Instant,
    ) -> anyhow::Result<()> {
        match applied {
            Ok(Some(step)) => {
                let status =
                    self.health
                        .step(&step, started.elapsed(), &self.slam, &self.sequencer);
                let stamp_ns = step.pose.header.stamp_ns;
                let output = &self.config.output;
                let due = |every: u64| every > 0 && self.health.steps().is_multiple_of(every);
                if due(output.map_every) {
                    self.out.map(&self.slam, stamp_ns)?;
                }
                if due(output.grid_every) {
                    self.out.grid(&mut self.slam, stamp_ns)?;
                }
                if due(output.particles_every) {
                    self.out.particles(&self.slam, stamp_ns)?;
                }
                self.out.status(status)?;
                if self.persist.checkpoint_due(self.health.steps()) {
                    match self.persist.write_checkpoint(|| self.checkpoint()) {
                        Ok(()) => {
                            let covered = self.sequencer.released();
                            let covered = covered.iter().map(|(s, &t)| (s, t));
                            self.out.checkpointed(stamp_ns, covered, false)?;
                        }
                        Err(e) => tracing::warn!("{e:#}"),
                    }
                }
            }
            Ok(None) => {}
            Err(e) => {
                let kind = RejectionKind::Filter;
                self.health.log.reject(Instant::now(), "input", 0, kind, &e);
            }
        }
        Ok(())
    }

    /// Counts `pushed` if the sequencer dropped or refused an input of `what`.
    fn count_pushed(&mut self, now: Instant, what: &str, seq: u64, pushed: Pushed) {
        let (kind, reason) = match pushed {
            Pushed::Queued => return,
            Pushed::Overflowed => (
                RejectionKind::Overflow,
                "queue full: its oldest input was dropped",
            ),
            Pushed::Late => (RejectionKind::Late, "older than inputs already processed"),
        };
        self.health.log.reject(now, what, seq, kind, &reason);
    }
}
