//! Admission of inputs: the message checks of `fastslam_protocol::validate`, plus the
//! per-stream state they need (stamp order, sequence numbers, publisher restarts, the
//! last odometry for the teleport check). The service admits every input through it, and
//! so does an in-process run, so both take and refuse the same inputs.

use crate::config::ServiceConfig;
use crate::per_stream::PerStream;
use fastslam_estimation::fastslam::AssociationMode;
use fastslam_protocol::validate::{self, Continuity, MotionLimits, Rejection, StreamCheck};
use fastslam_protocol::{
    Header, LaserScanHeader, Observation, ObservationsHeader, Odometry, StreamId,
};

/// The state of the input streams' checks.
#[derive(Debug, Clone)]
pub struct Admission {
    /// Each stream's header checks: stamp order, sequence numbers, publisher restarts.
    order: PerStream<StreamCheck>,
    last_odometry: Option<Odometry>,
    limits: MotionLimits,
    max_jump_ns: u64,
    /// Observations must carry landmark ids (known association).
    known_ids: bool,
}

impl Admission {
    /// Checks of `streams` with `config`'s limits (`[input]`: stamp steps up to
    /// `max_stamp_jump_s`, odometry within the motion limits), asking for landmark ids
    /// under known association.
    pub fn new(streams: &[StreamId], config: &ServiceConfig) -> Self {
        let max_jump_ns = (config.input.max_stamp_jump_s * 1e9) as u64;
        Self {
            order: PerStream::new(streams, |_| StreamCheck::new(max_jump_ns)),
            last_odometry: None,
            limits: config.input.motion_limits(),
            max_jump_ns,
            known_ids: config.filter.association.mode == AssociationMode::Known,
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

    /// Admits a scan's landmark observations: valid, with usable landmark ids under known
    /// association, and in stream order.
    ///
    /// # Errors
    /// The first [`Rejection`]; the streams' state is then unchanged.
    pub fn observations(
        &mut self,
        h: &ObservationsHeader,
        items: &[Observation],
    ) -> Result<(), Rejection> {
        let check = validate::observations(h, items).and_then(|()| match self.known_ids {
            true => validate::known_ids(items),
            false => Ok(()),
        });
        self.message(StreamId::Observations, check, h.header)
    }

    /// Admits a raw scan with ranges and intensities `data`: readable, and in stream
    /// order.
    ///
    /// # Errors
    /// The first [`Rejection`]; the streams' state is then unchanged.
    pub fn raw_scan(&mut self, h: &LaserScanHeader, data: &[f32]) -> Result<(), Rejection> {
        self.message(StreamId::Scan, validate::laser_scan(h, data), h.header)
    }

    /// Admits a message of `stream` (a sensor's, not odometry) whose content `check`
    /// gave, with header `h`.
    fn message(
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

    /// Checks of odometry and observations allowing stamp steps up to 10 s, under
    /// `mode`.
    fn admission(mode: AssociationMode) -> Admission {
        let mut config = ServiceConfig::default();
        config.input.max_stamp_jump_s = 10.0;
        config.filter.association.mode = mode;
        Admission::new(&[StreamId::Odometry, StreamId::Observations], &config)
    }

    /// A scan at `stamp_ns` numbered `seq` of one observation with landmark id `id`.
    fn scan(stamp_ns: u64, seq: u64, id: i64) -> (ObservationsHeader, [Observation; 1]) {
        let header = ObservationsHeader {
            header: Header { stamp_ns, seq },
            count: 1,
            max_range: 10.0,
            ..Default::default()
        };
        let o = Observation {
            range: 2.0,
            id,
            ..Default::default()
        };
        (header, [o])
    }

    #[test]
    fn a_restarted_odometry_publisher_may_restart_its_dead_reckoning() {
        let mut a = admission(AssociationMode::Unknown);
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
        let (far, items) = scan(u64::MAX / 2, 0, -1);
        assert!(
            matches!(
                a.observations(&far, &items),
                Err(Rejection::StampJump { .. })
            ),
            "a first lidar stamp far ahead of the odometry"
        );
    }

    #[test]
    fn landmark_ids_are_asked_for_under_known_association_only() {
        let (h, anonymous) = scan(1_000_000_000, 0, -1);
        let mut unknown = admission(AssociationMode::Unknown);
        assert_eq!(unknown.observations(&h, &anonymous), Ok(()));
        let mut known = admission(AssociationMode::Known);
        assert!(matches!(
            known.observations(&h, &anonymous),
            Err(Rejection::BadLandmarkId { id: -1, .. })
        ));
        let (_, identified) = scan(1_000_000_000, 0, 3);
        assert_eq!(known.observations(&h, &identified), Ok(()), "state kept");
        assert!(matches!(
            known.observations(&h, &identified),
            Err(Rejection::Duplicate { .. })
        ));
    }
}
