//! What the client and the live viewer subscribe to ([`Inputs`]), in an order that lets
//! the stack start, the lidar's output whichever form it takes ([`Lidar`]), whether the
//! run has ground truth ([`TruthWait`]), and when every stream has ended ([`Ends`]).

use fastslam_protocol::ipc::{Ipc, Sub, WakeSource};
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::{
    EndOfStream, GroundTruth, Header, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation,
    ObservationsHeader, OccupancyGridHeader, Odometry, Particle, ParticlesHeader, PoseEstimate,
    ServiceStatus, StreamId, TrajectoryHeader, TrajectoryPose, topics, validate,
};
use std::time::{Duration, Instant};

/// How long a consumer waits for a ground-truth publisher when it was not told whether
/// the run has ground truth (s).
pub const TRUTH_WAIT_S: f64 = 5.0;

/// Whether a consumer takes ground truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TruthWait {
    /// Never: the run has none.
    Off,
    /// When the `ground_truth` topic has a publisher once the other subscriptions are
    /// open, or gets one within this time; else the run goes on without truth.
    Within(Duration),
}

/// A subscriber to every topic of the stack a consumer records or shows.
pub struct Inputs {
    /// End-of-stream messages.
    pub eos: Sub<EndOfStream, ()>,
    /// The true landmark map (`None` without ground truth).
    pub true_map: Option<Sub<[MapLandmark], LandmarkMapHeader>>,
    /// The service's landmark map.
    pub map: Sub<[MapLandmark], LandmarkMapHeader>,
    /// The service's occupancy grid.
    pub grid: Sub<[i8], OccupancyGridHeader>,
    /// The smoothing back-end's trajectory.
    pub smoothed: Sub<[TrajectoryPose], TrajectoryHeader>,
    /// The smoothing back-end's map.
    pub smoothed_map: Sub<[MapLandmark], LandmarkMapHeader>,
    /// The service's particle cloud (sent only when its `[output] particles_every` asks).
    pub particles: Sub<[Particle], ParticlesHeader>,
    /// The service's status.
    pub status: Sub<ServiceStatus, ()>,
    /// Raw scans or landmark observations.
    pub lidar: Lidar,
    /// Ground truth (`None` without).
    pub truth: Option<Sub<GroundTruth, ()>>,
    /// Odometry.
    pub odometry: Sub<Odometry, ()>,
    /// Pose estimates.
    pub pose: Sub<PoseEstimate, ()>,
}

impl Inputs {
    /// Subscribes to every topic, waiting for each one's publisher; to ground truth and
    /// the true map only as `truth` says.
    ///
    /// # Errors
    /// IPC failures, or a timeout when a topic gets no publisher.
    pub fn open(ipc: &Ipc, truth: TruthWait) -> anyhow::Result<Self> {
        // A producer starts once the subscribers of one topic are there (truth simulator:
        // ground truth; odometry: odometry; lidar: its scans or observations; service: pose),
        // and a short run may be over before a later subscription exists: end-of-stream and
        // each producer's other topics come before the topic it waits on. Ground truth comes
        // last: nothing is published before it has its subscribers (the sensor simulators
        // relay the truth; the replay waits for the truth's subscribers too).
        let eos = ipc.subscriber::<EndOfStream>(&topics::END_OF_STREAM)?;
        let map = ipc.slice_subscriber::<LandmarkMapHeader, MapLandmark>(&topics::MAP)?;
        let grid = ipc.slice_subscriber::<OccupancyGridHeader, i8>(&topics::GRID)?;
        let smoothed =
            ipc.slice_subscriber::<TrajectoryHeader, TrajectoryPose>(&topics::SMOOTHED_TRAJECTORY)?;
        let smoothed_map =
            ipc.slice_subscriber::<LandmarkMapHeader, MapLandmark>(&topics::SMOOTHED_MAP)?;
        let particles = ipc.slice_subscriber::<ParticlesHeader, Particle>(&topics::PARTICLES)?;
        let status = ipc.subscriber::<ServiceStatus>(&topics::STATUS)?;
        let lidar = Lidar::open(ipc)?;
        let odometry = ipc.subscriber::<Odometry>(&topics::ODOMETRY)?;
        let pose = ipc.subscriber::<PoseEstimate>(&topics::POSE)?;
        let (true_map, truth) = if has_truth(ipc, truth)? {
            (
                Some(ipc.slice_subscriber(&topics::TRUE_LANDMARKS)?),
                Some(ipc.subscriber::<GroundTruth>(&topics::GROUND_TRUTH)?),
            )
        } else {
            (None, None)
        };
        Ok(Self {
            eos,
            true_map,
            map,
            grid,
            smoothed,
            smoothed_map,
            particles,
            status,
            lidar,
            truth,
            odometry,
            pose,
        })
    }

    /// Every subscriber, to wake on.
    pub fn sources(&self) -> Vec<&dyn WakeSource> {
        let truth = self.truth.as_ref().map(|s| s as &dyn WakeSource);
        let true_map = self.true_map.as_ref().map(|s| s as &dyn WakeSource);
        let rest: [&dyn WakeSource; 10] = [
            &self.odometry,
            self.lidar.source(),
            &self.status,
            &self.map,
            &self.grid,
            &self.smoothed,
            &self.smoothed_map,
            &self.particles,
            &self.pose,
            &self.eos,
        ];
        truth.into_iter().chain(rest).chain(true_map).collect()
    }

    /// True when the run has ground truth (its topic is subscribed to).
    pub fn ground_truth(&self) -> bool {
        self.truth.is_some()
    }
}

/// Whether to take ground truth, as `wait` says: for [`TruthWait::Within`], whether the
/// topic has a publisher or gets one in time (logging one line when it does not).
fn has_truth(ipc: &Ipc, wait: TruthWait) -> anyhow::Result<bool> {
    let TruthWait::Within(within) = wait else {
        return Ok(false);
    };
    let publishers = ipc.publisher_probe::<GroundTruth, ()>(&topics::GROUND_TRUTH)?;
    let start = Instant::now();
    while publishers() == 0 {
        if start.elapsed() >= within {
            tracing::info!(
                waited_s = within.as_secs_f64(),
                "no ground truth: the ground_truth topic has no publisher; going on without it"
            );
            return Ok(false);
        }
        ipc.sleep(Duration::from_millis(2))?;
    }
    Ok(true)
}

/// The streams a consumer takes until they end, each with its end bookkeeping.
pub struct Ends(Vec<(StreamId, StreamEnd)>);

impl Ends {
    /// The stack's streams, with `lidar` (scans or observations) as the lidar's; ground
    /// truth among them when `truth`.
    pub fn new(lidar: StreamId, truth: bool) -> Self {
        let truth = truth.then_some(StreamId::GroundTruth);
        Self(
            (truth.into_iter())
                .chain([
                    StreamId::Odometry,
                    lidar,
                    StreamId::Pose,
                    StreamId::Map,
                    StreamId::Grid,
                    StreamId::SmoothedTrajectory,
                    StreamId::SmoothedMap,
                    StreamId::Particles,
                    StreamId::Status,
                ])
                .map(|id| (id, StreamEnd::default()))
                .collect(),
        )
    }

    /// The message `seq` of stream `id` was processed.
    pub fn saw(&mut self, id: StreamId, seq: u64) {
        if let Some((_, end)) = self.0.iter_mut().find(|(s, _)| *s == id) {
            end.saw(seq);
        }
    }

    /// Records an end-of-stream message; true when it closes one of these streams.
    pub fn announce(&mut self, eos: &EndOfStream) -> bool {
        let id = StreamId::from_u32(eos.stream);
        match self.0.iter_mut().find(|(s, _)| Some(*s) == id) {
            Some((_, end)) => {
                end.announce(eos);
                true
            }
            None => false,
        }
    }

    /// True once every stream has ended and its last message was processed.
    pub fn finished(&self) -> bool {
        self.0.iter().all(|(_, end)| end.finished())
    }
}

/// The lidar's output, subscribed to only for its stamps (latency): raw scans or landmark
/// observations, whichever has a publisher, scans when both do (as the service chooses).
pub enum Lidar {
    /// Landmark observations.
    Observations(Sub<[Observation], ObservationsHeader>),
    /// Raw scans.
    Scans(Sub<[f32], LaserScanHeader>),
}

impl Lidar {
    /// Waits until the scan or the observation topic has a publisher and subscribes to it.
    ///
    /// # Errors
    /// IPC failures, or a timeout when neither topic gets a publisher.
    pub fn open(ipc: &Ipc) -> anyhow::Result<Self> {
        let scans = ipc.publisher_probe::<[f32], LaserScanHeader>(&topics::SCAN)?;
        let observations =
            ipc.publisher_probe::<[Observation], ObservationsHeader>(&topics::OBSERVATIONS)?;
        ipc.wait_until(
            || "a publisher on scan or observations".into(),
            || scans() + observations() > 0,
        )?;
        Ok(if scans() > 0 {
            Self::Scans(ipc.slice_subscriber(&topics::SCAN)?)
        } else {
            Self::Observations(ipc.slice_subscriber(&topics::OBSERVATIONS)?)
        })
    }

    /// The stream it carries.
    pub fn stream(&self) -> StreamId {
        match self {
            Self::Observations(_) => StreamId::Observations,
            Self::Scans(_) => StreamId::Scan,
        }
    }

    /// The subscriber to wake on.
    pub fn source(&self) -> &dyn WakeSource {
        match self {
            Self::Observations(s) => s,
            Self::Scans(s) => s,
        }
    }

    /// Calls `each` with the header of every pending message and the message.
    ///
    /// # Errors
    /// IPC failures.
    pub fn drain(&self, mut each: impl FnMut(Header, LidarMessage<'_>)) -> anyhow::Result<usize> {
        Ok(match self {
            Self::Observations(s) => s.drain(|m| {
                let header = m.user_header();
                let message = match validate::observations(header, m.payload()) {
                    Ok(()) => LidarMessage::Observations(header, m.payload()),
                    Err(_) => LidarMessage::Invalid,
                };
                each(header.header, message)
            })?,
            Self::Scans(s) => s.drain(|m| {
                let header = m.user_header();
                let message = match validate::laser_scan(header, m.payload()) {
                    Ok(()) => LidarMessage::Scan(header, m.payload()),
                    Err(_) => LidarMessage::Invalid,
                };
                each(header.header, message)
            })?,
        })
    }
}

/// One message of the lidar, as [`Lidar::drain`] hands it on.
pub enum LidarMessage<'a> {
    /// Landmark observations.
    Observations(&'a ObservationsHeader, &'a [Observation]),
    /// A raw scan: its header and its ranges (then intensities).
    Scan(&'a LaserScanHeader, &'a [f32]),
    /// A message that failed validation: only its stamp counts (latency, stream end).
    Invalid,
}
