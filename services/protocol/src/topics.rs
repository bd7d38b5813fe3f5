//! Service names. Every name lives under the stack's prefix: `<prefix>/<topic>`, so
//! several stacks (and parallel tests) share a machine without seeing each other.
//!
//! Each topic is a publish–subscribe service plus an event service of the same name;
//! publishers notify the event after each send so subscribers wake without polling.

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
/// [`crate::EndOfStream`] from every publisher of a finite stream.
pub const END_OF_STREAM: Topic = Topic {
    name: "end_of_stream",
    buffer: 16,
    history: 0,
    initial_slice_len: 1,
};

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
