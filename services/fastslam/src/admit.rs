//! Admission of inputs: the message checks of `fastslam_protocol::validate`, plus the
//! per-stream state they need (stamp order, sequence numbers, publisher restarts, the
//! last odometry for the teleport check).

use fastslam_protocol::validate::{self, Continuity, MotionLimits, Rejection, StreamCheck};
use fastslam_protocol::{Header, Odometry};

/// The state of both input streams' checks.
#[derive(Debug, Clone)]
pub struct Admission {
    odometry: StreamCheck,
    lidar: StreamCheck,
    last_odometry: Option<Odometry>,
    limits: MotionLimits,
}

impl Admission {
    /// Checks allowing stamp steps up to `max_jump_ns` and odometry within `limits`.
    pub fn new(max_jump_ns: u64, limits: MotionLimits) -> Self {
        Self {
            odometry: StreamCheck::new(max_jump_ns),
            lidar: StreamCheck::new(max_jump_ns),
            last_odometry: None,
            limits,
        }
    }

    /// Admits odometry `m`: finite, in stream order, and plausible motion since the
    /// publisher's previous message (a restarted publisher starts afresh).
    ///
    /// # Errors
    /// The first [`Rejection`]; the streams' state is then unchanged.
    pub fn odometry(&mut self, m: &Odometry) -> Result<(), Rejection> {
        validate::odometry(m)?;
        let mut order = self.odometry.clone();
        let previous = match order.accept(m.header)? {
            Continuity::Continues => self.last_odometry.as_ref(),
            Continuity::Restarted => {
                tracing::info!(seq = m.header.seq, "odometry publisher restarted");
                None
            }
        };
        validate::odometry_motion(m, previous, &self.limits)?;
        self.odometry = order;
        self.last_odometry = Some(*m);
        Ok(())
    }

    /// Admits a lidar message whose content `check` gave, with header `h`.
    ///
    /// # Errors
    /// `check`'s rejection, or the stream-order one.
    pub fn lidar(&mut self, check: Result<(), Rejection>, h: Header) -> Result<(), Rejection> {
        check?;
        if self.lidar.accept(h)? == Continuity::Restarted {
            tracing::info!(seq = h.seq, "lidar publisher restarted");
        }
        Ok(())
    }

    /// The odometry stream went quiet: let its next message jump ahead.
    pub fn resync_odometry(&mut self) {
        self.odometry.resync();
    }

    /// The lidar stream went quiet: let its next message jump ahead.
    pub fn resync_lidar(&mut self) {
        self.lidar.resync();
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
        let mut a = Admission::new(10_000_000_000, MotionLimits::default());
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
    }
}
