//! A sensor of your own in Rust: a robot driving a circle among four landmarks publishes
//! odometry, landmark observations with their ids and (for the metrics client) its true
//! pose and the true landmarks, then the end of each stream, and stays until its
//! observations and map have been taken.
//! Start the service (known association) and a client under the same prefix, then
//! `FASTSLAM_PREFIX=mine cargo run --release --example publisher`. Only `fastslam-protocol`
//! is needed; `FASTSLAM_IOX_ROOT` names the stack's iceoryx2 root if it has its own.

use fastslam_protocol::ipc::{Ipc, StackConfig};
use fastslam_protocol::*;
use std::f64::consts::PI;

const LANDMARKS: [(f64, f64); 4] = [(0.0, 14.0), (8.0, 6.0), (-8.0, 6.0), (0.0, -4.0)];
const V: f64 = 1.0; // m/s, on a circle of radius 10 m around (0, 10), at 20 Hz
const OMEGA: f64 = 0.1; // rad/s

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let env = |name| std::env::var(name).ok();
    let prefix = env("FASTSLAM_PREFIX").unwrap_or_else(|| "fastslam".into());
    let stack = StackConfig { prefix, root: env("FASTSLAM_IOX_ROOT") };
    let ipc = Ipc::open(&stack, "rust-publisher", std::time::Duration::from_secs(60))?;
    let odometry = ipc.publisher::<Odometry>(&topics::ODOMETRY)?;
    let scans = ipc.slice_publisher::<ObservationsHeader, Observation>(&topics::OBSERVATIONS)?;
    let truth = ipc.publisher::<GroundTruth>(&topics::GROUND_TRUTH)?;
    let true_map =
        ipc.slice_publisher::<LandmarkMapHeader, MapLandmark>(&topics::TRUE_LANDMARKS)?;
    let eos = ipc.publisher::<EndOfStream>(&topics::END_OF_STREAM)?;
    // The service and the client both take odometry and observations, and the service
    // subscribes to its inputs one after the other: wait for both processes on both
    // (the client alone would let the first messages go before the service is there).
    odometry.wait_for_subscribers(&ipc, 2)?; // the service and the client
    scans.wait_for_subscribers(&ipc, 2)?; // the service and the client
    truth.wait_for_subscribers(&ipc, 1)?; // the client
    let landmark = |(id, &(x, y)): (usize, &(f64, f64))| MapLandmark {
        id: id as u64,
        x,
        y,
        ..MapLandmark::default()
    };
    let map: Vec<MapLandmark> = LANDMARKS.iter().enumerate().map(landmark).collect();
    let header = Header::default();
    true_map.send(LandmarkMapHeader { header, count: 4, reserved: 0 }, &map)?;
    let (mut last_pose, mut last_scan) = (None, None);
    for k in 0..1200 {
        let theta = k as f64 * 0.05 * OMEGA; // heading after k periods of 50 ms
        let (x, y) = (10.0 * theta.sin(), 10.0 - 10.0 * theta.cos());
        let header = Header { stamp_ns: k * 50_000_000, seq: k };
        let (v, omega, steering) = (V, OMEGA, 0.0);
        odometry.send(Odometry { header, v, omega, steering, x, y, theta })?;
        truth.send(GroundTruth { header, x, y, theta, v, omega, steering })?;
        last_pose = Some(header);
        if k % 4 == 0 {
            let observe = |(id, &(lx, ly)): (usize, &(f64, f64))| {
                let bearing = ((ly - y).atan2(lx - x) - theta + PI).rem_euclid(2.0 * PI) - PI;
                let (range, diameter, id) = ((lx - x).hypot(ly - y), 0.0, id as i64);
                Observation { range, bearing, diameter, id }
            };
            let seen: Vec<Observation> = LANDMARKS.iter().enumerate().map(observe).collect();
            let header = Header { seq: k / 4, ..header };
            let (count, reserved, max_range, min_bearing, max_bearing) = (4, 0, 30.0, -PI, PI);
            let h =
                ObservationsHeader { header, count, reserved, max_range, min_bearing, max_bearing };
            scans.send(h, &seen)?;
            last_scan = Some(header);
        }
    }
    eos.send(EndOfStream::new(StreamId::Odometry, last_pose))?;
    eos.send(EndOfStream::new(StreamId::GroundTruth, last_pose))?;
    eos.send(EndOfStream::new(StreamId::Observations, last_scan))?;
    // Slice samples live in this process's memory until received: stay until taken.
    scans.wait_until_unsubscribed(&ipc)?;
    true_map.wait_until_unsubscribed(&ipc)?;
    Ok(())
}
