//! The service's bookkeeping of bad input: rejection counters for the status topic, and
//! a log that says why an input was skipped without flooding the log when a publisher
//! keeps sending garbage.

use crate::checkpoint::Checkpoint;
use crate::sequencer::Sequencer;
use crate::slam::{Slam, Step};
use fastslam_estimation::fastslam::{NIS_WINDOW_SCANS, NisWindow, noise_suspect};
use fastslam_protocol::status::{
    REJECTION_KINDS, RejectionKind, ServiceStatus, flags, noise_fit, noise_suspect,
};
use std::time::{Duration, Instant};

/// Everything behind the status message: step counters, rejections, and
/// the last step's filter figures (repeated when a status is sent between steps).
#[derive(Debug)]
pub struct Health {
    steps: u64,
    resamplings: u64,
    /// The rejection counters and their log.
    pub log: RejectionLog,
    last: ServiceStatus,
    /// The noise check's window of innovations.
    nis: NisWindow,
    /// Whether the noise check's warning has been logged.
    warned: bool,
    /// [`flags::UNKNOWN_ASSOCIATION`] when the filter associates without ids, else 0.
    association: u32,
}

impl Health {
    /// Counters at zero; rejections logged once per kind per `log_interval`; every
    /// status flagged [`flags::UNKNOWN_ASSOCIATION`] when `unknown_association`.
    pub fn new(log_interval: Duration, unknown_association: bool) -> Self {
        Self {
            steps: 0,
            resamplings: 0,
            log: RejectionLog::new(log_interval),
            last: ServiceStatus {
                nis: f64::NAN,
                ..ServiceStatus::default()
            },
            nis: NisWindow::new(NIS_WINDOW_SCANS),
            warned: false,
            association: if unknown_association {
                flags::UNKNOWN_ASSOCIATION
            } else {
                0
            },
        }
    }

    /// Continues the counters (steps, resamplings, rejections) and the noise check of a
    /// run resumed from `checkpoint`.
    pub fn resume(&mut self, checkpoint: &Checkpoint) {
        self.steps = checkpoint.steps;
        self.resamplings = checkpoint.resamplings;
        (self.nis, self.warned) = checkpoint.noise_check.clone();
        self.log.counts = checkpoint.rejections;
    }

    /// The noise check's state, for a checkpoint.
    pub fn noise_check(&self) -> (NisWindow, bool) {
        (self.nis.clone(), self.warned)
    }

    /// Observation steps done.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Times the particles were resampled.
    pub fn resamplings(&self) -> u64 {
        self.resamplings
    }

    /// The status after observation step `step`, which took `took`.
    pub fn step(
        &mut self,
        step: &Step,
        took: Duration,
        slam: &Slam,
        seq: &Sequencer,
    ) -> ServiceStatus {
        self.steps += 1;
        self.resamplings += u64::from(step.report.resampled);
        let noise = slam.noise();
        let noise_flags = self.check_noise(step, noise.and_then(|n| n.blames_odometry));
        self.last = ServiceStatus {
            header: step.pose.header,
            steps: self.steps,
            resamplings: self.resamplings,
            n_eff: step.report.neff,
            particles: slam.particles() as u32,
            distinct_particles: step.report.distinct as u32,
            landmarks: slam.landmarks() as u64,
            step_time_ns: took.as_nanos() as u64,
            flags: noise_flags
                | if step.report.resampled {
                    flags::RESAMPLED
                } else {
                    0
                },
            nis_dof: self.nis.dof().min(u64::from(u32::MAX)) as u32,
            nis: self.nis.per_dof(),
            ..ServiceStatus::default()
        };
        self.set_torn(slam);
        self.set_noise(slam);
        self.now(seq)
    }

    /// The noise check (docs/ALGORITHMS.md §1, "Noise check"): adds the step's
    /// innovations to the window, returns the status flags it sets, and logs one warning
    /// the first time the innovations stay above their band for a whole window. The
    /// suspect is the noise fit's (`blames_odometry`) once it has one, else the source
    /// whose term dominates the innovations.
    fn check_noise(&mut self, step: &Step, blames_odometry: Option<bool>) -> u32 {
        self.nis.push(step.report.innovations);
        if !self.nis.sustained_high() {
            return 0;
        }
        let pose = blames_odometry.unwrap_or(self.nis.motion_share() > 0.5);
        if !self.warned {
            self.warned = true;
            let suspect = noise_suspect(pose);
            tracing::warn!(
                nis_per_dof = self.nis.per_dof(),
                scans = NIS_WINDOW_SCANS,
                "noise check: innovations larger than the noise model explains for {NIS_WINDOW_SCANS} scans in a row: {suspect}"
            );
        }
        flags::NIS_HIGH | if pose { flags::NIS_POSE } else { 0 }
    }

    /// Notes in the status the noise fit and the source it blames: the back-end's
    /// variance components once it has reported a whole solve, else the filter's fit to
    /// its innovations with the suspect of the failed NIS check (docs/ALGORITHMS.md §1,
    /// "Noise fit").
    fn set_noise(&mut self, slam: &Slam) {
        let status = &mut self.last;
        let Some(report) = slam.noise() else {
            (status.noise_fit, status.noise_suspect) = (noise_fit::NONE, noise_suspect::NONE);
            return;
        };
        let blames = match slam.noise_components() {
            Some(components) => {
                let [q, r] = components.scales().map(f64::sqrt);
                let p = report.profile;
                status.noise_fitted = [p[0] * q, p[1] * q, p[2] * r, p[3] * r];
                status.noise_fit = noise_fit::SMOOTHER;
                components.blames_odometry()
            }
            None => {
                status.noise_fitted = report.fitted;
                status.noise_fit = noise_fit::INNOVATIONS;
                (status.flags & flags::NIS_HIGH != 0).then_some(status.flags & flags::NIS_POSE != 0)
            }
        };
        status.noise_profile = report.profile;
        status.noise_suspect = match blames {
            None => noise_suspect::NONE,
            Some(true) => noise_suspect::ODOMETRY,
            Some(false) => noise_suspect::SENSOR,
        };
    }

    /// Notes in the status the back-end's solves withheld as torn, as far as it reported
    /// them.
    fn set_torn(&mut self, slam: &Slam) {
        let torn = slam.torn_solves();
        self.last.torn_solves = torn.count;
        self.last.flags &= !flags::SMOOTHED_TORN;
        if torn.newest {
            self.last.flags |= flags::SMOOTHED_TORN;
        }
    }

    /// The status sent at shutdown: [`Health::now`], flagged [`flags::FINAL`] (not a step)
    /// and with the landmark count, torn solves and noise fit as they are now (the
    /// back-end's last solve included).
    pub fn final_status(&mut self, slam: &Slam, seq: &Sequencer) -> ServiceStatus {
        self.set_torn(slam);
        self.set_noise(slam);
        let now = self.now(seq);
        ServiceStatus {
            particles: slam.particles() as u32,
            landmarks: slam.landmarks() as u64,
            flags: now.flags | flags::FINAL,
            ..now
        }
    }

    /// The status now: the last step's figures with the current queues, watermarks,
    /// rejections and quiet streams (the sequencer's: it is what stops waiting for them).
    pub fn now(&self, seq: &Sequencer) -> ServiceStatus {
        let degraded = if seq.lanes().any(|lane| lane.quiet != 0) {
            flags::DEGRADED
        } else {
            0
        };
        let mut status = ServiceStatus {
            flags: (self.last.flags & (flags::RESAMPLED | flags::NIS_HIGH | flags::NIS_POSE))
                | degraded
                | self.association,
            rejections: self.log.counts(),
            ..self.last
        };
        status.set_streams(seq.lanes());
        status
    }
}

/// Counts rejected inputs by kind and logs them, once per kind per interval.
///
/// The first rejection of a kind is logged with its reason; further ones within the
/// interval are only counted, and summarised ("n more … in the last 5 s") by the first
/// rejection or [`RejectionLog::flush`] after the interval has passed.
#[derive(Debug)]
pub struct RejectionLog {
    interval: Duration,
    counts: [u64; REJECTION_KINDS],
    last_logged: [Option<Instant>; REJECTION_KINDS],
    suppressed: [u64; REJECTION_KINDS],
}

impl RejectionLog {
    /// A log that speaks at most once per kind per `interval`.
    pub fn new(interval: Duration) -> Self {
        Self {
            interval,
            counts: [0; REJECTION_KINDS],
            last_logged: [None; REJECTION_KINDS],
            suppressed: [0; REJECTION_KINDS],
        }
    }

    /// Counts one rejected input of `what` (a stream name) at `now`, logging it if no
    /// rejection of this kind was logged within the interval. Returns whether it logged.
    pub fn reject(
        &mut self,
        now: Instant,
        what: &str,
        seq: u64,
        kind: RejectionKind,
        reason: &dyn std::fmt::Display,
    ) -> bool {
        let k = kind as usize;
        self.counts[k] += 1;
        if self.last_logged[k].is_some_and(|t| now.duration_since(t) < self.interval) {
            self.suppressed[k] += 1;
            return false;
        }
        self.summarise(k);
        self.last_logged[k] = Some(now);
        tracing::warn!(seq, %reason, kind = kind.name(), "{what} skipped");
        true
    }

    /// Counts `count` inputs of `what` lost before the one numbered `seq`: a resumed
    /// service needed them and their sensor no longer had them. Always logged.
    pub fn lost(&mut self, what: &str, seq: u64, count: u64) {
        self.counts[RejectionKind::Lost as usize] += count;
        tracing::warn!(
            count,
            before_seq = seq,
            "{what} lost while the service was down: its sensor no longer had them to send again"
        );
    }

    /// Counts one input skipped because the checkpoint a resumed service started from
    /// holds it, other than the mark that begins a resend: not logged one by one (the
    /// service logs the total at the end).
    pub fn covered(&mut self) {
        self.counts[RejectionKind::Covered as usize] += 1;
    }

    /// Logs the summary of every kind with rejections left unlogged, whatever the
    /// interval: at the end of a run.
    pub fn flush_all(&mut self) {
        for k in 0..REJECTION_KINDS {
            self.summarise(k);
        }
    }

    /// Logs the summary of every kind whose interval has passed with rejections left
    /// unlogged; call it now and then (the service does on every wake-up).
    pub fn flush(&mut self, now: Instant) {
        for k in 0..REJECTION_KINDS {
            if self.last_logged[k].is_some_and(|t| now.duration_since(t) >= self.interval)
                && self.suppressed[k] > 0
            {
                self.summarise(k);
                self.last_logged[k] = Some(now);
            }
        }
    }

    /// Rejections so far, indexed by [`RejectionKind`].
    pub fn counts(&self) -> [u64; REJECTION_KINDS] {
        self.counts
    }

    /// Rejections counted but not logged yet, indexed by [`RejectionKind`].
    pub fn pending(&self) -> [u64; REJECTION_KINDS] {
        self.suppressed
    }

    fn summarise(&mut self, k: usize) {
        let n = std::mem::take(&mut self.suppressed[k]);
        if n > 0 {
            let kind = RejectionKind::ALL
                .get(k)
                .map_or("other", |kind| kind.name());
            tracing::warn!(
                "{n} more {kind} rejections in the last {:.0} s",
                self.interval.as_secs_f64()
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logs_once_per_kind_per_interval_and_counts_everything() {
        let t0 = Instant::now();
        let mut log = RejectionLog::new(Duration::from_secs(5));
        let at = |s: u64| t0 + Duration::from_secs(s);
        assert!(log.reject(at(0), "odometry", 1, RejectionKind::NonFinite, &"nan"));
        assert!(!log.reject(at(1), "odometry", 2, RejectionKind::NonFinite, &"nan"));
        assert!(!log.reject(at(2), "odometry", 3, RejectionKind::NonFinite, &"nan"));
        assert!(
            log.reject(at(2), "scan", 4, RejectionKind::Duplicate, &"dup"),
            "another kind has its own interval"
        );
        assert_eq!(log.pending()[RejectionKind::NonFinite as usize], 2);
        log.flush(at(4));
        assert_eq!(
            log.pending()[RejectionKind::NonFinite as usize],
            2,
            "too early"
        );
        log.flush(at(5));
        assert_eq!(log.pending(), [0; REJECTION_KINDS], "summarised");
        assert!(!log.reject(at(6), "odometry", 5, RejectionKind::NonFinite, &"nan"));
        assert!(log.reject(at(11), "odometry", 6, RejectionKind::NonFinite, &"nan"));
        let counts = log.counts();
        assert_eq!(counts[RejectionKind::NonFinite as usize], 5);
        assert_eq!(counts[RejectionKind::Duplicate as usize], 1);
        assert!(!log.reject(at(12), "odometry", 7, RejectionKind::NonFinite, &"nan"));
        log.flush_all();
        assert_eq!(log.pending(), [0; REJECTION_KINDS], "the end says the rest");
    }
}
