//! Admission of inputs: the message checks of `fastslam_protocol::validate`, plus the
//! per-stream state they need (stamp order, sequence numbers, publisher restarts, the
//! last odometry for the teleport check).

use crate::per_stream::PerStream;
use fastslam_protocol::validate::{self, Continuity, MotionLimits, Rejection, StreamCheck};
use fastslam_protocol::{Header, Odometry, StreamId};

/// The state of the input streams' checks.
#[derive(Debug, Clone)]
pub struct Admission {
    /// Each stream's header checks: stamp order, sequence numbers, publisher restarts.
    order: PerStream<StreamCheck>,
    last_odometry: Option<Odometry>,
    limits: MotionLimits,
    max_jump_ns: u64,
}

impl Admission {
    /// Checks of `streams` allowing stamp steps up to `max_jump_ns` and odometry within
    /// `limits`.
    pub fn new(streams: &[StreamId], max_jump_ns: u64, limits: MotionLimits) -> Self {
        Self {
            order: PerStream::new(streams, |_| StreamCheck::new(max_jump_ns)),
            last_odometry: None,
            limits,
            max_jump_ns,
        }
    }

    /// Admits odometry `m`: finite, in stream order, and plausible motion since the
    /// publisher's previous message (a restarted publisher starts afresh).
    ///
    /// # Errors
    /// The first [`Rejection`]; the streams' state is then unchanged.
    pub fn odometry(&mut self, m: &Odometry) -> Result<(), Rejection> {
        validate::odometry(m)?;
        self.first_near(StreamId::Odometry, m.header)?;
        let mut order = self.order[StreamId::Odometry].clone();
        let previous = match order.accept(m.header)? {
            Continuity::Continues => self.last_odometry.as_ref(),
            Continuity::Restarted => {
                tracing::info!(seq = m.header.seq, "odometry publisher restarted");
                None
            }
        };
        validate::odometry_motion(m, previous, &self.limits)?;
        self.order[StreamId::Odometry] = order;
        self.last_odometry = Some(*m);
        Ok(())
    }

    /// Admits a message of `stream` (a sensor's, not odometry) whose content `check`
    /// gave, with header `h`.
    ///
    /// # Errors
    /// `check`'s rejection, or the stream-order one.
    pub fn message(
        &mut self,
        stream: StreamId,
        check: Result<(), Rejection>,
        h: Header,
    ) -> Result<(), Rejection> {
        check?;
        self.first_near(stream, h)?;
        if self.order[stream].accept(h)? == Continuity::Restarted {
            tracing::info!(?stream, seq = h.seq, "publisher restarted");
        }
        Ok(())
    }

    /// A stream's first message has no history to be checked against: it may not lie
    /// further than the stamp-jump limit ahead of the other streams' newest stamp.
    fn first_near(&self, stream: StreamId, h: Header) -> Result<(), Rejection> {
        let others = (self.order.iter())
            .filter(|(s, _)| *s != stream)
            .filter_map(|(_, check)| check.last())
            .max();
        let max_ns = self.max_jump_ns;
        match (self.order[stream].last(), others) {
            (None, Some(previous_ns)) if h.stamp_ns.saturating_sub(previous_ns) > max_ns => {
                Err(Rejection::StampJump {
                    stamp_ns: h.stamp_ns,
                    previous_ns,
                    max_ns,
                })
            }
            _ => Ok(()),
        }
    }

    /// `stream` went quiet: let its next message jump ahead.
    pub fn resync(&mut self, stream: StreamId) {
        self.order[stream].resync();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn odo(t_s: f64, seq: u64, x: f64) -> Odometry {
        Odometry {
            header: Header {
                stamp_ns: (t_s * 1e9) as u64,
                seq,
            },
            v: 1.0,
            x,
            ..Default::default()
        }
    }

    #[test]
    fn a_restarted_odometry_publisher_may_restart_its_dead_reckoning() {
        let streams = [StreamId::Odometry, StreamId::Observations];
        let mut a = Admission::new(&streams, 10_000_000_000, MotionLimits::default());
        assert_eq!(a.odometry(&odo(1.0, 0, 0.0)), Ok(()));
        assert_eq!(a.odometry(&odo(1.1, 1, 0.1)), Ok(()));
        assert!(matches!(
            a.odometry(&odo(1.2, 2, 40.0)),
            Err(Rejection::Teleport { .. })
        ));
        assert!(matches!(
            a.odometry(&odo(1.2, 1, 0.2)),
            Err(Rejection::Duplicate { .. })
        ));
        assert_eq!(a.odometry(&odo(1.2, 2, 0.2)), Ok(()), "state kept");
        // Restarted: seq 0 again, stamp later, dead reckoning from the origin again.
        assert_eq!(a.odometry(&odo(3.0, 0, -40.0)), Ok(()));
        assert_eq!(a.odometry(&odo(3.1, 1, -39.9)), Ok(()));
        let far = Header {
            stamp_ns: u64::MAX / 2,
            seq: 0,
        };
        assert!(
            matches!(
                a.message(StreamId::Observations, Ok(()), far),
                Err(Rejection::StampJump { .. })
            ),
            "a first lidar stamp far ahead of the odometry"
        );
    }
}
