//! The service's outputs: the pose, status, landmark map, occupancy grid and particle
//! cloud publishers,
//! the `map/get` server, and the sequence numbers each stream continues (also across a
//! resume).

use crate::checkpoint::Checkpoint;
use crate::slam::{Slam, Smoothed};
use fastslam_estimation::graph::Solution;
use fastslam_protocol::ipc::{Ipc, Pub, SliceServer};
use fastslam_protocol::status::ServiceStatus;
use fastslam_protocol::validate;
use fastslam_protocol::{
    Checkpointed, EndOfStream, Header, LandmarkMapHeader, MapLandmark, MapRequest,
    OccupancyGridHeader, Particle, ParticlesHeader, PoseEstimate, StreamId, TrajectoryHeader,
    TrajectoryPose, topics,
};

/// The service's output ports (and the `map/get` server) and the last header sent on each.
pub(crate) struct Outputs {
    pose: Pub<PoseEstimate, ()>,
    map_get: SliceServer<MapRequest, LandmarkMapHeader, MapLandmark>,
    map: Pub<[MapLandmark], LandmarkMapHeader>,
    grid: Pub<[i8], OccupancyGridHeader>,
    smoothed_trajectory: Pub<[TrajectoryPose], TrajectoryHeader>,
    smoothed_map: Pub<[MapLandmark], LandmarkMapHeader>,
    particles: Pub<[Particle], ParticlesHeader>,
    status: Pub<ServiceStatus, ()>,
    checkpoint: Pub<Checkpointed, ()>,
    eos: Pub<EndOfStream, ()>,
    last_pose: Option<Header>,
    last_map: Option<Header>,
    last_grid: Option<Header>,
    last_status: Option<Header>,
    last_smoothed: Option<Header>,
    last_checkpoint: Option<Header>,
    last_particles: Option<Header>,
}

/// Next header of a stream whose last header was `last`.
fn next_header(last: Option<Header>, stamp_ns: u64) -> Header {
    Header {
        stamp_ns,
        seq: last.map_or(0, |h| h.seq + 1),
    }
}

impl Outputs {
    /// Creates the publishers and the `map/get` server.
    pub(crate) fn open(ipc: &Ipc) -> anyhow::Result<Self> {
        Ok(Self {
            // As fast as possible, the pose and status of several steps share a wake-up.
            pose: ipc
                .publisher(&topics::POSE)?
                .coalescing()
                .kept_for_client(ipc)?,
            map_get: ipc.slice_server(&topics::MAP_GET)?,
            map: ipc.slice_publisher(&topics::MAP)?.kept_for_client(ipc)?,
            grid: ipc.slice_publisher(&topics::GRID)?.kept_for_client(ipc)?,
            smoothed_trajectory: (ipc.slice_publisher(&topics::SMOOTHED_TRAJECTORY)?)
                .kept_for_client(ipc)?,
            smoothed_map: (ipc.slice_publisher(&topics::SMOOTHED_MAP)?).kept_for_client(ipc)?,
            particles: ipc
                .slice_publisher(&topics::PARTICLES)?
                .kept_for_client(ipc)?,
            status: ipc
                .publisher(&topics::STATUS)?
                .coalescing()
                .kept_for_client(ipc)?,
            checkpoint: ipc.newest_only_publisher(&topics::CHECKPOINT)?,
            eos: ipc
                .publisher(&topics::END_OF_STREAM)?
                .kept_for_client(ipc)?,
            last_pose: None,
            last_map: None,
            last_grid: None,
            last_status: None,
            last_smoothed: None,
            last_checkpoint: None,
            last_particles: None,
        })
    }

    /// Continues the sequence numbers of the run a checkpoint was taken from.
    pub(crate) fn resume(&mut self, checkpoint: &Checkpoint) {
        let header = |seq: Option<u64>| seq.map(|seq| Header { stamp_ns: 0, seq });
        let [pose, map, grid, status, smoothed, particles] = checkpoint.last_seq;
        self.last_pose = header(pose);
        self.last_map = header(map);
        self.last_grid = header(grid);
        self.last_status = header(status);
        self.last_smoothed = header(smoothed);
        self.last_particles = header(particles);
    }

    /// Waits until the pose has `count` subscribers, so a client that starts late loses
    /// nothing.
    pub(crate) fn wait_for_subscribers(&self, ipc: &Ipc, count: usize) -> anyhow::Result<()> {
        self.pose.wait_for_subscribers(ipc, count)?;
        Ok(())
    }

    /// Sequence numbers last published: pose, map, grid, status, smoothed trajectory and
    /// map (the two smoothed streams share their numbers), particle cloud.
    pub(crate) fn last_seq(&self) -> [Option<u64>; 6] {
        [
            self.last_pose,
            self.last_map,
            self.last_grid,
            self.last_status,
            self.last_smoothed,
            self.last_particles,
        ]
        .map(|h| h.map(|h| h.seq))
    }

    /// Stamp of the last pose published (0 before the first): the final map and grid
    /// carry it.
    pub(crate) fn last_pose_ns(&self) -> u64 {
        self.last_pose.map_or(0, |h| h.stamp_ns)
    }

    /// Publishes a pose, numbered after the last one.
    pub(crate) fn pose(&mut self, mut pose: PoseEstimate) -> anyhow::Result<()> {
        pose.header = next_header(self.last_pose, pose.header.stamp_ns);
        self.pose.send(pose)?;
        self.last_pose = Some(pose.header);
        Ok(())
    }

    /// Publishes the best particle's landmark map, stamped `stamp_ns`.
    pub(crate) fn map(&mut self, slam: &Slam, stamp_ns: u64) -> anyhow::Result<()> {
        let header = next_header(self.last_map, stamp_ns);
        let (h, map) = slam.map(header);
        self.map.send(h, &map)?;
        self.last_map = Some(header);
        Ok(())
    }

    /// Answers pending `map/get` requests with the best particle's map now, under the
    /// header of the last pose published (the estimate the map belongs to).
    pub(crate) fn answer_map_requests(&self, slam: &Slam) -> anyhow::Result<()> {
        let header = self.last_pose.unwrap_or_default();
        let answered = self.map_get.answer(|_| slam.map(header))?;
        if answered > 0 {
            tracing::debug!(answered, "map requests answered");
        }
        Ok(())
    }

    /// Publishes the particle cloud, stamped `stamp_ns`.
    pub(crate) fn particles(&mut self, slam: &Slam, stamp_ns: u64) -> anyhow::Result<()> {
        let header = next_header(self.last_particles, stamp_ns);
        let (h, cloud) = slam.cloud(header);
        self.particles.send(h, &cloud)?;
        self.last_particles = Some(header);
        Ok(())
    }

    /// Publishes the best particle's grid, if raw scans have given one.
    pub(crate) fn grid(&mut self, slam: &mut Slam, stamp_ns: u64) -> anyhow::Result<()> {
        let header = next_header(self.last_grid, stamp_ns);
        let Some((h, cells)) = slam.grid(header) else {
            return Ok(());
        };
        if let Err(reason) = validate::occupancy_grid(&h, &cells) {
            tracing::warn!(%reason, "occupancy grid not published");
            return Ok(());
        }
        self.grid.send(h, &cells)?;
        self.last_grid = Some(header);
        Ok(())
    }

    /// Publishes a smoothing back-end's solution: its trajectory on
    /// `smoothed/trajectory` and its map on `smoothed/map`, under one header (the stamp
    /// of its newest pose).
    pub(crate) fn smoothed(&mut self, solution: &Solution) -> anyhow::Result<()> {
        let stamp_ns = solution.poses.last().map_or(0, |(stamp_ns, _)| *stamp_ns);
        let header = next_header(self.last_smoothed, stamp_ns);
        let Smoothed {
            trajectory: (h, poses),
            map: (map_header, map),
        } = Smoothed::of(solution, header);
        if let Err(reason) = validate::trajectory(&h, &poses)
            .and_then(|()| validate::landmark_map(&map_header, &map))
        {
            tracing::warn!(%reason, "smoothed solution not published");
            return Ok(());
        }
        self.smoothed_map.send(map_header, &map)?;
        self.smoothed_trajectory.send(h, &poses)?;
        self.last_smoothed = Some(header);
        Ok(())
    }

    /// Publishes a status, numbered after the last one.
    pub(crate) fn status(&mut self, mut status: ServiceStatus) -> anyhow::Result<()> {
        status.header = next_header(self.last_status, status.header.stamp_ns);
        self.status.send(status)?;
        self.last_status = Some(status.header);
        Ok(())
    }

    /// Tells the sensors that a checkpoint was written after the step stamped `stamp_ns`,
    /// holding the inputs of each stream up to its stamp in `covered`; with `resume`,
    /// that this service has resumed from it and needs everything after.
    pub(crate) fn checkpointed(
        &mut self,
        stamp_ns: u64,
        covered: impl IntoIterator<Item = (StreamId, u64)>,
        resume: bool,
    ) -> anyhow::Result<()> {
        let header = next_header(self.last_checkpoint, stamp_ns);
        self.checkpoint
            .send(Checkpointed::new(header, covered, resume))?;
        self.last_checkpoint = Some(header);
        Ok(())
    }

    /// Wakes the subscribers of poses and status sent without a wake-up of their own:
    /// before the service sleeps, and at the end.
    pub(crate) fn flush(&self) -> anyhow::Result<()> {
        self.pose.flush()?;
        self.status.flush()?;
        Ok(())
    }

    /// Says the end: flushes, sends the end-of-stream of every output, and waits until
    /// the map and grid have no reader left.
    pub(crate) fn finish(&self, ipc: &Ipc) -> anyhow::Result<()> {
        self.flush()?;
        for (stream, last) in [
            (StreamId::Pose, self.last_pose),
            (StreamId::Map, self.last_map),
            (StreamId::Grid, self.last_grid),
            (StreamId::Status, self.last_status),
            (StreamId::SmoothedTrajectory, self.last_smoothed),
            (StreamId::SmoothedMap, self.last_smoothed),
            (StreamId::Particles, self.last_particles),
        ] {
            self.eos.send(EndOfStream::new(stream, last))?;
        }
        // The map and grid live in growable segments: stay until their readers have them.
        self.map.wait_until_unsubscribed(ipc)?;
        self.grid.wait_until_unsubscribed(ipc)?;
        self.smoothed_trajectory.wait_until_unsubscribed(ipc)?;
        self.smoothed_map.wait_until_unsubscribed(ipc)?;
        self.particles.wait_until_unsubscribed(ipc)?;
        Ok(())
    }
}
