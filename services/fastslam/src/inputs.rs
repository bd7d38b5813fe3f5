//! The service's inputs: the subscribers of odometry, of the lidar (landmark observations
//! or raw scans) and of end-of-stream, and [`LaneMessage`], the one trait through which
//! the wake loop takes a sensor message of any kind: its stamp, its admission, how it
//! reaches the filter and how it is queued.

use crate::admit::Admission;
use crate::config::LidarInput;
use crate::sequencer::{Input, Pushed, RawScan, Scan, Sequencer};
use crate::slam::{PoseSink, Slam, Step};
use fastslam_protocol::ipc::{HoldingSub, Ipc, Received, Sub, WakeSource};
use fastslam_protocol::validate::Rejection;
use fastslam_protocol::{
    EndOfStream, Header, LaserScanHeader, Observation, ObservationsHeader, Odometry, StreamId,
    topics,
};

/// The service's subscribers. Apart from the service's state ([`crate::service::Service`]),
/// so that draining one of them while the state takes its messages borrows disjoint
/// values.
pub(crate) struct Inputs {
    /// End-of-stream messages of every stream (those of the two inputs count).
    pub(crate) end_of_stream: Sub<EndOfStream, ()>,
    /// Odometry.
    pub(crate) odometry: Sub<Odometry, ()>,
    /// The lidar, whichever kind it sends.
    pub(crate) lidar: Lidar,
}

impl Inputs {
    /// Subscribes to end-of-stream, odometry and the lidar topic `choice` asks for (each
    /// waits for a publisher).
    pub(crate) fn open(ipc: &Ipc, choice: LidarInput) -> anyhow::Result<Self> {
        // End-of-stream before the inputs: a sensor starts once its subscribers are there,
        // and a short stream may end before a later subscription exists.
        let end_of_stream = ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?;
        let odometry = ipc.subscriber::<Odometry>(&topics::ODOMETRY)?;
        let lidar = Lidar::open(ipc, choice)?;
        Ok(Self {
            end_of_stream,
            odometry,
            lidar,
        })
    }

    /// What the wake loop sleeps on.
    pub(crate) fn wake_sources(&self) -> [&dyn WakeSource; 3] {
        [
            &self.odometry,
            self.lidar.wake_source(),
            &self.end_of_stream,
        ]
    }

    /// The input streams, in the sequencer's order: odometry first (on equal stamps the
    /// filter predicts before it updates), then the lidar.
    pub(crate) fn streams(&self) -> [StreamId; 2] {
        [StreamId::Odometry, self.lidar.stream()]
    }

    /// True when samples of `stream` wait in its subscriber (or a scan is held).
    ///
    /// # Errors
    /// IPC errors.
    pub(crate) fn pending(&self, stream: StreamId) -> anyhow::Result<bool> {
        Ok(if stream == StreamId::Odometry {
            self.odometry.pending()?
        } else if stream == self.lidar.stream() {
            self.lidar.pending()?
        } else {
            false
        })
    }

    /// The input stream that an end-of-stream of the wire's `stream` closes, if any.
    pub(crate) fn closed_by(&self, stream: u32) -> Option<StreamId> {
        StreamId::from_u32(stream).filter(|id| self.streams().contains(id))
    }
}

/// The lidar topic the service listens to: landmark observations or raw scans. A scan
/// that arrives before the odometry up to its stamp is held back in shared memory until
/// that odometry is in ([`HoldingSub`]), so it too reaches the filter without a copy.
pub(crate) enum Lidar {
    /// Landmark observations.
    Observations(HoldingSub<[Observation], ObservationsHeader>),
    /// Raw scans (poles are extracted from them).
    Scans(HoldingSub<[f32], LaserScanHeader>),
}

impl Lidar {
    /// Subscribes to the configured lidar topic; `auto` waits until one of the two has a
    /// publisher (and takes `scan` if both have).
    fn open(ipc: &Ipc, choice: LidarInput) -> anyhow::Result<Self> {
        let choice = match choice {
            LidarInput::Auto => {
                let scans = ipc.publisher_probe::<[f32], LaserScanHeader>(&topics::SCAN)?;
                let observations = ipc
                    .publisher_probe::<[Observation], ObservationsHeader>(&topics::OBSERVATIONS)?;
                ipc.wait_until(
                    || "a publisher on scan or observations".into(),
                    || scans() + observations() > 0,
                )?;
                if scans() > 0 {
                    LidarInput::Scan
                } else {
                    LidarInput::Observations
                }
            }
            chosen => chosen,
        };
        Ok(match choice {
            LidarInput::Scan => Self::Scans(ipc.slice_subscriber(&topics::SCAN)?.holding()),
            LidarInput::Auto | LidarInput::Observations => {
                Self::Observations(ipc.slice_subscriber(&topics::OBSERVATIONS)?.holding())
            }
        })
    }

    /// The stream whose end-of-stream closes the lidar input.
    pub(crate) fn stream(&self) -> StreamId {
        match self {
            Self::Observations(_) => StreamId::Observations,
            Self::Scans(_) => StreamId::Scan,
        }
    }

    /// True while a scan is held back.
    pub(crate) fn holds(&self) -> bool {
        match self {
            Self::Observations(sub) => sub.holds(),
            Self::Scans(sub) => sub.holds(),
        }
    }

    /// True while a scan is held or scans wait in the subscriber.
    fn pending(&self) -> anyhow::Result<bool> {
        Ok(match self {
            Self::Observations(sub) => sub.pending()?,
            Self::Scans(sub) => sub.pending()?,
        })
    }

    /// The subscriber, for the wake loop.
    fn wake_source(&self) -> &dyn WakeSource {
        match self {
            Self::Observations(sub) => sub,
            Self::Scans(sub) => sub,
        }
    }
}

/// A sensor message in shared memory, as the wake loop takes it: checked, then applied
/// straight from shared memory or copied into the queue. Adding an input stream is an
/// implementation of this trait, an [`Input`] variant and an estimator method.
pub(crate) trait LaneMessage {
    /// The stream's name in the logs.
    const WHAT: &'static str;

    /// The stream it arrives on.
    const STREAM: StreamId;

    /// Its stamp and sequence number.
    fn header(&self) -> Header;

    /// Admits the message through `admission`: its content and its place in its stream.
    ///
    /// # Errors
    /// Why the message is refused.
    fn admit(&self, admission: &mut Admission) -> Result<(), Rejection>;

    /// One filter step on the message where it lies (no copy).
    ///
    /// # Errors
    /// As [`Slam::apply`].
    fn apply(&self, slam: &mut Slam, publish: PoseSink<'_>) -> fastslam_estimation::Result<Step>;

    /// Copies the message into the sequencer's queue.
    fn queue(&self, sequencer: &mut Sequencer) -> Pushed;
}

impl LaneMessage for Received<[Observation], ObservationsHeader> {
    const WHAT: &'static str = "observations";
    const STREAM: StreamId = StreamId::Observations;

    fn header(&self) -> Header {
        self.user_header().header
    }

    fn admit(&self, admission: &mut Admission) -> Result<(), Rejection> {
        admission.observations(self.user_header(), self.payload())
    }

    fn apply(&self, slam: &mut Slam, publish: PoseSink<'_>) -> fastslam_estimation::Result<Step> {
        slam.observe(self.user_header(), self.payload(), publish)
    }

    fn queue(&self, sequencer: &mut Sequencer) -> Pushed {
        let observations = sequencer.copy_observations(self.payload());
        sequencer.push(Input::Scan(Scan {
            header: *self.user_header(),
            items: observations,
        }))
    }
}

impl LaneMessage for Received<[f32], LaserScanHeader> {
    const WHAT: &'static str = "scan";
    const STREAM: StreamId = StreamId::Scan;

    fn header(&self) -> Header {
        self.user_header().header
    }

    fn admit(&self, admission: &mut Admission) -> Result<(), Rejection> {
        admission.raw_scan(self.user_header(), self.payload())
    }

    fn apply(&self, slam: &mut Slam, publish: PoseSink<'_>) -> fastslam_estimation::Result<Step> {
        let header = self.user_header();
        slam.observe_raw(header, header.ranges_of(self.payload()), publish)
    }

    fn queue(&self, sequencer: &mut Sequencer) -> Pushed {
        let header = *self.user_header();
        let ranges = sequencer.copy_ranges(header.ranges_of(self.payload()));
        sequencer.push(Input::RawScan(RawScan {
            header,
            items: ranges,
        }))
    }
}
