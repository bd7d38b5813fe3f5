//! Service names. Every name lives under the stack's prefix: `<prefix>/<topic>`, so
//! several stacks (and parallel tests) share a machine without seeing each other.
//!
//! Each topic is a publish–subscribe service plus an event service of the same name;
//! publishers notify the event after each send so subscribers wake without polling.
//!
//! [`TABLE`] lists every topic once with what a process needs to take it without naming
//! it: its settings, its stream, its payload type and check, and who publishes it. The
//! processes that take many topics (the bridge, the client, the viewer) iterate it;
//! adding a topic is its constant here, its row in the table and a match arm where its
//! messages are used.

use crate::message::{Fixed, Payload, Slice};
use crate::{StreamId, validate};

/// How a topic's service is set up. Every process opens a topic with the same settings
/// (iceoryx2 refuses to open a service whose settings are incompatible), so they live
/// here and nowhere else.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topic {
    /// Service name below the prefix.
    pub name: &'static str,
    /// Samples a subscriber may hold before the publisher has to wait.
    pub buffer: usize,
    /// Samples kept for subscribers that join later.
    pub history: usize,
    /// First guess of the slice length (slice topics grow by powers of two).
    pub initial_slice_len: usize,
}

/// Publishers per service (the live one plus restarted ones not yet cleaned up).
pub const MAX_PUBLISHERS: usize = 8;
/// Subscribers per service (the stack's processes plus users' own clients).
pub const MAX_SUBSCRIBERS: usize = 8;

/// [`crate::GroundTruth`] from the truth simulator.
pub const GROUND_TRUTH: Topic = Topic {
    name: "ground_truth",
    buffer: 256,
    history: 0,
    initial_slice_len: 1,
};
/// The true landmark map (`LandmarkMapHeader` + `[MapLandmark]`) from the truth
/// simulator, kept in history for late joiners.
pub const TRUE_LANDMARKS: Topic = Topic {
    name: "truth/landmarks",
    buffer: 2,
    history: 1,
    initial_slice_len: 64,
};
/// [`crate::Odometry`] from the odometry sensor.
pub const ODOMETRY: Topic = Topic {
    name: "odometry",
    buffer: 256,
    history: 0,
    initial_slice_len: 1,
};
/// `ObservationsHeader` + `[Observation]` from the landmark sensor.
pub const OBSERVATIONS: Topic = Topic {
    name: "observations",
    buffer: 64,
    history: 0,
    initial_slice_len: 32,
};
/// `LaserScanHeader` + `[f32]` (ranges, then intensities) from a lidar that sends raw
/// scans; the service extracts landmarks from them and builds the occupancy grid.
pub const SCAN: Topic = Topic {
    name: "scan",
    buffer: 64,
    history: 0,
    initial_slice_len: 1024,
};
/// [`crate::PoseEstimate`] from the FastSLAM service.
pub const POSE: Topic = Topic {
    name: "pose",
    buffer: 256,
    history: 0,
    initial_slice_len: 1,
};
/// `LandmarkMapHeader` + `[MapLandmark]`: the best particle's map, from the service.
pub const MAP: Topic = Topic {
    name: "map",
    buffer: 4,
    history: 1,
    initial_slice_len: 64,
};
/// `OccupancyGridHeader` + `[i8]`: the occupancy grid of the best particle, from the
/// service at a low rate; the newest one is kept in history for late joiners.
pub const GRID: Topic = Topic {
    name: "grid",
    buffer: 2,
    history: 1,
    initial_slice_len: 1 << 16,
};
/// `TrajectoryHeader` + `[TrajectoryPose]`: the smoothing back-end's trajectory, from
/// the service after each solve (loop closures, end of stream); the newest is kept in
/// history for late joiners.
pub const SMOOTHED_TRAJECTORY: Topic = Topic {
    name: "smoothed/trajectory",
    buffer: 2,
    history: 1,
    initial_slice_len: 1024,
};
/// `LandmarkMapHeader` + `[MapLandmark]`: the smoothing back-end's map (marginal
/// covariances), published with each [`SMOOTHED_TRAJECTORY`].
pub const SMOOTHED_MAP: Topic = Topic {
    name: "smoothed/map",
    buffer: 2,
    history: 1,
    initial_slice_len: 64,
};
/// `ParticlesHeader` + `[Particle]`: the particle cloud from the FastSLAM service, after
/// every `[output] particles_every` observation steps (off by default: it is large).
pub const PARTICLES: Topic = Topic {
    name: "particles",
    buffer: 16,
    history: 0,
    initial_slice_len: 128,
};
/// [`crate::ServiceStatus`] from the FastSLAM service, after every observation step.
pub const STATUS: Topic = Topic {
    name: "status",
    buffer: 256,
    history: 1,
    initial_slice_len: 1,
};
/// [`crate::Checkpointed`] from the FastSLAM service, after each checkpoint it writes
/// (what the sensors may forget) and once after a resume (what it asks for again). The
/// service never waits on it: a sample that finds a subscriber's buffer full is not
/// delivered to it, so the buffer is ample.
pub const CHECKPOINT: Topic = Topic {
    name: "checkpoint",
    buffer: 16,
    history: 1,
    initial_slice_len: 1,
};
/// [`crate::ClientNotice`] from the client: what it has recorded, and that it was
/// started again. Every process that publishes for the client subscribes once; the
/// client never waits on it, so the buffer is ample, and the newest stays in history for
/// a publisher that starts later.
pub const CLIENT_NOTICE: Topic = Topic {
    name: "client/notice",
    buffer: 64,
    history: 1,
    initial_slice_len: 1,
};
/// [`crate::EndOfStream`] from every publisher of a finite stream.
pub const END_OF_STREAM: Topic = Topic {
    name: "end_of_stream",
    buffer: 16,
    history: 0,
    initial_slice_len: 1,
};

/// Who publishes a topic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Publisher {
    /// A sensor (odometry, lidar) or what stands in for one (a replay): the inputs of the
    /// service.
    Sensor,
    /// The FastSLAM service.
    Service,
    /// The truth simulator (or a replay's reference): what runs are scored against.
    Truth,
    /// Every publisher of a finite stream, for its own stream.
    EachStream,
}

/// One topic as [`TABLE`] lists it.
pub struct TopicRow {
    /// Its service settings.
    pub topic: Topic,
    /// The stream it carries, whose end is announced on [`END_OF_STREAM`]; `None` for a
    /// topic that does not end (the true map, kept in history; checkpoints) and for
    /// [`END_OF_STREAM`] itself.
    pub stream: Option<StreamId>,
    /// Its payload type and the check receivers apply to it.
    pub payload: Payload,
    /// Who publishes it.
    pub publisher: Publisher,
    /// What its messages are, in words, for logs.
    pub what: &'static str,
}

/// Every topic of the stack, in the order a consumer of many drains them: ground truth
/// and the sensors' topics before the service's (a pose's truth and inputs were published
/// before it, so they are in by the time the pose is), then the true map, and the end of
/// stream last.
pub static TABLE: [TopicRow; 14] = [
    TopicRow {
        topic: GROUND_TRUTH,
        stream: Some(StreamId::GroundTruth),
        payload: Payload::GroundTruth(Fixed::checked(validate::ground_truth)),
        publisher: Publisher::Truth,
        what: "ground truth",
    },
    TopicRow {
        topic: ODOMETRY,
        stream: Some(StreamId::Odometry),
        payload: Payload::Odometry(Fixed::checked(validate::odometry)),
        publisher: Publisher::Sensor,
        what: "odometry",
    },
    TopicRow {
        topic: OBSERVATIONS,
        stream: Some(StreamId::Observations),
        payload: Payload::Observations(Slice::checked(validate::observations)),
        publisher: Publisher::Sensor,
        what: "observations",
    },
    TopicRow {
        topic: SCAN,
        stream: Some(StreamId::Scan),
        payload: Payload::Scan(Slice::checked(validate::laser_scan)),
        publisher: Publisher::Sensor,
        what: "scan",
    },
    TopicRow {
        topic: POSE,
        stream: Some(StreamId::Pose),
        payload: Payload::Pose(Fixed::UNCHECKED),
        publisher: Publisher::Service,
        what: "pose",
    },
    TopicRow {
        topic: MAP,
        stream: Some(StreamId::Map),
        payload: Payload::LandmarkMap(Slice::checked(validate::landmark_map)),
        publisher: Publisher::Service,
        what: "map",
    },
    TopicRow {
        topic: GRID,
        stream: Some(StreamId::Grid),
        payload: Payload::Grid(Slice::checked(validate::occupancy_grid)),
        publisher: Publisher::Service,
        what: "grid",
    },
    TopicRow {
        topic: SMOOTHED_TRAJECTORY,
        stream: Some(StreamId::SmoothedTrajectory),
        payload: Payload::Trajectory(Slice::checked(validate::trajectory)),
        publisher: Publisher::Service,
        what: "smoothed trajectory",
    },
    TopicRow {
        topic: SMOOTHED_MAP,
        stream: Some(StreamId::SmoothedMap),
        payload: Payload::LandmarkMap(Slice::checked(validate::landmark_map)),
        publisher: Publisher::Service,
        what: "smoothed map",
    },
    TopicRow {
        topic: PARTICLES,
        stream: Some(StreamId::Particles),
        payload: Payload::Particles(Slice::checked(validate::particles)),
        publisher: Publisher::Service,
        what: "particle cloud",
    },
    TopicRow {
        topic: STATUS,
        stream: Some(StreamId::Status),
        payload: Payload::Status(Fixed::UNCHECKED),
        publisher: Publisher::Service,
        what: "status",
    },
    TopicRow {
        topic: CHECKPOINT,
        stream: None,
        payload: Payload::Checkpointed(Fixed::UNCHECKED),
        publisher: Publisher::Service,
        what: "checkpoint",
    },
    TopicRow {
        topic: TRUE_LANDMARKS,
        stream: None,
        payload: Payload::LandmarkMap(Slice::checked(validate::landmark_map)),
        publisher: Publisher::Truth,
        what: "true map",
    },
    TopicRow {
        topic: END_OF_STREAM,
        stream: None,
        payload: Payload::EndOfStream(Fixed::UNCHECKED),
        publisher: Publisher::EachStream,
        what: "end of stream",
    },
];

/// The row of the topic named `name`, if it is one of the stack's.
pub fn row(name: &str) -> Option<&'static TopicRow> {
    TABLE.iter().find(|r| r.topic.name == name)
}

/// A request–response service (as opposed to a publish–subscribe [`Topic`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RequestResponse {
    /// Service name below the prefix.
    pub name: &'static str,
    /// First guess of the response's slice length (it grows by powers of two).
    pub initial_slice_len: usize,
}

/// `MapRequest` → `LandmarkMapHeader` + `[MapLandmark]`: the best particle's map now,
/// answered by the FastSLAM service.
pub const MAP_GET: RequestResponse = RequestResponse {
    name: "map/get",
    initial_slice_len: 64,
};

/// The full service name of `topic` under `prefix`.
pub fn service_name(prefix: &str, topic: &str) -> String {
    format!("{prefix}/{topic}")
}

/// The service on which the publishers of `topic` send again, to a client started again
/// after a crash, what it had not recorded ([`crate::ClientNotice`]): `<topic>/resend`,
/// with the topic's settings but no history. Its name is made once per call and lives as
/// long as the process (a process opens a handful).
pub fn resend(topic: &Topic) -> Topic {
    Topic {
        name: Box::leak(format!("{}/resend", topic.name).into_boxed_str()),
        history: 0,
        ..*topic
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_topic_and_every_stream_has_one_row() {
        for (i, row) in TABLE.iter().enumerate() {
            assert_eq!(
                TABLE.iter().position(|r| r.topic.name == row.topic.name),
                Some(i),
                "{} listed twice",
                row.topic.name
            );
        }
        let streams: Vec<StreamId> = (0..64).filter_map(StreamId::from_u32).collect();
        assert!(streams.len() >= 11, "{streams:?}");
        for id in streams {
            let rows = TABLE.iter().filter(|r| r.stream == Some(id)).count();
            assert_eq!(rows, 1, "{id:?} is carried by {rows} topics");
        }
        assert_eq!(row("map").map(|r| r.topic), Some(MAP));
        assert!(row("nonsense").is_none());
    }
}
