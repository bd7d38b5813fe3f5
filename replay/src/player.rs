//! Publishes a [`DataSet`] the way the sensors that recorded it would have: every stream on
//! its protocol topic, all of them merged into one stamp order, in real time (optionally
//! sped up) or as fast as the consumers take it, then an end-of-stream per stream.
//!
//! One process plays all streams of a data set (like a bag player), so their order on
//! one clock is the data set's and real-time pacing needs no clock shared between
//! processes. The service still treats them as independent streams.

use crate::dataset::DataSet;
use fastslam_protocol::ipc::{Ipc, IpcError, Pub, shutdown};
use fastslam_protocol::{
    EndOfStream, GroundTruth, Header, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation,
    ObservationsHeader, Odometry, StreamId, topics,
};
use std::time::{Duration, Instant};

/// How fast the data set is played.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// As fast as the consumers take it (publishers wait when a buffer is full).
    AsFastAsPossible,
    /// At the data's own pace times `rate` (1 = real time, 2 = twice as fast).
    RealTime {
        /// Speed-up factor, > 0.
        rate: f64,
    },
}

/// The player's output ports.
struct Outputs {
    /// Ground truth and the true map: `None` for a recording without truth, whose client
    /// runs with `--no-truth` and takes neither topic.
    truth: Option<Truth>,
    odometry: Pub<Odometry, ()>,
    laser: Laser,
    eos: Pub<EndOfStream, ()>,
}

/// The ground-truth ports.
struct Truth {
    poses: Pub<GroundTruth, ()>,
    landmarks: Pub<[MapLandmark], LandmarkMapHeader>,
}

/// The laser's port: observations or raw scans, whichever the data set holds.
enum Laser {
    Observations(Pub<[Observation], ObservationsHeader>),
    Scans(Pub<[f32], LaserScanHeader>),
}

/// One message to publish: which stream, and its index in that stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Next {
    /// `data.truth[i]`.
    Truth(usize),
    /// `data.odometry[i]`.
    Odometry(usize),
    /// `data.scans[i]`.
    Scan(usize),
    /// `data.raw_scans[i]`.
    RawScan(usize),
}

/// Every message of `data` in stamp order; on equal stamps truth, then odometry (so the
/// filter predicts up to a scan before it updates), then the scan (observations or raw).
/// The order the player publishes in, and an in-process run replays in.
pub fn schedule(data: &DataSet) -> Vec<(u64, Next)> {
    let mut order: Vec<(u64, Next)> = (data.truth.iter().enumerate())
        .map(|(i, m)| (m.header.stamp_ns, Next::Truth(i)))
        .chain(
            (data.odometry.iter().enumerate()).map(|(i, m)| (m.header.stamp_ns, Next::Odometry(i))),
        )
        .chain(
            (data.scans.iter().enumerate()).map(|(i, s)| (s.header.header.stamp_ns, Next::Scan(i))),
        )
        .chain(
            (data.raw_scans.iter().enumerate())
                .map(|(i, s)| (s.header.header.stamp_ns, Next::RawScan(i))),
        )
        .collect();
    // `Next` orders by variant first (truth < odometry < scans), then by index.
    order.sort_unstable();
    order
}

/// Opens the player's publishers, waits for its consumers, then plays `data`: its raw
/// scans on `scan` where it has any, else its observations on `observations`; ground
/// truth and the true map only when the data set has any (a user's recording has none).
///
/// `consumers` counts the processes that take the sensor streams: 1 = the service alone,
/// 2 = the service and the client, 3 = also the live viewer. Play starts once odometry
/// and the laser's topic have that many subscribers (the client takes the laser too,
/// for latency: counting one would let the client's subscription stand in for a service
/// that is still starting) and the ground truth one fewer (every consumer but the
/// service takes it). Each consumer subscribes to
/// end-of-stream first and to the topic its producer waits on last, so by then every
/// subscription exists and nothing published is lost.
///
/// # Errors
/// IPC failures, a timeout waiting for consumers, or a shutdown signal.
pub fn play(ipc: &Ipc, data: &DataSet, pacing: Pacing, consumers: usize) -> Result<(), IpcError> {
    let out = open(ipc, data)?;
    publish(ipc, &out, data, pacing, consumers)
}

/// [`play`] of `data` once `finish` has completed it: `finish` runs after the publishers
/// exist, so that consumers waiting for them do not time out while it works (the
/// odometry made from a recording's scans). It must not change whether `data` has truth
/// or raw scans.
///
/// # Errors
/// As [`play`].
pub fn play_after(
    ipc: &Ipc,
    data: &mut DataSet,
    finish: impl FnOnce(&mut DataSet),
    pacing: Pacing,
    consumers: usize,
) -> Result<(), IpcError> {
    let out = open(ipc, data)?;
    finish(data);
    publish(ipc, &out, data, pacing, consumers)
}

/// The publishers `data` needs.
fn open(ipc: &Ipc, data: &DataSet) -> Result<Outputs, IpcError> {
    let has_truth = !(data.truth.is_empty() && data.landmarks.is_empty());
    Ok(Outputs {
        truth: match has_truth {
            true => Some(Truth {
                poses: ipc.publisher(&topics::GROUND_TRUTH)?.kept_for_client(ipc)?,
                landmarks: (ipc.slice_publisher(&topics::TRUE_LANDMARKS)?).kept_for_client(ipc)?,
            }),
            false => None,
        },
        odometry: ipc.publisher(&topics::ODOMETRY)?.kept_for_client(ipc)?,
        laser: if data.raw_scans.is_empty() {
            Laser::Observations(
                ipc.slice_publisher(&topics::OBSERVATIONS)?
                    .kept_for_client(ipc)?,
            )
        } else {
            Laser::Scans(ipc.slice_publisher(&topics::SCAN)?.kept_for_client(ipc)?)
        },
        eos: ipc
            .publisher(&topics::END_OF_STREAM)?
            .kept_for_client(ipc)?,
    })
}

/// Waits for `consumers` and publishes `data` on `out` with `pacing`, then the
/// end-of-stream messages.
fn publish(
    ipc: &Ipc,
    out: &Outputs,
    data: &DataSet,
    pacing: Pacing,
    consumers: usize,
) -> Result<(), IpcError> {
    out.odometry.wait_for_subscribers(ipc, consumers)?;
    match &out.laser {
        Laser::Observations(p) => p.wait_for_subscribers(ipc, consumers)?,
        Laser::Scans(p) => p.wait_for_subscribers(ipc, consumers)?,
    }
    if let Some(truth) = &out.truth {
        truth
            .poses
            .wait_for_subscribers(ipc, consumers.saturating_sub(1))?;
    }
    let order = schedule(data);
    let first_ns = order.first().map_or(0, |(stamp, _)| *stamp);
    let send_map = |stamp_ns: u64, seq: u64| {
        let header = LandmarkMapHeader {
            header: Header { stamp_ns, seq },
            count: data.landmarks.len() as u32,
            reserved: 0,
        };
        match &out.truth {
            Some(truth) => truth.landmarks.send(header, &data.landmarks),
            None => Ok(()),
        }
    };
    send_map(first_ns, 0)?;
    tracing::info!(messages = order.len(), ?pacing, "playing");
    let started = Instant::now();
    for (stamp_ns, next) in &order {
        match pacing {
            Pacing::RealTime { rate } => {
                let due = Duration::from_secs_f64((stamp_ns - first_ns) as f64 * 1e-9 / rate);
                ipc.sleep(due.saturating_sub(started.elapsed()))?;
            }
            Pacing::AsFastAsPossible if shutdown::requested() => return Err(IpcError::Shutdown),
            Pacing::AsFastAsPossible => {}
        }
        match (*next, &out.laser) {
            (Next::Truth(i), _) => {
                if let Some(truth) = &out.truth {
                    truth.poses.send(data.truth[i])?;
                }
            }
            (Next::Odometry(i), _) => out.odometry.send(data.odometry[i])?,
            (Next::Scan(i), Laser::Observations(p)) => {
                let scan = &data.scans[i];
                p.send(scan.header, &scan.items)?;
            }
            (Next::RawScan(i), Laser::Scans(p)) => {
                let scan = &data.raw_scans[i];
                p.send(scan.header, &scan.items)?;
            }
            // A data set with raw scans plays those alone.
            (Next::Scan(_), Laser::Scans(_)) | (Next::RawScan(_), Laser::Observations(_)) => {}
        }
    }
    let last_ns = order.last().map_or(0, |(stamp, _)| *stamp);
    send_map(last_ns, 1)?;
    let laser = match &out.laser {
        Laser::Observations(_) => (
            StreamId::Observations,
            data.scans.last().map(|s| s.header.header),
        ),
        Laser::Scans(_) => (
            StreamId::Scan,
            data.raw_scans.last().map(|s| s.header.header),
        ),
    };
    let truth_end = (StreamId::GroundTruth, data.truth.last().map(|m| m.header));
    let sensors = [
        (StreamId::Odometry, data.odometry.last().map(|m| m.header)),
        laser,
    ];
    for (stream, last) in (out.truth.is_some().then_some(truth_end))
        .into_iter()
        .chain(sensors)
    {
        out.eos.send(EndOfStream::new(stream, last))?;
    }
    tracing::info!(
        data_s = (last_ns - first_ns) as f64 * 1e-9,
        wall_s = started.elapsed().as_secs_f64(),
        "data set played"
    );
    // A client that dies now and is started again asks for what it missed.
    ipc.wait_for_client()?;
    // A slice topic's samples live in this process's data segment until each subscriber
    // has received them: a short recording is sent before the service takes its first
    // scan, and would be lost were this process to exit now.
    match &out.laser {
        Laser::Observations(p) => p.wait_until_unsubscribed(ipc)?,
        Laser::Scans(p) => p.wait_until_unsubscribed(ipc)?,
    }
    if let Some(truth) = &out.truth {
        truth.landmarks.wait_until_unsubscribed(ipc)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::Scan;

    #[test]
    fn the_schedule_is_in_stamp_order_with_odometry_before_a_scan_of_the_same_stamp() {
        let at = |stamp_ns| Header { stamp_ns, seq: 0 };
        let data = DataSet {
            odometry: [0, 10, 20]
                .map(|t| Odometry {
                    header: at(t),
                    ..Default::default()
                })
                .to_vec(),
            scans: [10, 15]
                .map(|t| Scan {
                    header: ObservationsHeader {
                        header: at(t),
                        ..Default::default()
                    },
                    items: vec![],
                })
                .to_vec(),
            truth: [5, 10]
                .map(|t| GroundTruth {
                    header: at(t),
                    ..Default::default()
                })
                .to_vec(),
            ..DataSet::default()
        };
        let order: Vec<Next> = schedule(&data).into_iter().map(|(_, n)| n).collect();
        let (t, o, s) = (Next::Truth, Next::Odometry, Next::Scan);
        assert_eq!(order, [o(0), t(0), t(1), o(1), s(0), s(1), o(2)]);
    }
}
