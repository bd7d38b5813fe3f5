//! Sensor deadlines: a stream that delivered nothing for longer than its deadline (wall
//! time) is *quiet*; the service then marks itself degraded and stops waiting for it,
//! until it delivers again.

use std::time::{Duration, Instant};

/// What a [`Watchdog`] saw change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// The stream has just gone quiet.
    WentQuiet,
    /// The quiet stream has just delivered again.
    Returned,
}

/// The deadline of one input stream. It starts with the stream's first delivery: a
/// stream that never delivered is waited for, as before any fault (the service only
/// starts once every input has a publisher).
#[derive(Debug, Clone)]
pub struct Watchdog {
    deadline: Duration,
    last: Option<Instant>,
    quiet: bool,
}

impl Watchdog {
    /// A watchdog declaring the stream quiet after `deadline` without a delivery.
    pub fn new(deadline: Duration) -> Self {
        Self {
            deadline,
            last: None,
            quiet: false,
        }
    }

    /// The stream delivered at `now`; [`Change::Returned`] if it was quiet.
    pub fn heard(&mut self, now: Instant) -> Option<Change> {
        self.last = Some(now);
        std::mem::take(&mut self.quiet).then_some(Change::Returned)
    }

    /// Looks at the clock: [`Change::WentQuiet`] when the deadline has just passed.
    pub fn check(&mut self, now: Instant) -> Option<Change> {
        let overdue = self
            .last
            .is_some_and(|t| now.saturating_duration_since(t) > self.deadline);
        (overdue && !self.quiet).then(|| {
            self.quiet = true;
            Change::WentQuiet
        })
    }

    /// True while the stream is quiet.
    pub fn quiet(&self) -> bool {
        self.quiet
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goes_quiet_after_the_deadline_and_returns_on_delivery() {
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        let mut w = Watchdog::new(Duration::from_millis(100));
        assert_eq!(
            w.check(ms(5000)),
            None,
            "no deadline before the first delivery"
        );
        assert_eq!(w.heard(ms(0)), None);
        assert_eq!(w.check(ms(100)), None);
        assert_eq!(w.check(ms(101)), Some(Change::WentQuiet));
        assert!(w.quiet());
        assert_eq!(w.check(ms(500)), None, "reported once");
        assert_eq!(w.heard(ms(600)), Some(Change::Returned));
        assert!(!w.quiet());
        assert_eq!(w.check(ms(650)), None);
    }
}
