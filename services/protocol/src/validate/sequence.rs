//! Checks of a message against the ones before it on its stream: stamp order, sequence
//! continuity and plausible motion.

use super::*;
use crate::Odometry;

/// Per-stream stamp order: remembers the newest stamp and rejects older ones.
#[derive(Debug, Default, Clone)]
pub struct StampOrder {
    last_ns: Option<u64>,
}

impl StampOrder {
    /// Accepts `stamp_ns` when it is not older than the previous accepted stamp.
    ///
    /// # Errors
    /// [`Rejection::StampBackwards`] otherwise (the stream's state is left unchanged).
    pub fn accept(&mut self, stamp_ns: u64) -> Result<(), Rejection> {
        match self.last_ns {
            Some(previous_ns) if stamp_ns < previous_ns => Err(Rejection::StampBackwards {
                stamp_ns,
                previous_ns,
            }),
            _ => {
                self.last_ns = Some(stamp_ns);
                Ok(())
            }
        }
    }

    /// The newest accepted stamp: the stream's watermark.
    pub fn last(&self) -> Option<u64> {
        self.last_ns
    }
}

/// How a message continued its stream, when [`StreamCheck::accept`] took it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Continuity {
    /// The next message of the same publisher (or the stream's first).
    Continues,
    /// The sequence number went back while the stamp advanced: a restarted publisher,
    /// which numbers its messages from 0 again. Per-publisher state (a dead-reckoned
    /// pose) starts afresh.
    Restarted,
}

/// Per-stream header checks: stamps never go back and never jump further ahead than
/// `max_jump_ns`, sequence numbers never repeat — except that a publisher restart (seq
/// back, stamp forward) is accepted, and after [`StreamCheck::resync`] (the stream went
/// quiet) one jump of any size forward is.
#[derive(Debug, Clone)]
pub struct StreamCheck {
    max_jump_ns: u64,
    last: Option<crate::Header>,
    resync: bool,
}

impl StreamCheck {
    /// A check allowing stamp steps of at most `max_jump_ns`.
    pub fn new(max_jump_ns: u64) -> Self {
        Self {
            max_jump_ns,
            last: None,
            resync: false,
        }
    }

    /// Accepts `h` when it continues the stream (see the type's doc); the stream's
    /// state is updated only then.
    ///
    /// # Errors
    /// [`Rejection::StampBackwards`], [`Rejection::Duplicate`] or
    /// [`Rejection::StampJump`].
    pub fn accept(&mut self, h: crate::Header) -> Result<Continuity, Rejection> {
        let Some(last) = self.last else {
            self.last = Some(h);
            self.resync = false;
            return Ok(Continuity::Continues);
        };
        if h.stamp_ns < last.stamp_ns {
            return Err(Rejection::StampBackwards {
                stamp_ns: h.stamp_ns,
                previous_ns: last.stamp_ns,
            });
        }
        let restarted = h.seq < last.seq && h.stamp_ns > last.stamp_ns;
        if h.seq <= last.seq && !restarted {
            return Err(Rejection::Duplicate {
                seq: h.seq,
                newest: last.seq,
            });
        }
        if !self.resync && h.stamp_ns - last.stamp_ns > self.max_jump_ns {
            return Err(Rejection::StampJump {
                stamp_ns: h.stamp_ns,
                previous_ns: last.stamp_ns,
                max_ns: self.max_jump_ns,
            });
        }
        self.last = Some(h);
        self.resync = false;
        Ok(if restarted {
            Continuity::Restarted
        } else {
            Continuity::Continues
        })
    }

    /// Lets the next message jump ahead by any amount: call it when the stream went
    /// quiet, so a publisher that returns after a long pause is not rejected forever.
    pub fn resync(&mut self) {
        self.resync = true;
    }

    /// The newest accepted stamp: the stream's watermark.
    pub fn last(&self) -> Option<u64> {
        self.last.map(|h| h.stamp_ns)
    }
}

/// Limits of plausible odometry (a vehicle cannot teleport).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionLimits {
    /// Largest plausible |v| (m/s).
    pub max_speed: f64,
    /// Largest plausible |ω| (rad/s).
    pub max_yaw_rate: f64,
    /// Slack on the dead-reckoned position step beyond `max_speed · dt` (m).
    pub pose_slack: f64,
}

impl Default for MotionLimits {
    /// 30 m/s, 10 rad/s, 0.5 m: far beyond any ground robot, far below a teleport.
    fn default() -> Self {
        Self {
            max_speed: 30.0,
            max_yaw_rate: 10.0,
            pose_slack: 0.5,
        }
    }
}

/// Checks odometry `m` (already [`odometry`]-valid) against `limits`, and its
/// dead-reckoned position against `previous`, the stream's last accepted message from
/// the same publisher: the step may be at most `max_speed · dt + pose_slack`.
///
/// # Errors
/// [`Rejection::Teleport`] naming `v`, `omega` or `pose_step`.
pub fn odometry_motion(
    m: &Odometry,
    previous: Option<&Odometry>,
    limits: &MotionLimits,
) -> Result<(), Rejection> {
    for (field, value, limit) in [
        ("v", m.v, limits.max_speed),
        ("omega", m.omega, limits.max_yaw_rate),
    ] {
        if value.abs() > limit {
            return Err(Rejection::Teleport {
                field,
                value,
                limit,
            });
        }
    }
    if let Some(p) = previous {
        let dt = m.header.stamp_ns.saturating_sub(p.header.stamp_ns) as f64 * 1e-9;
        let step = (m.x - p.x).hypot(m.y - p.y);
        let limit = limits.max_speed * dt + limits.pose_slack;
        if step.is_nan() || step > limit {
            return Err(Rejection::Teleport {
                field: "pose_step",
                value: step,
                limit,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamp_order_rejects_going_back_and_keeps_watermark() {
        let mut s = StampOrder::default();
        assert!(s.accept(10).is_ok());
        assert!(s.accept(10).is_ok());
        assert!(s.accept(9).is_err());
        assert_eq!(s.last(), Some(10));
        assert!(s.accept(11).is_ok());
    }

    fn h(stamp_ns: u64, seq: u64) -> crate::Header {
        crate::Header { stamp_ns, seq }
    }

    #[test]
    fn stream_check_rejects_duplicates_backwards_and_far_jumps() {
        let mut s = StreamCheck::new(100);
        assert_eq!(s.accept(h(10, 0)), Ok(Continuity::Continues));
        assert_eq!(
            s.accept(h(10, 1)),
            Ok(Continuity::Continues),
            "equal stamps"
        );
        assert!(matches!(
            s.accept(h(20, 1)),
            Err(Rejection::Duplicate { seq: 1, .. })
        ));
        assert!(matches!(
            s.accept(h(5, 2)),
            Err(Rejection::StampBackwards { .. })
        ));
        assert!(matches!(
            s.accept(h(111, 2)),
            Err(Rejection::StampJump { .. })
        ));
        assert_eq!(s.last(), Some(10), "rejections leave the state alone");
        assert_eq!(s.accept(h(110, 2)), Ok(Continuity::Continues));
    }

    #[test]
    fn stream_check_takes_a_restarted_publisher_and_a_resync() {
        let mut s = StreamCheck::new(100);
        s.accept(h(10, 7)).unwrap();
        assert!(matches!(
            s.accept(h(10, 0)),
            Err(Rejection::Duplicate { .. })
        ));
        assert_eq!(s.accept(h(20, 0)), Ok(Continuity::Restarted));
        assert_eq!(s.accept(h(30, 1)), Ok(Continuity::Continues));
        assert!(s.accept(h(10_000, 2)).is_err());
        s.resync();
        assert_eq!(s.accept(h(10_000, 2)), Ok(Continuity::Continues));
        assert!(s.accept(h(20_000, 3)).is_err(), "one jump per resync");
    }

    #[test]
    fn odometry_motion_rejects_teleports() {
        let limits = MotionLimits::default();
        let at = |t_s: f64, x: f64, v: f64| Odometry {
            header: h((t_s * 1e9) as u64, 0),
            v,
            x,
            ..Default::default()
        };
        let a = at(1.0, 0.0, 1.0);
        assert_eq!(odometry_motion(&a, None, &limits), Ok(()));
        assert_eq!(
            odometry_motion(&at(1.1, 0.1, 1.0), Some(&a), &limits),
            Ok(())
        );
        for (bad, field) in [
            (at(1.1, 50.0, 1.0), "pose_step"),
            (at(1.1, 0.1, 99.0), "v"),
            (at(1.1, f64::NAN, 1.0), "pose_step"),
        ] {
            assert!(
                matches!(odometry_motion(&bad, Some(&a), &limits), Err(Rejection::Teleport { field: f, .. }) if f == field),
                "{field}"
            );
        }
        let spin = Odometry { omega: -11.0, ..a };
        assert!(odometry_motion(&spin, None, &limits).is_err());
    }
}
