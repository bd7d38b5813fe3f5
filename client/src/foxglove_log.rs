//! The run in Foxglove's well-known schemas (protobuf): one channel per topic on a
//! Foxglove [`Context`], each message logged at its own stamp (simulated or recorded
//! time) to every sink the context has — the `run.mcap` writer ([`crate::mcap`]), the live
//! view's WebSocket server ([`crate::viewer`]), or both. A channel nothing was logged on
//! appears in no MCAP file.
//!
//! | topic | schema | one message per |
//! |---|---|---|
//! | `/pose` | `foxglove.Odometry` | pose estimate, with its (x, y, yaw) covariance |
//! | `/tf` | `foxglove.FrameTransforms` | pose estimate: `map` → `base_link` |
//! | `/trajectory` | `foxglove.PosesInFrame` | the estimated trajectory so far (live view only) |
//! | `/truth` | `foxglove.PoseInFrame` | ground-truth sample |
//! | `/dead_reckoning` | `foxglove.PoseInFrame` | odometry message (its dead-reckoned pose) |
//! | `/map` | `foxglove.SceneUpdate` | landmark map, each landmark its 2σ ellipse |
//! | `/true_map` | `foxglove.SceneUpdate` | true landmark map |
//! | `/grid` | `foxglove.Grid` | occupancy grid (raw-scan runs) |
//! | `/smoothed` | `foxglove.PosesInFrame` | smoothing back-end's solution: its trajectory |
//! | `/smoothed_map` | `foxglove.SceneUpdate` | smoothing back-end's solution: its map |
//! | `/particles` | `foxglove.PosesInFrame` | particle cloud (when the service sends it) |
//! | `/scan` | `foxglove.LaserScan` | raw scan (frame `base_link`) |
//! | `/observations` | `foxglove.SceneUpdate` | landmark observation message (frame `base_link`) |

use fastslam_protocol::message::Message;
use fastslam_protocol::topics::{self, Topic};
use fastslam_protocol::{
    GroundTruth, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation, ObservationsHeader,
    OccupancyGridHeader, Particle, ParticlesHeader, PoseEstimate, TrajectoryHeader, TrajectoryPose,
};
use foxglove::messages::{
    Color, FrameTransform, FrameTransforms, Grid, LaserScan, Odometry, PackedElementField, Pose,
    PoseInFrame, PosesInFrame, Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Timestamp,
    Vector2, Vector3, packed_element_field::NumericType,
};
use foxglove::{Channel, Context};
use std::sync::Arc;

/// The fixed frame the estimate, the truth and the maps are in.
const MAP_FRAME: &str = "map";
/// The robot's frame: the scans and observations are in it.
const ROBOT_FRAME: &str = "base_link";

/// The run's channels on one Foxglove context: a call logs to every sink of the context.
pub struct RunLog {
    pose: Channel<Odometry>,
    tf: Channel<FrameTransforms>,
    trajectory: Channel<PosesInFrame>,
    truth: Channel<PoseInFrame>,
    dead_reckoning: Channel<PoseInFrame>,
    map: Channel<SceneUpdate>,
    true_map: Channel<SceneUpdate>,
    grid: Channel<Grid>,
    smoothed: Channel<PosesInFrame>,
    smoothed_map: Channel<SceneUpdate>,
    particles: Channel<PosesInFrame>,
    scan: Channel<LaserScan>,
    observations: Channel<SceneUpdate>,
    /// The newest stamp logged (ns).
    last_ns: u64,
}

impl RunLog {
    /// The run's channels on `context`.
    pub fn new(context: &Arc<Context>) -> Self {
        let channel = |topic: &str| context.channel_builder(topic);
        Self {
            pose: channel("/pose").build(),
            tf: channel("/tf").build(),
            trajectory: channel("/trajectory").build(),
            truth: channel("/truth").build(),
            dead_reckoning: channel("/dead_reckoning").build(),
            map: channel("/map").build(),
            true_map: channel("/true_map").build(),
            grid: channel("/grid").build(),
            smoothed: channel("/smoothed").build(),
            smoothed_map: channel("/smoothed_map").build(),
            particles: channel("/particles").build(),
            scan: channel("/scan").build(),
            observations: channel("/observations").build(),
            last_ns: 0,
        }
    }

    /// The newest stamp logged so far (ns; 0 before any).
    pub fn last_ns(&self) -> u64 {
        self.last_ns
    }

    /// Logs `message` on `channel` at `stamp_ns`.
    fn log<T: foxglove::Encode>(
        &mut self,
        channel: fn(&Self) -> &Channel<T>,
        message: &T,
        stamp_ns: u64,
    ) {
        self.last_ns = self.last_ns.max(stamp_ns);
        channel(self).log_with_time(message, stamp_ns);
    }

    /// A valid message of `topic` on its channels; the topics without one (status,
    /// checkpoints, end of stream) log nothing.
    pub fn message(&mut self, topic: Topic, message: Message<'_>) {
        match (topic, message) {
            (topics::GROUND_TRUTH, Message::GroundTruth(m)) => self.truth(m),
            (topics::ODOMETRY, Message::Odometry(m)) => self.dead_reckoning(m),
            (topics::OBSERVATIONS, Message::Observations(h, o)) => self.observations(h, o),
            (topics::SCAN, Message::Scan(h, d)) => self.scan(h, d),
            (topics::POSE, Message::Pose(m)) => self.pose(m),
            (topics::MAP, Message::LandmarkMap(h, l)) => self.map(h, l),
            (topics::SMOOTHED_MAP, Message::LandmarkMap(h, l)) => self.smoothed_map(h, l),
            (topics::TRUE_LANDMARKS, Message::LandmarkMap(h, l)) => self.true_map(h, l),
            (topics::GRID, Message::Grid(h, c)) => self.grid(h, c),
            (topics::SMOOTHED_TRAJECTORY, Message::Trajectory(h, p)) => self.smoothed(h, p),
            (topics::PARTICLES, Message::Particles(h, p)) => self.particles(h, p),
            _ => {}
        }
    }

    /// A pose estimate: `/pose` and `/tf`.
    pub fn pose(&mut self, m: &PoseEstimate) {
        let stamp_ns = m.header.stamp_ns;
        let odometry = Odometry {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: MAP_FRAME.into(),
            body_frame_id: ROBOT_FRAME.into(),
            pose: Some(planar(m.x, m.y, m.theta)),
            pose_covariance: covariance_6x6(&m.covariance),
            ..Odometry::default()
        };
        self.log(|s| &s.pose, &odometry, stamp_ns);
        let transform = FrameTransform {
            timestamp: Some(timestamp(stamp_ns)),
            parent_frame_id: MAP_FRAME.into(),
            child_frame_id: ROBOT_FRAME.into(),
            translation: Some(Vector3 {
                x: m.x,
                y: m.y,
                z: 0.0,
            }),
            rotation: Some(yaw(m.theta)),
        };
        let transforms = FrameTransforms {
            transforms: vec![transform],
        };
        self.log(|s| &s.tf, &transforms, stamp_ns);
    }

    /// The estimated trajectory so far, `poses` in stamp order: `/trajectory`, at the
    /// newest pose's stamp.
    pub fn trajectory(&mut self, poses: &[PoseEstimate]) {
        let Some(last) = poses.last() else {
            return;
        };
        let stamp_ns = last.header.stamp_ns;
        let trajectory = PosesInFrame {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: MAP_FRAME.into(),
            poses: poses.iter().map(|p| planar(p.x, p.y, p.theta)).collect(),
        };
        self.log(|s| &s.trajectory, &trajectory, stamp_ns);
    }

    /// A ground-truth sample: `/truth`.
    pub fn truth(&mut self, m: &GroundTruth) {
        let stamp_ns = m.header.stamp_ns;
        self.log(
            |s| &s.truth,
            &pose_in_map(stamp_ns, m.x, m.y, m.theta),
            stamp_ns,
        );
    }

    /// An odometry message's dead-reckoned pose: `/dead_reckoning`.
    pub fn dead_reckoning(&mut self, m: &fastslam_protocol::Odometry) {
        let stamp_ns = m.header.stamp_ns;
        let pose = pose_in_map(stamp_ns, m.x, m.y, m.theta);
        self.log(|s| &s.dead_reckoning, &pose, stamp_ns);
    }

    /// The service's landmark map: `/map`.
    pub fn map(&mut self, header: &LandmarkMapHeader, landmarks: &[MapLandmark]) {
        let stamp_ns = header.header.stamp_ns;
        let update = landmark_scene(stamp_ns, "landmarks", landmarks, RED);
        self.log(|s| &s.map, &update, stamp_ns);
    }

    /// The true landmark map: `/true_map`.
    pub fn true_map(&mut self, header: &LandmarkMapHeader, landmarks: &[MapLandmark]) {
        let stamp_ns = header.header.stamp_ns;
        let update = landmark_scene(stamp_ns, "true_landmarks", landmarks, GREEN);
        self.log(|s| &s.true_map, &update, stamp_ns);
    }

    /// An occupancy grid (validated): `/grid`, one `int8` cell each (−1 unknown, else
    /// 0–100 % occupied), rows along +x from the grid's origin.
    pub fn grid(&mut self, header: &OccupancyGridHeader, cells: &[i8]) {
        let stamp_ns = header.header.stamp_ns;
        let grid = Grid {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: MAP_FRAME.into(),
            pose: Some(planar(
                header.origin_x,
                header.origin_y,
                header.origin_theta,
            )),
            column_count: header.width,
            cell_size: Some(Vector2 {
                x: header.resolution,
                y: header.resolution,
            }),
            row_stride: header.width,
            cell_stride: 1,
            fields: vec![PackedElementField {
                name: "occupancy".into(),
                offset: 0,
                r#type: NumericType::Int8.into(),
            }],
            data: cells.iter().map(|&c| c.to_ne_bytes()[0]).collect(),
        };
        self.log(|s| &s.grid, &grid, stamp_ns);
    }

    /// The smoothing back-end's trajectory: `/smoothed`.
    pub fn smoothed(&mut self, header: &TrajectoryHeader, poses: &[TrajectoryPose]) {
        let stamp_ns = header.header.stamp_ns;
        let trajectory = PosesInFrame {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: MAP_FRAME.into(),
            poses: poses.iter().map(|p| planar(p.x, p.y, p.theta)).collect(),
        };
        self.log(|s| &s.smoothed, &trajectory, stamp_ns);
    }

    /// The smoothing back-end's map: `/smoothed_map`.
    pub fn smoothed_map(&mut self, header: &LandmarkMapHeader, landmarks: &[MapLandmark]) {
        let stamp_ns = header.header.stamp_ns;
        let update = landmark_scene(stamp_ns, "smoothed_landmarks", landmarks, PURPLE);
        self.log(|s| &s.smoothed_map, &update, stamp_ns);
    }

    /// The service's particle cloud (validated): `/particles`, one pose per particle.
    pub fn particles(&mut self, header: &ParticlesHeader, particles: &[Particle]) {
        let stamp_ns = header.header.stamp_ns;
        let cloud = PosesInFrame {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: MAP_FRAME.into(),
            poses: particles
                .iter()
                .map(|p| planar(p.x, p.y, p.theta))
                .collect(),
        };
        self.log(|s| &s.particles, &cloud, stamp_ns);
    }

    /// A raw scan (validated): `/scan`.
    pub fn scan(&mut self, header: &LaserScanHeader, data: &[f32]) {
        let stamp_ns = header.header.stamp_ns;
        let n = header.ranges as usize;
        let scan = LaserScan {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: ROBOT_FRAME.into(),
            pose: Some(planar(0.0, 0.0, 0.0)),
            start_angle: f64::from(header.angle_min),
            end_angle: header.angle_max(),
            ranges: header
                .ranges_of(data)
                .iter()
                .map(|&r| f64::from(r))
                .collect(),
            intensities: data
                .get(n..n + header.intensities as usize)
                .unwrap_or_default()
                .iter()
                .map(|&i| f64::from(i))
                .collect(),
        };
        self.log(|s| &s.scan, &scan, stamp_ns);
    }

    /// A landmark observation message (validated): `/observations`, a small sphere where
    /// each observation puts its landmark.
    pub fn observations(&mut self, header: &ObservationsHeader, observations: &[Observation]) {
        let stamp_ns = header.header.stamp_ns;
        let spheres = observations
            .iter()
            .map(|o| {
                let (s, c) = o.bearing.sin_cos();
                SpherePrimitive {
                    pose: Some(planar(o.range * c, o.range * s, 0.0)),
                    size: Some(Vector3 {
                        x: 0.5,
                        y: 0.5,
                        z: 0.5,
                    }),
                    color: Some(BLUE),
                }
            })
            .collect();
        let update = scene(stamp_ns, ROBOT_FRAME, "observations", spheres);
        self.log(|s| &s.observations, &update, stamp_ns);
    }
}

/// Estimated landmarks and their ellipses, as in the trajectory picture.
const RED: Color = Color {
    r: 0.85,
    g: 0.1,
    b: 0.1,
    a: 0.6,
};
/// The smoothing back-end's landmarks.
const PURPLE: Color = Color {
    r: 0.58,
    g: 0.4,
    b: 0.74,
    a: 0.6,
};
/// True landmarks.
const GREEN: Color = Color {
    r: 0.1,
    g: 0.6,
    b: 0.1,
    a: 0.8,
};
/// Observations.
const BLUE: Color = Color {
    r: 0.1,
    g: 0.3,
    b: 0.9,
    a: 0.8,
};

/// A stamp in nanoseconds as a Foxglove timestamp.
fn timestamp(stamp_ns: u64) -> Timestamp {
    const NS: u64 = 1_000_000_000;
    Timestamp::new(
        u32::try_from(stamp_ns / NS).unwrap_or(u32::MAX),
        (stamp_ns % NS) as u32,
    )
}

/// A rotation by `theta` about z.
fn yaw(theta: f64) -> Quaternion {
    let (s, c) = (theta / 2.0).sin_cos();
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: s,
        w: c,
    }
}

/// A planar (x, y, θ) covariance as the 6×6 (x, y, z, roll, pitch, yaw) one, row-major.
fn covariance_6x6(c: &[f64; 9]) -> Vec<f64> {
    let mut out = vec![0.0; 36];
    for (i, a) in [0, 1, 5].into_iter().enumerate() {
        for (j, b) in [0, 1, 5].into_iter().enumerate() {
            out[6 * a + b] = c[3 * i + j];
        }
    }
    out
}

/// A pose in the plane.
fn planar(x: f64, y: f64, theta: f64) -> Pose {
    Pose {
        position: Some(Vector3 { x, y, z: 0.0 }),
        orientation: Some(yaw(theta)),
    }
}

/// A pose in the map frame at a stamp.
fn pose_in_map(stamp_ns: u64, x: f64, y: f64, theta: f64) -> PoseInFrame {
    PoseInFrame {
        timestamp: Some(timestamp(stamp_ns)),
        frame_id: MAP_FRAME.into(),
        pose: Some(planar(x, y, theta)),
    }
}

/// A scene update that replaces the entity `id` by `spheres` in `frame`.
fn scene(stamp_ns: u64, frame: &str, id: &str, spheres: Vec<SpherePrimitive>) -> SceneUpdate {
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: Some(timestamp(stamp_ns)),
            frame_id: frame.into(),
            id: id.into(),
            spheres,
            ..SceneEntity::default()
        }],
    }
}

/// A landmark map as the entity `id`: each landmark a flat ellipsoid, its 2σ ellipse.
fn landmark_scene(stamp_ns: u64, id: &str, landmarks: &[MapLandmark], color: Color) -> SceneUpdate {
    let spheres = landmarks
        .iter()
        .map(|l| {
            let (major, minor, angle) = crate::plot::ellipse_axes(l);
            // Diameters of the 2σ ellipse; a true landmark (no covariance) a small disc.
            let size = |sigma: f64| (4.0 * sigma).max(0.2);
            SpherePrimitive {
                pose: Some(planar(l.x, l.y, angle)),
                size: Some(Vector3 {
                    x: size(major),
                    y: size(minor),
                    z: 0.05,
                }),
                color: Some(color),
            }
        })
        .collect();
    scene(stamp_ns, MAP_FRAME, id, spheres)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pose_covariance_lands_on_x_y_and_yaw() {
        let c = covariance_6x6(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        let at = |row: usize, col: usize| c[6 * row + col];
        assert_eq!([at(0, 0), at(0, 1), at(0, 5)], [1.0, 2.0, 3.0]);
        assert_eq!([at(1, 0), at(1, 1), at(1, 5)], [4.0, 5.0, 6.0]);
        assert_eq!([at(5, 0), at(5, 1), at(5, 5)], [7.0, 8.0, 9.0]);
        assert_eq!(c.iter().filter(|&&v| v != 0.0).count(), 9);
        assert_eq!(timestamp(3_000_000_007), Timestamp::new(3, 7));
        let q = yaw(std::f64::consts::PI);
        assert!((q.z - 1.0).abs() < 1e-12 && q.w.abs() < 1e-12);
    }
}
